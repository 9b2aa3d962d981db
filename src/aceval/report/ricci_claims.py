"""Ricci et al. 2014's claims (reference/ricci2014/headline_findings.md) as rules on this dataset's
children, each with a verdict of :mod:`aceval.report.claims` and its numbers. The child is the
independent unit: each rule reads one value per child and cell (Table 1's rho, a child's
supported - unsupported difference, its LM iterations with its two sides averaged, its residual
angle).
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from aceval.methods import registry
from aceval.report.claims import (
    CODE,
    FAILS,
    HOLDS,
    UNTESTABLE,
    Cells,
    Claim,
    Requirement,
    Rule,
    every_cell,
    labelled,
    one_cell,
    present,
    subject_cells,
)
from aceval.report.kong_angle_claims import SAME_CALIBRATION_DEG
from aceval.report.ricci2014 import (
    PRIMARY_READING,
    SAME_SOLUTION_DEG,
    SUPPORTED_PAIRS,
    published_lm,
    segment_label,
)

CHILDREN = "children"


@dataclass
class Evidence:
    """What Ricci's rules read: the ricci_* tables, the axes (each child's rho and residuals) and
    the calibrations (the LM's iterations), and the dataset's test names -> the paper's.
    """

    tables: dict
    calibrations: pd.DataFrame | None
    axes: pd.DataFrame | None = None
    paper_names: dict | None = None

    def axis_cells(self, value: str) -> pd.DataFrame:
        """Each child's ``value`` per (test as the paper names it, segment with side)."""
        a = self.axes
        if a is None or a.empty or value not in a:
            return pd.DataFrame(columns=["subject", "test", "segment", value])
        names = self.paper_names or {}
        data = a.dropna(subset=[value]).assign(
            segment=lambda t: segment_label(t["segment"], t["side"]),
            test=lambda t: t["test"].map(lambda v: names.get(v, v)),
        )
        return subject_cells(data, ["test", "segment"], value)


def _published_cells(e: Evidence, static: bool) -> pd.DataFrame:
    """Table 1's rows this run has, static postures or movements, with the paper's values."""
    table = present(e.tables.get("ricci_table1"))
    if table.empty:
        return table
    chosen = table["test"].isin(["TS/US/FS", "S"])
    return table[chosen if static else ~chosen].dropna(subset=["published_mean"])


def _rho_cells(e: Evidence, rows: pd.DataFrame) -> pd.DataFrame:
    cells = e.axis_cells("rho").merge(rows[["test", "segment"]], on=["test", "segment"])
    return labelled(cells, ["test", "segment"], "rho")


#: Ricci's words for the static postures' rho, "about 0.97-0.99" (Table 1), at the precision they
#: are written with (two decimals: 0.965-0.995)
STATIC_RANGE = (0.965, 0.995)


def _static(e: Evidence):
    rows = _published_cells(e, static=True)
    if rows.empty:
        return UNTESTABLE, "no static posture"
    cells = _rho_cells(e, rows)
    low, high = STATIC_RANGE
    requirement = Requirement(above=low, above_inclusive=True, below=high, below_inclusive=True)
    return Cells(cells, every_cell(cells, requirement), digits=3, subjects=CHILDREN)


def _movements(e: Evidence):
    rows = _published_cells(e, static=False)
    if rows.empty:
        return UNTESTABLE, "no movement of Table 1"
    cells = _rho_cells(e, rows)
    published = rows.assign(cell=rows["test"].astype(str) + " " + rows["segment"].astype(str))
    requirements = {
        r["cell"]: Requirement.within(r["published_mean"], r["published_sd"])
        for _, r in published.iterrows()
        if r["cell"] in set(cells["cell"])
    }
    return Cells(cells, requirements, digits=3, subjects=CHILDREN)


#: the smallest difference in rho that matters: the precision Ricci's Table 1 reports rho with
#: (two decimals); a smaller difference does not show in the paper's own table
RHO_PRECISION = 0.01


def _supported(e: Evidence):
    rho = e.axis_cells("rho")
    parts = []
    for reading, frame, supported, unsupported in SUPPORTED_PAIRS:
        if reading != PRIMARY_READING:
            continue
        for label in sorted(rho.loc[rho["segment"].str.startswith(frame), "segment"].unique()):
            wide = rho[rho["segment"] == label].pivot_table(
                index="subject", columns="test", values="rho"
            )
            if {supported, unsupported} <= set(wide.columns):
                difference = (wide[supported] - wide[unsupported]).dropna()
                parts.append(one_cell(f"{label} {supported} - {unsupported}", difference))
    if not parts:
        return UNTESTABLE, "needs FEB and FE"
    cells = pd.concat(parts, ignore_index=True)
    return Cells(
        cells,
        every_cell(cells, Requirement.of(">", 0.0, RHO_PRECISION)),
        digits=3,
        subjects=CHILDREN,
        note="the second reading (elbow FFEB vs FE, a different movement) is in table ricci_ttest",
    )


# --- the LM -----------------------------------------------------------------------------------


def _iterations(e: Evidence):
    c = e.calibrations
    lm = registry.paper_method("ricci2014")
    fits = c[c["method"] == lm] if c is not None and "n_iterations" in c else None
    if fits is None or fits.empty:
        return UNTESTABLE, "no LM fit"
    children = subject_cells(fits, ["segment"], "n_iterations")  # a child's sides averaged
    published = published_lm().query("quantity == 'iterations'").set_index("frame")
    children = children[children["segment"].isin(published.index)]
    if children.empty:
        return UNTESTABLE, "no frame of the paper"
    cells = labelled(children, ["segment"], "n_iterations")
    requirements = {
        cell: Requirement.within(published.loc[cell, "mean"], published.loc[cell, "sd"])
        for cell in dict.fromkeys(cells["cell"])
    }
    return Cells(cells, requirements, subjects=CHILDREN, note="paper: 6.34, 8.36, 7.30")


def _random_starts(e: Evidence) -> tuple[str, str]:
    lm = present(e.tables.get("ricci_lm"))
    if lm.empty or not lm["random_starts"].sum():
        return UNTESTABLE, "no LM fit"
    starts, reached = int(lm["random_starts"].sum()), int(lm["random_starts_optimum"].sum())
    return (HOLDS if reached == starts else FAILS), (
        f"{reached} of {starts} starts within {SAME_SOLUTION_DEG:g} deg of the closed-form "
        f"optimum; iterations mean {lm['random_start_iterations_mean'].mean():.1f}, max "
        f"{int(lm['random_start_iterations_max'].max())} (paper: 12 in its example)"
    )


# --- residuals --------------------------------------------------------------------------------


def _residuals_shrink(e: Evidence) -> tuple[str, str]:
    residuals = present(e.tables.get("ricci_residuals"))
    if residuals.empty:
        return UNTESTABLE, "no LM fit"
    per_test = residuals[residuals["test"] != "all"]
    return (HOLDS if (per_test["mean"] < per_test["before_mean"]).all() else FAILS), (
        f"before {per_test['before_mean'].min():.1f}-{per_test['before_mean'].max():.1f} deg, after "
        f"{per_test['mean'].min():.2f}-{per_test['mean'].max():.2f} deg"
    )


def _residuals_after(e: Evidence):
    published = published_lm().query("quantity == 'residual_after_deg'")
    a = e.axes
    if a is None or a.empty or "residual_after_deg" not in a:
        return UNTESTABLE, "no LM fit on the paper's axes"
    data = a.dropna(subset=["residual_after_deg"])
    data = data.assign(segment=segment_label(data["segment"], data["side"]))
    per_test = subject_cells(data, ["segment", "test"], "residual_after_deg")
    overall = subject_cells(data, ["segment"], "residual_after_deg").assign(test="all")
    cells = pd.concat([per_test, overall], ignore_index=True).merge(
        published.rename(columns={"frame": "segment"})[["segment", "test", "mean"]],
        on=["segment", "test"],
    )
    if cells.empty:
        return UNTESTABLE, "no LM fit on the paper's axes"
    long = labelled(cells, ["segment", "test"], "residual_after_deg")
    targets = cells.assign(cell=long["cell"]).drop_duplicates("cell").set_index("cell")["mean"]
    requirements = {
        cell: Requirement.within(target, SAME_CALIBRATION_DEG) for cell, target in targets.items()
    }
    note = "paper: " + ", ".join(
        f"{r['frame']} {r['test']} {r['mean']:.2f}" for _, r in published.iterrows()
    )
    return Cells(long, requirements, unit="deg", subjects=CHILDREN, note=note)


RULES = [
    Rule(
        "Ricci Table 1",
        "Static postures have rho about 0.97-0.99 (Table 1)",
        f"every static cell's mean over the children within {STATIC_RANGE[0]}-{STATIC_RANGE[1]} "
        "(the paper's 'about 0.97-0.99' at the precision it is written with)",
        _static,
        key="ricci_static_rho",
    ),
    Rule(
        "Ricci Table 1",
        "Movement rho values of Table 1 are reproduced",
        "every movement cell's mean over the children within the paper's SD of that cell of the "
        "paper's mean (equivalence; Table 1: as close as one of the paper's children typically "
        "is, a standardised difference below 1)",
        _movements,
        key="ricci_movement_rho",
    ),
    Rule(
        "Ricci t-test",
        "Supported movements (bar) have higher rho than unsupported ones, p < 0.05 "
        "for upper arms and forearms",
        "the paper's reading, the same movement with and without the bar (shoulder flexion-"
        "extension FEB vs FE) at the upper-arm and forearm sensors: per child and side, "
        f"supported - unsupported > 0 (within +-{RHO_PRECISION:g}, the precision Table 1 reports "
        "rho with, no relevant difference); elbow FFEB vs FE, a different movement, is a second "
        "reading in table ricci_ttest",
        _supported,
        key="ricci_supported_higher",
    ),
    Rule(
        "Ricci LM",
        "LM converges in thorax 6.34, upper arm 8.36, forearm 7.30 iterations (mean)",
        "each frame's mean iterations over the children (a child's two sides averaged) within "
        "the paper's SD of the paper's mean (Sec. 3: 0.561 / 0.767 / 0.863; equivalence: as close "
        "as one of the paper's fits typically is)",
        _iterations,
        key="ricci_lm_iterations",
    ),
    Rule(
        "Ricci LM",
        "LM converges from random initial quaternions too",
        f"every random start ends within {SAME_SOLUTION_DEG:g} deg of the closed-form optimum "
        "(Kong's own threshold for a calibration that no longer changes, 'less than one degree', "
        "Sec. 3.3; no subjects: judged on the count)",
        _random_starts,
        key="ricci_random_starts",
    ),
    Rule(
        "Ricci residuals",
        "Residuals after the fit: thorax 5.39/2.56/2.86 deg (TR/TFE/supine), "
        "forearms 4.68/4.72 deg",
        "each published residual's cell, its mean over the children within "
        f"{SAME_CALIBRATION_DEG:g} deg of the paper's (equivalence; the paper gives no SD for its "
        "residuals: Kong's 'less than one degree', Sec. 3.3, the smallest change of a "
        "calibration that matters)",
        _residuals_after,
        key="ricci_residuals_after",
    ),
    Rule(
        "Ricci residuals",
        "Residual angles shrink from the identity start to the fit: true of any "
        "least-squares fit from an arbitrary start, so a check of the code, not a finding",
        "every segment x test: mean residual after < before",
        _residuals_shrink,
        CODE,
        key="code_residuals_shrink",
    ),
]


def ricci_claims(tables: dict, data: dict) -> list[Claim]:
    """Every Ricci et al. 2014 claim (:data:`RULES`) from the ricci_* tables and the axes and
    calibrations of ``data``.
    """
    evidence = Evidence(tables, data.get("calibrations"), data.get("axes"), data.get("paper_names"))
    return [rule.apply(evidence) for rule in RULES]


#: why Ricci's claims cannot be tested on a dataset without its recordings
NO_FUNCTIONAL_AXES = (
    "no functional-axis recordings (Ricci's static postures and movements, table ricci_table1)"
)


def ricci_untestable(why: str = NO_FUNCTIONAL_AXES) -> list[Claim]:
    """Ricci's claims (not its checks of the code) as not testable, with ``why``: the lines
    SUMMARY.md shows on a dataset without Ricci's recordings.
    """
    return [
        Claim(r.objective, r.claim, r.rule, UNTESTABLE, why, r.section, r.key)
        for r in RULES
        if r.section != CODE
    ]
