"""Kong et al. 2016's claims on the error angles (Obj 3-5: convergence, test-retest, cross-test;
Tables 8-11) and beside the paper (the error's axis, the recommended test and Kong's error against
a truth), as rules of :mod:`aceval.report.kong_claims`: each returns the subject-level cells it
is judged on.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import full_set_rows, rows_of_method, usable
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
from aceval.report.kong2016 import reference
from aceval.report.kong_evidence import RIGID_BOX, Evidence, against

#: Kong's own threshold for a calibration that no longer changes: "after including three
#: repetitions the change caused by adding one more repetition ... is less than one degree"
#: (Sec. 3.3, Obj 3): two calibrations closer than this are, by Kong's reading, the same one; the
#: smallest effect of interest of every superiority claim on the error angles
SAME_CALIBRATION_DEG = 1.0

# --- Obj 3-4 ----------------------------------------------------------------------------------


#: the repetitions of one test each angle needs: "incremental" a subset and one repetition more,
#: "to last" a subset and all of them, test-retest two distinct subsets of k (Kong: 3 of 5)
REPETITIONS_NEEDED = {"incremental": 2, "to_last": 2, "test_retest": 4}


def _why_no_angles(e: Evidence, comparison: str, needed: int, excluded: bool) -> str:
    """Why a dataset has no angle of ``comparison`` for a claim: no body segment calibrated, too
    few repetitions of any test (the most it has), or every cell outside the claim.
    """
    c = e.calibrations
    body = c[c["segment"] != RIGID_BOX] if c is not None and "segment" in c else None
    most = int(body["n_reps"].max()) if body is not None and len(body) and "n_reps" in body else 0
    if body is not None and len(body) and most < needed:
        return (
            f"needs {needed} or more repetitions of a motion test ({comparison} angles); the tests "
            f"here have at most {most}"
        )
    if excluded:
        return f"every cell of {comparison} angles here is one the claim leaves out"
    return "no body segment calibrated by a motion test"


def angles_below(comparison: str, keys: list[str], limit: float, where=None, needed=None):
    """A rule: every cell's (``keys``) subject mean angle of ``comparison`` is below ``limit``
    (deg); ``needed``: the repetitions the cells need (default :data:`REPETITIONS_NEEDED`).
    """

    def judge(e: Evidence):
        cells = e.angle_cells(comparison, keys)
        chosen = cells[where(cells)] if where is not None and len(cells) else cells
        if chosen.empty:
            reps = needed or REPETITIONS_NEEDED[comparison]
            return UNTESTABLE, _why_no_angles(e, comparison, reps, len(cells) > 0)
        return against(chosen, keys, "error_angle_deg", limit, "<")

    return judge


def lower_than_upper(e: Evidence):
    """Obj 3: the lower limbs' to-last angle exceeds the upper body's, per subject."""
    cells = e.angle_cells("to_last", ["segment"])
    wide = cells.pivot_table(index="subject", columns="segment", values="error_angle_deg")
    upper, lower = [s for s in UPPER if s in wide], [s for s in LOWER if s in wide]
    if not upper or not lower:
        return UNTESTABLE, "needs upper-body and lower-limb segments"
    long = one_cell("lower limbs - upper body", wide[lower].mean(axis=1) - wide[upper].mean(axis=1))
    requirement = Requirement.of(">", 0.0, SAME_CALIBRATION_DEG)
    return Cells(long, every_cell(long, requirement), unit="deg")


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
    requirement = Requirement.of(">", 0.0, SAME_CALIBRATION_DEG)
    return Cells(long, every_cell(long, requirement), unit="deg")


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


#: Kong's subjects (Sec. 2.1): Table 11's means and SDs are over them
PAPER_SUBJECTS = 5


def at_paper_precision(mean: float, sd: float, n: int = PAPER_SUBJECTS) -> float:
    """A published mean (deg) at the precision the paper reports it with: the upper limit of its
    95 % t-interval over the paper's ``n`` subjects, the largest value the paper's own data do not
    exclude (Table 11's waist T1-T3, 5.39 +- 5.75 deg: 12.53).
    """
    from scipy import stats

    return float(mean + stats.t.ppf(0.975, n - 1) * sd / np.sqrt(n))


def published_cross(pair: str, segment: str) -> tuple[float, float]:
    """Kong Table 11's (mean, SD) of one test pair and segment (deg)."""
    table = reference(11).set_index(["t_ex_pair", "segment"])
    return float(table.loc[(pair, segment), "mean_deg"]), float(
        table.loc[(pair, segment), "sd_deg"]
    )


#: Kong Table 11's largest cell outside the feet and the thighs with T3 (waist T1-T3, 5.39 deg):
#: what "about 5 deg" reaches in the paper
ABOUT_5_DEG = published_cross("T1-T3", "waist")[0]
#: "about 5 deg" at the paper's precision (:func:`at_paper_precision` of waist T1-T3): a cell
#: within it is as small as the paper's own largest cell can be said to be
ABOUT_5_BOUND = at_paper_precision(*published_cross("T1-T3", "waist"))


def cross_small(e: Evidence):
    """Obj 5: about 5 deg or less outside the feet and the thighs with T3."""
    cells = cross(e)
    if cells.empty:
        return UNTESTABLE, "needs IMUs calibrated by two tests"
    return against(
        cells[~special(cells)], ["t_ex_pair", "segment"], "error_angle_deg", ABOUT_5_BOUND, "<="
    )


def cross_large(e: Evidence):
    """Obj 5: larger than about 5 deg for the feet and the thighs with T3."""
    cells = cross(e)
    large = cells[special(cells)] if len(cells) else cells
    if large.empty:
        return UNTESTABLE, "needs the feet or the thighs with T3 in two tests"
    return against(large, ["t_ex_pair", "segment"], "error_angle_deg", ABOUT_5_DEG, ">")


#: Kong's recommendation (Sec. 3.5): the standard test against the tests designed for anatomical
#: calibration, per segment, as the Table 11 pairs that compare them, and the paper's bound at
#: the paper's precision (:func:`at_paper_precision`): "in maximum 5.39 degree" (upper body:
#: waist T1-T3, 5.39 +- 5.75), "lower than 5.12 degree" (thighs, shanks: shank T5-T6, 5.12 +-
#: 4.61)
UPPER_BOUND = Requirement.of("<=", at_paper_precision(*published_cross("T1-T3", "waist")))
LOWER_BOUND = Requirement.of("<", at_paper_precision(*published_cross("T5-T6", "shank")))
RECOMMENDED = {
    "head": ("T3", ["T1-T3", "T2-T3"], UPPER_BOUND),
    "chest": ("T3", ["T1-T3", "T2-T3"], UPPER_BOUND),
    "waist": ("T3", ["T1-T3", "T2-T3"], UPPER_BOUND),
    "thigh": ("T6", ["T5-T6"], LOWER_BOUND),
    "shank": ("T6", ["T4-T6", "T5-T6"], LOWER_BOUND),
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
    full = usable(full_set_rows(rows_of_method(c)))
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


#: an error of a segment's calibration that should raise concern: McGinley et al. 2009 (Gait &
#: Posture 29:360-369, a systematic review of the reliability of 3-D gait kinematics): errors of
#: 2-5 deg are "reasonable", errors above 5 deg "should raise concern" and may mislead clinical
#: interpretation. A calibration's error passes into its segment's orientation, so into every
#: joint angle the segment is part of. Kong's "about 5 deg" between tests (Obj 5) is the same size.
ACCEPTABLE_ERROR_DEG = 5.0


def recommended_errors(e: Evidence) -> pd.DataFrame:
    """Each subject's mean error to the truth (deg) of Kong's calibration from the test Kong
    recommends for each segment (:data:`RECOMMENDED`; all repetitions, unflagged, its IMUs and
    sets averaged): columns subject, segment, test, error_deg; empty without a truth.
    """
    c = e.calibrations
    if c is None or "error_deg" not in c or c["error_deg"].isna().all():
        return pd.DataFrame(columns=["subject", "segment", "test", "error_deg"])
    full = usable(full_set_rows(rows_of_method(c))).dropna(subset=["error_deg"])
    chosen = [
        full[(full["segment"] == segment) & (full["test"] == test)]
        for segment, (test, _, _) in RECOMMENDED.items()
    ]
    rows = pd.concat(chosen, ignore_index=True)
    return (
        rows.groupby(["subject", "segment", "test"], sort=False)["error_deg"].mean().reset_index()
    )


def kong_accurate(e: Evidence):
    """Against a truth: Kong's calibration from the recommended test is within
    :data:`ACCEPTABLE_ERROR_DEG` of the truth, per segment (absolute accuracy).
    """
    c = e.calibrations
    if c is None or "error_deg" not in c or c["error_deg"].isna().all():
        return UNTESTABLE, "no ground truth"
    errors = recommended_errors(e)
    if errors.empty:
        return UNTESTABLE, "no calibration from the test Kong recommends for a segment"
    errors["segment"] = pd.Categorical(errors["segment"], list(RECOMMENDED))  # the paper's order
    long = labelled(errors.sort_values(["segment", "subject"]), ["segment", "test"], "error_deg")
    requirement = Requirement.of("<", ACCEPTABLE_ERROR_DEG)
    return Cells(long, every_cell(long, requirement), unit="deg")
