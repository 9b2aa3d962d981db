"""How often each claim's rule says what: its operating characteristics, beside the power
analysis that fixed the powered design's number of subjects (:mod:`aceval.report.power`).

Both read only committed files: every dataset's ``tables/claim_cells.csv`` (one value per subject
and cell of every claim), ``claim_estimates.csv`` (each cell's requirement) and ``claims.csv``.

**Operating characteristics** (:func:`operating_table`): the subjects of the powered design
(Ricci's: its 40 children) are the population. Each claim's cells are shifted so that the cell
that decides it lies :data:`SHIFT_SD` of its subjects' SD on the claim's side of its bound (the
claim true), on the bound, or as far on the other side (false), every other cell moved by the
same number of its own SDs; then :data:`DRAWS` samples of n subjects are drawn with replacement
(the subject brings all its cells) and judged by the very rule of SUMMARY.md
(:func:`aceval.evaluation.verdicts.verdict_codes`), at the paper's n and the powered n. Beside it,
how often the cells' own 95 % intervals and the simultaneous ones cover the population's means.
Resampling the committed cells costs seconds; a workflow run per sample would cost minutes each.

``python -m aceval.report.operating RESULTS`` writes both into RESULTS/operating_characteristics/.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.evaluation.verdicts import (
    FAILS,
    HOLDS,
    POWER,
    half_width,
    level,
    margins,
    verdict_codes,
)
from aceval.report.power import (
    AFFORDABLE_N,
    FAMILY_POWER,
    PAPER_DESIGN,
    PILOT_UCL,
    POWERED_DESIGN,
    POWERED_N,
    RICCI_DESIGN,
    claim_specs,
    family,
    family_table,
    power_table,
    powered_n,
    prediction_check,
)

#: samples of subjects per claim, design and scenario (Monte Carlo SE of a share at most 1.1 %)
DRAWS = 2000
#: how far the claim is true or false in the scenarios: half of the deciding cell's SD over the
#: subjects (Cohen's medium standardised effect)
SHIFT_SD = 0.5
SCENARIOS = {
    f"true by {SHIFT_SD:g} SD": SHIFT_SD,
    "on the bound": 0.0,
    f"false by {SHIFT_SD:g} SD": -SHIFT_SD,
    "as simulated": None,
}
#: a verdict a rule returns less often than this where it should is "almost never" returned
RARELY = 0.05
SEED = 42


# --- operating characteristics ------------------------------------------------------------------


def placed_against(req: dict, target: float) -> dict:
    """The requirement a scenario is placed against: a superiority cell's bound moved to the edge
    of its negligible band (its smallest effect of interest), on the claim's side when the claim
    is true (``target`` > 0: true by a relevant amount), on the other side when it is false (a
    relevant difference the other way); the bound itself when on it.
    """
    shift = np.sign(target) * np.nan_to_num(req["smallest_effect"], nan=0.0)
    return {**req, "above": req["above"] + shift, "below": req["below"] - shift}


def shifted(wide: pd.DataFrame, req: dict, combine: str, target: float | None) -> pd.DataFrame:
    """The population with every cell moved so that the deciding cell lies ``target`` of its SDs
    on the claim's side of its nearest bound (negative: beyond it; a superiority cell's bound
    taken at the edge of its smallest effect of interest, :func:`placed_against`), each other
    cell by the same number of its own SDs (a range's cell no farther in than its middle); None:
    as it is.
    """
    if target is None:
        return wide
    req = placed_against(req, target)
    mean, sd = wide.mean().to_numpy(), wide.std().to_numpy()
    z = margins(mean, sd, req)
    finite = np.isfinite(z)
    if not finite.any():
        return wide
    order = np.argsort(np.where(finite, z, np.inf), kind="stable")
    deciding = order[0] if combine == "all" else order[finite.sum() - (finite.sum() // 2 + 1)]
    wanted = z + (target - z[deciding])
    above, below = req["above"], req["below"]
    lower_nearer = np.isfinite(above) & ~(np.isfinite(below) & (below - mean < mean - above))
    middle = np.where(np.isfinite(above) & np.isfinite(below), (below - above) / (2 * sd), np.inf)
    wanted = np.minimum(wanted, middle)
    new_mean = np.where(lower_nearer, above + wanted * sd, below - wanted * sd)
    return wide + np.where(finite, new_mean - mean, 0.0)


def sampled(wide: pd.DataFrame, req: dict, combine: str, n: int, rng) -> dict:
    """The rule on :data:`DRAWS` samples of ``n`` subjects drawn with replacement from ``wide``:
    the share of each verdict, and how often the cells' 95 % intervals (median and smallest
    over the cells) and their simultaneous intervals (all at once) cover the population means.
    """
    values = wide.to_numpy(float)
    truth = np.nanmean(values, axis=0)
    m = values.shape[1]
    codes, covered, all_covered = [], [], []
    for start in range(0, DRAWS, 250):
        draws = values[rng.integers(0, len(values), size=(min(250, DRAWS - start), n))]
        count = np.isfinite(draws).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"), _quiet():
            mean = np.nanmean(draws, axis=1)
            sd = np.nanstd(draws, axis=1, ddof=1)
        codes.append(verdict_codes(mean, sd, count, req, combine))
        one = half_width(sd, count, level(1))
        covered.append(np.abs(mean - truth) <= one)
        all_covered.append((np.abs(mean - truth) <= half_width(sd, count, level(m))).all(axis=1))
    codes, covered = np.concatenate(codes), np.concatenate(covered)
    per_cell = covered.mean(axis=0)
    return {
        **{
            f"p_{name}": float(np.mean(codes == k))
            for name, k in (("holds", 0), ("fails", 1), ("inconclusive", 2), ("negligible", 3))
        },
        "coverage_median": float(np.median(per_cell)),
        "coverage_min": float(per_cell.min()),
        "simultaneous_coverage": float(np.concatenate(all_covered).mean()),
    }


class _quiet:
    """No 'mean of empty slice' warnings for a cell a sample has no value in."""

    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        return self._catch.__exit__(*exc)


def operating_table(results: Path) -> pd.DataFrame:
    """Every claim's rule at the paper's n and the powered n (Ricci: its 40 children), in each
    scenario (:data:`SCENARIOS`), with a note where it almost never returns a verdict it should.
    """
    designs = [
        (POWERED_DESIGN, [("the paper's design", 5), ("the powered design", POWERED_N)]),
        (RICCI_DESIGN, [("the paper's design", 40)]),
    ]
    rows = []
    rng = np.random.default_rng(SEED)
    for dataset, sizes in designs:
        for key, (wide, req, combine, claim) in claim_specs(results / dataset).items():
            for design, n in sizes:
                for scenario, target in SCENARIOS.items():
                    population = shifted(wide, req, combine, target)
                    rows.append(
                        {
                            "claim": key,
                            "objective": claim["objective"],
                            "population": f"{dataset} ({len(wide)} subjects)",
                            "design": design,
                            "n": n,
                            "scenario": scenario,
                            **sampled(population, req, combine, n, rng),
                        }
                    )
    return _with_notes(pd.DataFrame(rows))


def _with_notes(table: pd.DataFrame) -> pd.DataFrame:
    """A note beside each claim and design whose rule almost never (:data:`RARELY`) says 'holds'
    when the claim is true, or 'does not hold' when it is false.
    """
    notes = []
    for _, row in table.iterrows():
        note = ""
        if row["scenario"].startswith("true") and row["p_holds"] < RARELY:
            note = f"almost never says '{HOLDS}' when the claim is true"
        if row["scenario"].startswith("false") and row["p_fails"] < RARELY:
            note = f"almost never says '{FAILS}' when the claim is false"
        notes.append(note)
    return table.assign(note=notes)


def verdicts_by_design(results: Path) -> pd.DataFrame:
    """Every Kong claim's committed verdict at the paper's n and at the powered n, side by side
    (an inconclusive one with the way it leans and the subjects that would decide it).
    """

    def shown(dataset: str) -> pd.Series:
        claims = pd.read_csv(results / dataset / "tables" / "claims.csv", keep_default_na=False)
        text = [
            v if v != "inconclusive" or not lean else f"{v} (leans '{lean}', n {n or '> 100000'})"
            for v, lean, n in zip(claims["verdict"], claims["leaning"], claims["n_to_decide"])
        ]
        return pd.Series(text, index=claims["claim"])

    paper, powered = shown(PAPER_DESIGN), shown(POWERED_DESIGN)
    return pd.DataFrame(
        {
            "claim": paper.index,
            f"{PAPER_DESIGN} (5 subjects)": paper.values,
            f"{POWERED_DESIGN} ({POWERED_N} subjects)": powered.reindex(paper.index).values,
        }
    )


#: the sizes at which the family's joint probability of being decided is tabulated: the paper's,
#: the powered design's, the one before it (93) and the budget
FAMILY_SIZES = tuple(sorted({5, 20, 40, 60, 80, POWERED_N, 93, AFFORDABLE_N}))


def _percent(table: pd.DataFrame, columns) -> pd.DataFrame:
    shown = table.copy()
    for column in columns:
        shown[column] = shown[column].map(lambda v: f"{100 * v:.0f} %" if pd.notna(v) else "")
    return shown


def _markdown(analysis: dict, table: pd.DataFrame, verdicts: pd.DataFrame) -> str:
    """operating_characteristics.md: the power analysis, its check, both designs' verdicts and
    the rules' operating characteristics.
    """
    power, joint, check, n = (analysis[k] for k in ("power", "family", "check", "n"))
    shown = _percent(
        table,
        [c for c in table.columns if c.startswith(("p_", "coverage_", "simultaneous_"))],
    )
    power = _percent(power, ["p_decide", "p_decide_sd_ucl", "assurance"])
    joint = _percent(joint, [c for c in joint.columns if c.startswith("joint")])
    check = _percent(check, ["p_decide", "assurance"])
    return "\n".join(
        [
            "# Operating characteristics of the claims' rules (SIMULATED)",
            "",
            "Made by `python -m aceval.report.operating results` from the committed "
            "`results/*/tables/claim_*.csv` (aceval.report.operating and aceval.report.power "
            "explain how).",
            "",
            "## Power analysis on the paper's design (kong_sim, 5 subjects)",
            "",
            f"Per claim: the subjects at which it reaches the verdict its estimates lean to with "
            f"{POWER:.0%} probability, its cells' means taken as the truth and their SDs as "
            f"observed (`n_to_decide`), at their one-sided {PILOT_UCL:.0%} upper confidence limit "
            "(`n_at_sd_ucl`: a 5-subject SD is that uncertain) and scaled (`n_sd_x*`); its "
            f"probability of being decided at {POWERED_N} subjects with the SDs as observed, at "
            "their upper limit, and averaged over the truths the pilot leaves possible "
            f"(`assurance`). The family: the claims decidable within {AFFORDABLE_N} subjects at "
            f"the upper-limit SDs (`affordable`). The powered design's n is the fewest at which "
            f"the family is decided with {FAMILY_POWER:.0%} (independent claims, upper-limit "
            f"SDs), at most {AFFORDABLE_N}: fixed in advance at **{POWERED_N}** "
            f"(config/powered.yaml); on the cells committed now the analysis gives {n}.",
            "",
            power.to_markdown(index=False),
            "",
            "The family's joint probability of being decided (`any_dependence`: the Bonferroni "
            "inequality's lower bound, 1 - sum(1 - P), whatever the claims' dependence):",
            "",
            joint.to_markdown(index=False),
            "",
            f"## What the analysis said, and what the powered design ({POWERED_N} subjects) gave",
            "",
            check.to_markdown(index=False),
            "",
            "## The committed verdicts at both n",
            "",
            verdicts.to_markdown(index=False),
            "",
            "## How often each rule says what",
            "",
            f"Population: the subjects of the committed powered design (Ricci: its children), each "
            f"claim's cells shifted so that the deciding cell lies {SHIFT_SD:g} SD on the claim's side "
            f"of its bound (true), on it, or {SHIFT_SD:g} SD beyond it (false), or as simulated (a "
            "superiority claim's bound taken at the edge of its smallest effect of interest when "
            "true or false: true or false by a relevant amount; on the bound, 'no relevant "
            "difference' is the right answer where the subjects' SD is small against it); "
            f"{DRAWS} samples of n subjects with replacement per row. p_negligible: 'no relevant "
            "difference'. coverage: the cells' 95 % intervals (median and smallest over the cells) "
            "and the simultaneous ones (every cell at once) around the population means.",
            "",
            shown.to_markdown(index=False),
            "",
        ]
    )


def power_analysis(results: Path) -> dict:
    """The power analysis on the paper's design (:mod:`aceval.report.power`): per claim, the
    family's joint probability, the n it gives, and its check against the powered design.
    """
    folder = results / PAPER_DESIGN
    power = power_table(folder)
    members = family(folder)
    check = prediction_check(power, results / POWERED_DESIGN)
    joint = family_table(members, FAMILY_SIZES)
    return {"power": power, "family": joint, "check": check, "n": powered_n(members)}


def main(argv: list[str] | None = None) -> int:
    """``python -m aceval.report.operating RESULTS``: the power analysis and the operating
    characteristics into RESULTS/operating_characteristics/; ``--power``: print the power
    analysis only (what fixes the powered design's n, before that design exists).
    """
    import argparse

    parser = argparse.ArgumentParser(prog="python -m aceval.report.operating")
    parser.add_argument("results", type=Path)
    parser.add_argument("--power", action="store_true", help="the power analysis only")
    args = parser.parse_args(argv)
    results = args.results
    if args.power:
        folder = results / PAPER_DESIGN
        members = family(folder)
        print(power_table(folder).to_string(index=False))
        print(family_table(members, FAMILY_SIZES).to_string(index=False))
        print(f"powered design: {powered_n(members)} subjects")
        return 0
    analysis = power_analysis(results)
    table = operating_table(results)
    out = results / "operating_characteristics"
    out.mkdir(parents=True, exist_ok=True)
    for name in ("power", "family", "check"):
        csv = {"family": "family_power", "check": "power_check"}.get(name, name)
        analysis[name].to_csv(out / f"{csv}.csv", index=False, float_format="%.4f")
    table.to_csv(out / "operating_characteristics.csv", index=False, float_format="%.4f")
    verdicts = verdicts_by_design(results)
    verdicts.to_csv(out / "verdicts_by_design.csv", index=False)
    (out / "operating_characteristics.md").write_text(_markdown(analysis, table, verdicts))
    print(f"powered design: {analysis['n']} subjects", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
