"""The power analysis that fixes the powered design's number of subjects, read from the paper's
design's committed claims (kong_sim's ``tables/claim_cells.csv``, ``claim_estimates.csv`` and
``claims.csv``), and its check against what the powered design then gave.

A pilot of 5 subjects estimates each cell's SD with a 95 % interval of x0.60-2.87 of its value: an
n computed from the observed SDs is underpowered about half the time (Browne 1995, Stat Med
14:1933). So, per claim (:func:`power_table`):

* the subjects at which it reaches the verdict its estimates lean to with 80 % probability, its
  cells' means and SDs taken as the truth (:func:`aceval.evaluation.verdicts.n_to_decide`), with
  the SDs as observed, at their one-sided 80 % upper confidence limit (:data:`PILOT_UCL`, Browne's
  recommendation) and scaled by :data:`SD_FACTORS` (the sensitivity of n to the SDs);
* the probability of deciding at the powered n, at the observed SDs, at their upper limit and
  averaged over the pilot's uncertainty (``assurance``: :data:`DRAWS` truths drawn from what the
  pilot leaves possible, SD^2 ~ (n - 1) s^2 / chi^2(n - 1), mean ~ its t-interval's distribution;
  O'Hagan & Stevens 2001).

The family is the claims each decidable within :data:`AFFORDABLE_N` at the upper-limit SDs;
:func:`powered_n` is the fewest subjects at which the whole family is decided with
:data:`FAMILY_POWER`, its claims independent (the product of their probabilities; the Bonferroni
inequality's lower bound, valid for any dependence, beside it), at most :data:`AFFORDABLE_N`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.evaluation.verdicts import (
    FAILS,
    HOLDS,
    NEGLIGIBLE,
    arrays_of,
    decide_probability,
    n_to_decide,
    point_leaning,
)

#: the paper's design (Kong's 5 subjects), the powered one, and Ricci's (the paper's 40 children)
PAPER_DESIGN, POWERED_DESIGN, RICCI_DESIGN = "kong_sim", "kong_powered", "ricci_sim"
#: the most subjects a simulated design may cost here (60-100 subjects, about two minutes of
#: workflow each run on 2 cores)
AFFORDABLE_N = 100
#: the one-sided confidence of the pilot SD's upper limit the design is planned on (Browne 1995)
PILOT_UCL = 0.8
#: the SDs scaled by these in the sensitivity columns (a 5-subject SD's 95 % interval is
#: x0.60-2.87 of its value)
SD_FACTORS = (0.6, 1.5, 2.0)
#: the probability with which the powered design decides the whole family
FAMILY_POWER = 0.8
#: truths drawn from the pilot's uncertainty per claim (assurance)
DRAWS = 400
SEED = 7
#: the powered design's subjects (config/powered.yaml), fixed in advance by :func:`powered_n` on
#: the paper's design's committed cells. Not recomputed with every later run of the paper's
#: design: a design is fixed before its data are seen, and power.csv says what the analysis gives
#: on the cells committed now.
POWERED_N = 91


def claim_specs(folder: Path) -> dict:
    """Per claim judged on cells: ``(wide, req, combine, claim)``: the subjects x cells table of
    its values (cells in the claim's order), the cells' requirements as arrays, how they combine
    and the claim's row of claims.csv.
    """
    tables = folder / "tables"
    claims = pd.read_csv(tables / "claims.csv", keep_default_na=False, na_values=[""])
    estimates = pd.read_csv(tables / "claim_estimates.csv")
    cells = pd.read_csv(tables / "claim_cells.csv")
    specs = {}
    for _, claim in claims[claims["cells"] > 0].iterrows():
        own = estimates[estimates["claim"] == claim["claim"]]
        values = cells[cells["claim"] == claim["claim"]]
        wide = values.pivot_table(index="subject", columns="cell", values="value", sort=False)
        wide = wide.reindex(columns=list(own["cell"]))
        specs[claim["claim"]] = (wide, arrays_of(own), claim["combine"], claim)
    return specs


def sd_ucl_factor(n: int, confidence: float = PILOT_UCL) -> float:
    """The one-sided upper confidence limit of an SD from ``n`` values, over the SD itself:
    sqrt((n - 1) / chi^2_{1 - confidence}(n - 1)) (1.557 for 5 values at 80 %).
    """
    from scipy import stats

    return float(np.sqrt((n - 1) / stats.chi2.ppf(1 - confidence, n - 1)))


def decided_probability(mean, sd, req: dict, combine: str, n: int) -> float:
    """P(the claim is decided at ``n`` subjects, whichever way), its cells' means and SDs the
    truth.
    """
    verdicts = (HOLDS, FAILS, NEGLIGIBLE) if combine == "all" else (HOLDS, FAILS)
    return float(sum(decide_probability(mean, sd, req, combine, v, n) for v in verdicts))


def assurance(wide: pd.DataFrame, req: dict, combine: str, n: int, rng) -> float:
    """P(decided at ``n``) averaged over :data:`DRAWS` truths the pilot ``wide`` leaves possible:
    each cell's variance from its scaled inverse chi^2, its mean from its t-distribution
    (independent cells).
    """
    mean, sd, count = wide.mean().to_numpy(), wide.std().to_numpy(), wide.count().to_numpy()
    if not (np.isfinite(sd).all() and (count >= 2).all()):
        return np.nan
    df = count - 1.0
    sigma = sd * np.sqrt(df / rng.chisquare(df, size=(DRAWS, len(mean))))
    mu = mean + sigma / np.sqrt(count) * rng.standard_normal((DRAWS, len(mean)))
    return float(np.mean([decided_probability(m, s, req, combine, n) for m, s in zip(mu, sigma)]))


def _scaled(factor: float) -> str:
    """The column of the n at the SDs scaled by ``factor``: 'n_sd_x1_5'."""
    return f"n_sd_x{factor:g}".replace(".", "_")


def _claim_power(wide, req, combine, leaning: str, design_n: int, rng) -> dict:
    """One claim's n to decide (observed SDs, their upper limit, scaled) and its probabilities of
    deciding at ``design_n``.
    """
    mean, sd = wide.mean().to_numpy(), wide.std().to_numpy()
    ucl = sd * sd_ucl_factor(int(wide.count().min()))
    row = {"n_to_decide": np.nan, "n_at_sd_ucl": np.nan}
    row |= {_scaled(f): np.nan for f in SD_FACTORS}
    if leaning:
        row["n_to_decide"] = n_to_decide(mean, sd, req, combine, leaning)
        row["n_at_sd_ucl"] = n_to_decide(mean, ucl, req, combine, leaning)
        for f in SD_FACTORS:
            row[_scaled(f)] = n_to_decide(mean, sd * f, req, combine, leaning)
    finite = np.isfinite(sd).all()
    row["p_decide"] = decided_probability(mean, sd, req, combine, design_n) if finite else np.nan
    row["p_decide_sd_ucl"] = (
        decided_probability(mean, ucl, req, combine, design_n) if finite else np.nan
    )
    row["assurance"] = assurance(wide, req, combine, design_n, rng)
    return row


def power_table(folder: Path, design_n: int = POWERED_N) -> pd.DataFrame:
    """Per claim of the paper's design: its verdict, the way its estimates lean, the subjects that
    would decide it (:func:`_claim_power`), its probabilities of being decided at ``design_n``
    and whether it is in the family (``affordable``: decidable within :data:`AFFORDABLE_N` at the
    upper-limit SDs).
    """
    rows = []
    rng = np.random.default_rng(SEED)
    for key, (wide, req, combine, claim) in claim_specs(folder).items():
        leaning = point_leaning(wide.mean().to_numpy(), req, combine)
        power = _claim_power(wide, req, combine, leaning, design_n, rng)
        rows.append(
            {
                "claim": key,
                "objective": claim["objective"],
                "n": len(wide),
                "verdict": claim["verdict"],
                "estimates_lean": leaning,
                **power,
                "affordable": bool(
                    np.isfinite(power["n_at_sd_ucl"]) and power["n_at_sd_ucl"] <= AFFORDABLE_N
                ),
            }
        )
    return pd.DataFrame(rows)


def family(folder: Path) -> list[tuple]:
    """The family: per claim with a leaning whose n at the upper-limit SDs is at most
    :data:`AFFORDABLE_N`, ``(mean, sd, sd at its upper limit, req, combine)``.
    """
    members = []
    for wide, req, combine, _ in claim_specs(folder).values():
        mean, sd = wide.mean().to_numpy(), wide.std().to_numpy()
        leaning = point_leaning(mean, req, combine)
        if not leaning or not np.isfinite(sd).all():
            continue
        ucl = sd * sd_ucl_factor(int(wide.count().min()))
        if n_to_decide(mean, ucl, req, combine, leaning) <= AFFORDABLE_N:
            members.append((mean, sd, ucl, req, combine))
    return members


def family_power(members: list[tuple], n: int, planned: str = "ucl") -> tuple[float, float]:
    """``(product, lower bound)`` of the family's (:func:`family`) joint probability of being
    decided at ``n``, the SDs at their upper limit (``planned`` 'ucl') or as observed
    ('observed'): the product holds for independent claims, 1 - sum(1 - P) for any dependence.
    """
    p = np.array(
        [
            decided_probability(mean, ucl if planned == "ucl" else sd, req, combine, n)
            for mean, sd, ucl, req, combine in members
        ]
    )
    p = np.clip(p, 0.0, 1.0)
    return float(np.prod(p)), float(max(0.0, 1.0 - np.sum(1.0 - p)))


def powered_n(members: list[tuple]) -> int:
    """The fewest subjects, at most :data:`AFFORDABLE_N`, at which the family (:func:`family`) is
    decided with :data:`FAMILY_POWER` (independent claims, upper-limit SDs); :data:`AFFORDABLE_N`
    when none.
    """
    low, high = 2, AFFORDABLE_N
    if family_power(members, high)[0] < FAMILY_POWER:
        return AFFORDABLE_N
    while high - low > 1:  # the joint probability grows with n
        middle = (low + high) // 2
        enough = family_power(members, middle)[0] >= FAMILY_POWER
        low, high = (low, middle) if enough else (middle, high)
    return high


def family_table(members: list[tuple], sizes) -> pd.DataFrame:
    """The family's joint probability of being decided at each of ``sizes``
    (:func:`family_power`), the SDs as observed and at their upper limit.
    """
    rows = []
    for n in sizes:
        observed, observed_bound = family_power(members, n, "observed")
        ucl, ucl_bound = family_power(members, n, "ucl")
        rows.append(
            {
                "n": n,
                "claims": len(members),
                "joint_observed_sd": observed,
                "joint_observed_sd_any_dependence": observed_bound,
                "joint_sd_ucl": ucl,
                "joint_sd_ucl_any_dependence": ucl_bound,
            }
        )
    return pd.DataFrame(rows)


def prediction_check(power: pd.DataFrame, powered: Path) -> pd.DataFrame:
    """What the power analysis said of each claim beside what the powered design gave
    (``powered``: its folder): the pilot's leaning, its probability of deciding at the powered n,
    the verdict reached, and whether it is the one the pilot leaned to.
    """
    claims = pd.read_csv(powered / "tables" / "claims.csv", keep_default_na=False)
    reached = claims.set_index("claim")["verdict"]
    out = power[["claim", "estimates_lean", "n_at_sd_ucl", "p_decide", "assurance"]].copy()
    out["verdict_at_powered_n"] = out["claim"].map(reached).fillna("")
    decided = out["verdict_at_powered_n"].isin([HOLDS, FAILS, NEGLIGIBLE])
    same = out["verdict_at_powered_n"] == out["estimates_lean"]
    out["as_leaned"] = np.where(
        decided & (out["estimates_lean"] != ""), np.where(same, "yes", "no"), ""
    )
    return out
