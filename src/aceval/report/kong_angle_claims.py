"""Kong et al. 2016's claims on the error angles (Obj 3-5: convergence, test-retest, cross-test;
Tables 8-11) and beside the paper (the error's axis, the recommended test against a truth), as
rules of :mod:`aceval.report.kong_claims`: each returns the subject-level cells it is judged on.
"""

from __future__ import annotations

import pandas as pd

from aceval.calibrate.table import full_set_rows, kong_rows, usable
from aceval.report.claims import (
    FAILS,
    HOLDS,
    LOWER,
    UNTESTABLE,
    UPPER,
    Cells,
    Requirement,
    every_cell,
    labelled,
    one_cell,
)
from aceval.report.kong_evidence import Evidence, against

# --- Obj 3-4 ----------------------------------------------------------------------------------


def angles_below(comparison: str, keys: list[str], limit: float, where=None):
    """A rule: every cell's (``keys``) subject mean angle of ``comparison`` is below ``limit`` (deg)."""

    def judge(e: Evidence):
        cells = e.angle_cells(comparison, keys)
        if where is not None and len(cells):
            cells = cells[where(cells)]
        if cells.empty:
            return UNTESTABLE, f"needs repeated motion tests of body segments ({comparison})"
        return against(cells, keys, "error_angle_deg", limit, "<")

    return judge


def lower_than_upper(e: Evidence):
    """Obj 3: the lower limbs' to-last angle exceeds the upper body's, per subject."""
    cells = e.angle_cells("to_last", ["segment"])
    wide = cells.pivot_table(index="subject", columns="segment", values="error_angle_deg")
    upper, lower = [s for s in UPPER if s in wide], [s for s in LOWER if s in wide]
    if not upper or not lower:
        return UNTESTABLE, "needs upper-body and lower-limb segments"
    long = one_cell("lower limbs - upper body", wide[lower].mean(axis=1) - wide[upper].mean(axis=1))
    return Cells(long, every_cell(long, Requirement.of(">", 0.0)), unit="deg")


def t6_faster(e: Evidence):
    """Obj 3: the lower limbs converge faster in T6 than in T5 (to-last angle, per subject)."""
    cells = e.angle_cells("to_last", ["segment", "test"])
    parts = []
    for segment in LOWER:
        wide = cells[cells["segment"] == segment].pivot_table(
            index="subject", columns="test", values="error_angle_deg"
        )
        if {"T5", "T6"} <= set(wide.columns):
            parts.append(one_cell(f"{segment} T5 - T6", wide["T5"] - wide["T6"]))
    if not parts:
        return UNTESTABLE, "needs T5 and T6"
    long = pd.concat(parts, ignore_index=True)
    return Cells(long, every_cell(long, Requirement.of(">", 0.0)), unit="deg")


# --- Obj 5 ------------------------------------------------------------------------------------


def cross(e: Evidence) -> pd.DataFrame:
    """Obj 5: each subject's mean cross-test angle per (test pair, segment)."""
    cells = e.angle_cells("cross_test", ["test", "segment"])
    return cells.rename(columns={"test": "t_ex_pair"})


def special(cells: pd.DataFrame) -> pd.Series:
    """The cross-test cells Kong singles out: the feet, and the thighs with T3."""
    return (cells["segment"] == "foot") | (
        (cells["segment"] == "thigh") & cells["t_ex_pair"].str.contains("T3")
    )


#: Kong Table 11's largest cell outside the feet and the thighs with T3 (waist T1-T3, 5.39 deg):
#: what "about 5 deg" reaches in the paper
ABOUT_5_DEG = 5.39


def cross_small(e: Evidence):
    """Obj 5: about 5 deg or less outside the feet and the thighs with T3."""
    cells = cross(e)
    if cells.empty:
        return UNTESTABLE, "needs IMUs calibrated by two tests"
    return against(
        cells[~special(cells)], ["t_ex_pair", "segment"], "error_angle_deg", ABOUT_5_DEG, "<="
    )


def cross_large(e: Evidence):
    """Obj 5: larger than about 5 deg for the feet and the thighs with T3."""
    cells = cross(e)
    large = cells[special(cells)] if len(cells) else cells
    if large.empty:
        return UNTESTABLE, "needs the feet or the thighs with T3 in two tests"
    return against(large, ["t_ex_pair", "segment"], "error_angle_deg", ABOUT_5_DEG, ">")


#: Kong's recommendation (Sec. 3.5): the standard test against the tests designed for anatomical
#: calibration, per segment, as the Table 11 pairs that compare them, and the paper's bound:
#: "in maximum 5.39 degree" (upper body), "lower than 5.12 degree" (thighs, shanks)
RECOMMENDED = {
    "head": ("T3", ["T1-T3", "T2-T3"], Requirement.of("<=", 5.39)),
    "chest": ("T3", ["T1-T3", "T2-T3"], Requirement.of("<=", 5.39)),
    "waist": ("T3", ["T1-T3", "T2-T3"], Requirement.of("<=", 5.39)),
    "thigh": ("T6", ["T5-T6"], Requirement.of("<", 5.12)),
    "shank": ("T6", ["T4-T6", "T5-T6"], Requirement.of("<", 5.12)),
}


def recommendation(e: Evidence):
    """Sec. 3.5: the recommended test within the paper's bound of the designed ones."""
    cells = cross(e)
    parts, requirements = [], {}
    for segment, (_, pairs, bound) in RECOMMENDED.items():
        chosen = cells[(cells["segment"] == segment) & cells["t_ex_pair"].isin(pairs)]
        if len(chosen):
            long = labelled(chosen, ["segment", "t_ex_pair"], "error_angle_deg")
            parts.append(long)
            requirements |= {cell: bound for cell in dict.fromkeys(long["cell"])}
    if not parts:
        return UNTESTABLE, "needs the recommended test and a designed one for a segment"
    return Cells(pd.concat(parts, ignore_index=True), requirements, unit="deg")


# --- beside the paper -------------------------------------------------------------------------


def about_z0(e: Evidence) -> tuple[str, str]:
    """Code check: every error angle is a rotation about the vertical z0."""
    angles = e.angles
    moved = angles[angles["error_angle_deg"] > 1e-6] if angles is not None else None
    if moved is None or moved.empty:
        return UNTESTABLE, "no error angle"
    share = moved["vertical_share"].min()
    return (HOLDS if share > 0.999 else FAILS), (
        f"smallest share {share:.6f} over {len(moved)} comparisons"
    )


#: Kong's own threshold for a calibration that no longer changes: "after including three
#: repetitions the change caused by adding one more repetition ... is less than one degree"
#: (Sec. 3.3, Obj 3): two calibrations closer than this are, by Kong's reading, the same one
SAME_CALIBRATION_DEG = 1.0


def held_out_differences(per_subject: pd.DataFrame, recommended: str) -> pd.Series:
    """Per subject (index), the recommended test's error minus that of the best other test,
    the best chosen on the *other* subjects (leave one subject out: the subject tested is not
    the one the choice was made on). ``per_subject``: subjects x tests, mean error (deg).
    """
    others = [t for t in per_subject.columns if t != recommended]
    differences = {}
    for subject in per_subject.index:
        rest = per_subject.drop(index=subject)[others].mean()
        if rest.notna().any():
            best = rest.idxmin()
            differences[subject] = (
                per_subject.loc[subject, recommended] - per_subject.loc[subject, best]
            )
    return pd.Series(differences, dtype=float)


def recommended_most_accurate(e: Evidence):
    """Against a truth: the recommended test is not worse than the best other test, chosen on
    the other subjects, by Kong's 1 deg (non-inferiority, leave one subject out).
    """
    c = e.calibrations
    if c is None or "error_deg" not in c or c["error_deg"].isna().all():
        return UNTESTABLE, "no ground truth"
    full = usable(full_set_rows(kong_rows(c)))
    per_subject = full.groupby(["subject", "segment", "test"])["error_deg"].mean().reset_index()
    parts = []
    for segment, (test, _, _) in RECOMMENDED.items():
        wide = per_subject[per_subject["segment"] == segment].pivot_table(
            index="subject", columns="test", values="error_deg"
        )
        if test in wide and wide.shape[1] >= 2 and len(wide) >= 2:
            cell = f"{segment}: {test} - best other (held out)"
            parts.append(one_cell(cell, held_out_differences(wide, test)))
    if not parts:
        return UNTESTABLE, "needs the recommended test, another one and two subjects"
    long = pd.concat(parts, ignore_index=True)
    return Cells(long, every_cell(long, Requirement.of("<", SAME_CALIBRATION_DEG)), unit="deg")
