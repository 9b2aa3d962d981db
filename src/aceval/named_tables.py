"""The tables beyond Kong's numbered ones: Ricci et al. 2014 (Table 1, t-tests, LM), the
reliability indices of Kong's tests, and the methods against the ground truth.

Each is built from the tidy outputs of ``aceval calibrate`` (``axes``, ``calibrations``) and,
for the test-retest relation, ``angles``; rendered as CSV and Markdown with the published value
beside each reproduced one where the paper gives one.
"""

from __future__ import annotations

import pandas as pd

from . import comparison, reliability, tables
from .tables import _fmt, _fmt_p, rounded

TABLES = {
    "correlation_factors": dict(
        needs="correlations",
        title="Kong et al. 2016, Obj 1-2: share of the variance of the correlations explained by the "
        "test the matrix comes from (T_ex), the test it is applied to (T_ap) and the segment",
        unit="Obj 1: subject x IMU x T_ex x T_ap (Table 3's units); Obj 2: subject x set x side x pair x "
        "T_ex x T_ap (Table 6's); eta squared from type II sums of squares of an additive model",
        build=lambda d: tables.correlation_factors(d["correlations"]),
    ),
    "truth_errors": dict(
        needs="calibrations",
        title="Against a marker-based ground truth: each method's error beside the truth's own "
        "uncertainty, the second (marker-frame) truth, and the method's conditioning",
        unit="one row per sensor, test and method (all repetitions); the truths and their checks are in "
        "the dataset's ground_truth_method.tsv",
        build=lambda d: comparison.truth_errors(d["calibrations"], d["truth_method"]),
    ),
    "conditioning": dict(
        needs="calibrations",
        title="How well each test determines each IMU's heading by Kong's plane: eigenvalue ratio "
        "(smallest/middle; above 0.5 undetermined) and planarity, flagged calibrations included",
        unit="subject x sensor set x IMU x test (the calibration from all repetitions)",
        build=lambda d: reliability.conditioning_table(d["calibrations"]),
    ),
    "loose_reference": dict(
        needs="calibrations",
        title="Orders of magnitude against a loose reference (hand-tuned segment axes, NOT a ground "
        "truth): angle between each calibration's right axis and the reference's, and between the "
        "verticals (deg)",
        unit="one row per sensor, test and method (all repetitions, flagged calibrations included); "
        "the reference and its standing check are in the dataset's loose_reference.tsv",
        build=lambda d: comparison.loose_reference_angles(d["calibrations"], d["loose_reference"]),
    ),
    "obj1_sensitivity": dict(
        needs="correlations",
        title="What Kong's Obj 1 correlation can detect: the frontal vs lateral acceleration correlation "
        "when the lateral calibration is turned by a known heading error, per correlation mode",
        unit="subject x IMU x T_ex x T_ap (Table 3's units), each averaged over the repetitions",
        build=lambda d: tables.correlation_sensitivity(d["correlations"]),
    ),
    "ricci_table1": dict(
        needs="axes",
        title="Ricci et al. 2014, Table 1: reliability index rho per movement and segment",
        unit="subjects (each child's rho pooled over its 3 trials, as Ricci: 9-12 repetitions)",
        build=lambda d: reliability.rho_table(d["axes"], d["paper_names"]),
    ),
    "ricci_ttest": dict(
        needs="axes",
        title="Ricci et al. 2014: paired t-test of rho, supported (bar) vs unsupported movement",
        unit="children, one pair per child and side (rho pooled over the 3 trials); sides tested separately; "
        "p raw and Holm-corrected within each reading; the paper reports only p < 0.05 for each frame",
        build=lambda d: reliability.supported_ttest(d["axes"]),
    ),
    "ricci_lm": dict(
        needs="calibrations",
        title="Ricci et al. 2014: Levenberg-Marquardt iterations per frame, and random starts",
        unit="IMUs (subject x side); q0 = identity, lambda = 1e-3, stop at relative cost change < 1e-4; "
        "each fit also from random unit quaternions (how many: random_starts), counted as reaching "
        "the optimum when within 0.1 deg of SciPy's closed-form solution",
        build=lambda d: reliability.lm_table(d["calibrations"]),
    ),
    "ricci_residuals": dict(
        needs="axes",
        title="Ricci et al. 2014, Fig. 5 / Eq. 13: residual angle between each reference axis and its "
        "estimate, before (identity) and after the LM fit (deg)",
        unit="IMUs (subject x side)",
        build=lambda d: reliability.residual_table(d["axes"], d["paper_names"]),
    ),
    "reliability": dict(
        needs="axes+calibrations",
        title="Reliability indices of Kong's tests in Ricci Table 1's layout: rho of the gyroscope "
        "axis and Kong planarity",
        unit="subject x sensor set x IMU (both from all repetitions of the test)",
        build=lambda d: reliability.kong_reliability_table(
            reliability.kong_units(d["axes"], d["calibrations"], d.get("angles"))
        ),
    ),
    "reliability_retest": dict(
        needs="axes+calibrations+angles",
        title="Does a reliability index predict the Obj 4 test-retest angle? Spearman rank correlation",
        unit="subject x sensor set x IMU x test (index from all repetitions; angle = mean over the pairs of "
        "3-repetition subsets)",
        build=lambda d: reliability.reliability_vs_retest(
            reliability.kong_units(d["axes"], d["calibrations"], d.get("angles"))
        ),
    ),
    "methods": dict(
        needs="calibrations",
        title="Every method against the ground truth: error angle to the true mounting (deg)",
        unit="subjects (each IMU's calibration from all repetitions of the test; Ricci's design: "
        "from all its axes)",
        build=lambda d: comparison.methods_table(d["calibrations"]),
    ),
    "methods_best": dict(
        needs="calibrations",
        title="Which test to use for which segment: smallest median error per method, "
        "beside Kong's recommendation (T3 upper body, T6 thighs and shanks)",
        unit="calibrations of both sensor sets",
        build=lambda d: comparison.best_tests(d["calibrations"]),
    ),
}


def build(
    name: str,
    axes=None,
    calibrations=None,
    angles=None,
    paper_names=None,
    correlations=None,
    truth_method=None,
    loose_reference=None,
) -> pd.DataFrame:
    """Table ``name`` (a key of ``TABLES``) as a tidy frame, floats rounded to 4 decimals."""
    if name not in TABLES:
        raise ValueError(
            f"unknown table {name!r}: one of {', '.join(TABLES)} or a Kong table number"
        )
    table = TABLES[name]["build"](
        dict(
            axes=axes,
            calibrations=calibrations,
            angles=angles,
            correlations=correlations,
            truth_method=truth_method,
            loose_reference=loose_reference,
            paper_names=paper_names or {},
        )
    )
    return rounded(table.reset_index(drop=True))


def to_markdown(table: pd.DataFrame, name: str, dataset: str, simulated: bool) -> str:
    """A named table as Markdown, labelled with its dataset (and SIMULATED)."""
    spec = TABLES[name]
    lines = [
        f"# {spec['title']}",
        "",
        f"Dataset **{dataset}**"
        + (" (SIMULATED data, not the paper's recordings)" if simulated else "")
        + f". n counts {spec['unit']}.",
        "",
    ]
    if table.empty:
        return "\n".join(lines + ["No data in this dataset for this table.", ""])
    shown = table.copy()
    for column in shown.columns:
        if column in ("p", "p_holm"):
            shown[column] = [_fmt_p(v) for v in shown[column]]
        elif pd.api.types.is_float_dtype(shown[column]):
            shown[column] = [_fmt(v) for v in shown[column]]
    return "\n".join(lines + [shown.to_markdown(index=False, disable_numparse=True), ""])
