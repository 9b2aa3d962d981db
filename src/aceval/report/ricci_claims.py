"""Ricci et al. 2014's claims (reference/ricci2014/headline_findings.md) as rules on this dataset's
children, each with a verdict of :mod:`aceval.report.claims` and its numbers. The child is the
independent unit: Table 1's cells and the residuals are one value per child; the LM's iterations
are averaged over a child's two sides before the interval is formed.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from aceval.evaluation.stats import summary_ci
from aceval.methods import registry
from aceval.report.claims import (
    CODE,
    FAILS,
    HOLDS,
    UNTESTABLE,
    Claim,
    Rule,
    _cells,
    beyond,
    cell_estimates,
    equivalent_to,
    every,
    interval,
    subject_cells,
    tally,
)
from aceval.report.ricci2014 import PRIMARY_READING, SAME_SOLUTION_DEG, published_lm


@dataclass
class Evidence:
    """What Ricci's rules read: the ricci_* tables and the calibrations (the LM's iterations)."""

    tables: dict
    calibrations: pd.DataFrame | None


def _with_intervals(table: pd.DataFrame) -> pd.DataFrame:
    """A table's rows (mean, sd, n children) with their 95 % and 90 % t-intervals."""
    out = table.copy()
    for level, low, high in ((0.95, "low", "high"), (0.90, "low90", "high90")):
        bounds = [summary_ci(r["mean"], r["sd"], int(r["n"]), level) for _, r in out.iterrows()]
        out[low], out[high] = [b[0] for b in bounds], [b[1] for b in bounds]
    return out


def _equal_to_published(rows: pd.DataFrame, margin_column: str, label) -> tuple[str, str]:
    """Every row's mean equivalent to its ``published_mean`` within ``margin_column`` (two
    one-sided tests, :func:`aceval.report.claims.equivalent_to`): the verdict, the counts and the
    row farthest from the paper.
    """
    rows = _with_intervals(rows)
    verdicts = [equivalent_to(r, r["published_mean"], r[margin_column]) for _, r in rows.iterrows()]
    far = rows.loc[(rows["mean"] - rows["published_mean"]).abs().idxmax()]
    return every(verdicts), (
        f"equivalent / different / undecided: {tally(verdicts)} of {len(rows)} cells; farthest {label(far)} "
        f"{interval(far['mean'], far['low'], far['high'], 3)} (paper {far['published_mean']:.2f} "
        f"+- {far[margin_column]:.3f}, n {int(far['n'])} children)"
    )


# --- Table 1 ----------------------------------------------------------------------------------


#: Ricci's words for the static postures' rho: "about 0.97-0.99" (Table 1)
STATIC_RANGE = (0.97, 0.99)


def _static(e: Evidence) -> tuple[str, str]:
    table = _cells(e.tables.get("ricci_table1"))
    rows = table[table["test"].isin(["TS/US/FS", "S"])] if len(table) else table
    if rows.empty:
        return UNTESTABLE, "no static posture"
    rows = _with_intervals(rows)
    low, high = STATIC_RANGE
    verdicts = [
        every(
            [
                beyond(r["low"], r["high"], low - r["published_sd"], ">="),
                beyond(r["low"], r["high"], high + r["published_sd"], "<="),
            ]
        )
        for _, r in rows.iterrows()
    ]
    return every(verdicts), "; ".join(
        f"{r['segment']} {interval(r['mean'], r['low'], r['high'], 3)}" for _, r in rows.iterrows()
    ) + f" (n {int(rows['n'].max())} children)"


def _movements(e: Evidence) -> tuple[str, str]:
    table = _cells(e.tables.get("ricci_table1"))
    rows = table[~table["test"].isin(["TS/US/FS", "S"])] if len(table) else table
    rows = rows.dropna(subset=["published_mean"]) if len(rows) else rows
    if rows.empty:
        return UNTESTABLE, "no movement of Table 1"
    return _equal_to_published(rows, "published_sd", lambda r: f"{r['test']} {r['segment']}")


def _supported(e: Evidence) -> tuple[str, str]:
    ttest = _cells(e.tables.get("ricci_ttest"))
    if ttest.empty:
        return UNTESTABLE, "needs FEB and FE (and FFEB)"
    primary = ttest[ttest["reading"] == PRIMARY_READING]
    if primary.empty:
        return UNTESTABLE, "needs FEB and FE"
    verdicts = [beyond(r["ci95_low"], r["ci95_high"], 0.0, ">") for _, r in primary.iterrows()]

    def listed(rows):
        return "; ".join(
            f"{r['segment']} {r['supported']} - {r['unsupported']} "
            f"{interval(r['mean_difference'], r['ci95_low'], r['ci95_high'], 3)} (p {r['p']:.2g}, "
            f"n {int(r['n'])} children)"
            for _, r in rows.iterrows()
        )

    second = ttest[ttest["reading"] != PRIMARY_READING]
    return every(verdicts), listed(primary) + (
        f"; second reading: {listed(second)}" if len(second) else ""
    )


# --- the LM -----------------------------------------------------------------------------------


def _iterations(e: Evidence) -> tuple[str, str]:
    c = e.calibrations
    lm = registry.paper_method("ricci2014")
    fits = c[c["method"] == lm] if c is not None and "n_iterations" in c else None
    if fits is None or fits.empty:
        return UNTESTABLE, "no LM fit"
    children = subject_cells(fits, ["segment"], "n_iterations")  # a child's sides averaged
    estimates = cell_estimates(children, ["segment"], "n_iterations")
    published = published_lm().query("quantity == 'iterations'")[["frame", "mean", "sd"]]
    rows = estimates.merge(
        published.rename(
            columns={"frame": "segment", "mean": "published_mean", "sd": "published_sd"}
        ),
        on="segment",
    )
    if rows.empty:
        return UNTESTABLE, "no frame of the paper"
    verdicts = [
        equivalent_to(r, r["published_mean"], r["published_sd"]) for _, r in rows.iterrows()
    ]
    return every(verdicts), "; ".join(
        f"{r['segment']} {interval(r['mean'], r['low'], r['high'])} (paper {r['published_mean']:.2f} "
        f"+- {r['published_sd']:.3f}, n {int(r['n'])} children)"
        for _, r in rows.iterrows()
    )


def _random_starts(e: Evidence) -> tuple[str, str]:
    lm = _cells(e.tables.get("ricci_lm"))
    if lm.empty or not lm["random_starts"].sum():
        return UNTESTABLE, "no LM fit"
    starts, reached = int(lm["random_starts"].sum()), int(lm["random_starts_optimum"].sum())
    return (HOLDS if reached == starts else FAILS), (
        f"{reached} of {starts} starts within {SAME_SOLUTION_DEG} deg of the closed-form optimum; "
        f"iterations mean {lm['random_start_iterations_mean'].mean():.1f}, max "
        f"{int(lm['random_start_iterations_max'].max())} (paper: 12 in its example)"
    )


# --- residuals --------------------------------------------------------------------------------


def _residuals_shrink(e: Evidence) -> tuple[str, str]:
    residuals = _cells(e.tables.get("ricci_residuals"))
    if residuals.empty:
        return UNTESTABLE, "no LM fit"
    per_test = residuals[residuals["test"] != "all"]
    return (HOLDS if (per_test["mean"] < per_test["before_mean"]).all() else FAILS), (
        f"before {per_test['before_mean'].min():.1f}-{per_test['before_mean'].max():.1f} deg, after "
        f"{per_test['mean'].min():.2f}-{per_test['mean'].max():.2f} deg"
    )


def _residuals_after(e: Evidence) -> tuple[str, str]:
    residuals = _cells(e.tables.get("ricci_residuals"))
    published = residuals.dropna(subset=["published_mean"]) if len(residuals) else residuals
    if published.empty:
        return UNTESTABLE, "no LM fit on the paper's axes"
    return _equal_to_published(
        published.assign(margin=published["sd"]), "margin", lambda r: f"{r['segment']} {r['test']}"
    )


RULES = [
    Rule(
        "Ricci Table 1",
        "Static postures have rho about 0.97-0.99 (Table 1)",
        "every static cell's 95 % interval over the children inside the paper's range 0.97-0.99 "
        "widened by the paper's SD of that cell (its 'about', Table 1)",
        _static,
    ),
    Rule(
        "Ricci Table 1",
        "Movement rho values of Table 1 are reproduced",
        "every movement cell's mean over the children equivalent to the paper's within the "
        "paper's SD of that cell (Table 1: two one-sided tests)",
        _movements,
    ),
    Rule(
        "Ricci t-test",
        "Supported movements (bar) have higher rho than unsupported ones, p < 0.05 "
        "for upper arms and forearms",
        "the paper's reading, the same movement with and without the bar (shoulder flexion-"
        "extension FEB vs FE) at the upper-arm and forearm sensors: every row's 95 % interval of "
        "supported - unsupported (over the children) above 0; elbow FFEB vs FE, a different "
        "movement, is listed as a second reading",
        _supported,
    ),
    Rule(
        "Ricci LM",
        "LM converges in thorax 6.34, upper arm 8.36, forearm 7.30 iterations (mean)",
        "each frame's mean iterations over the children (a child's two sides averaged) "
        "equivalent to the paper's within the paper's SD (Sec. 3: 0.561 / 0.767 / 0.863; two "
        "one-sided tests)",
        _iterations,
    ),
    Rule(
        "Ricci LM",
        "LM converges from random initial quaternions too",
        f"every random start ends within {SAME_SOLUTION_DEG} deg of the closed-form optimum (a "
        "tenth of Kong's 1 deg test-retest bound: closer solutions are the same calibration for "
        "either paper)",
        _random_starts,
    ),
    Rule(
        "Ricci residuals",
        "Residuals after the fit: thorax 5.39/2.56/2.86 deg (TR/TFE/supine), "
        "forearms 4.68/4.72 deg",
        "each published residual's cell, its mean over the children equivalent to the paper's "
        "within this run's SD between children (the paper gives no SD for its residuals; Table "
        "1's rule uses the SD between children as its margin too)",
        _residuals_after,
    ),
    Rule(
        "Ricci residuals",
        "Residual angles shrink from the identity start to the fit: true of any "
        "least-squares fit from an arbitrary start, so a check of the code, not a finding",
        "every segment x test: mean residual after < before",
        _residuals_shrink,
        CODE,
    ),
]


def ricci_claims(tables: dict, data: dict) -> list[Claim]:
    """Every Ricci et al. 2014 claim (:data:`RULES`) from the ricci_* tables and the calibrations
    of ``data``.
    """
    evidence = Evidence(tables, data.get("calibrations"))
    return [rule.apply(evidence) for rule in RULES]
