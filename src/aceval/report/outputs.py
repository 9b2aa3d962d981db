"""The one registry of aceval's outputs: every table and figure, the paper item it reproduces (or
that it goes beyond the papers), the analysis it belongs to, what it is built from, its caption
and its builder. The workflow (which files a dataset gets, and the report's labels), the command
line (``aceval table|figure|outputs``) and the renderers read it; adding an output is one entry
here and its builder.

Builders import their modules when called, so reading the registry costs no start-up time.
Tables are built from a dict ``data`` of tidy tables (``INPUT_KINDS``) plus ``paper_names`` and
``sensor_sets``; figures draw from the same dict to a PNG path.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, get_args

from aceval.report import builders
from aceval.report.builders import (
    figure,
    kong_figure,
    kong_markdown,
    kong_table,
    kong_units,
    named_markdown,
)

#: the tidy tables an output can be built from: the per-subject outputs of ``aceval calibrate``
#: (calibrations, axes, correlations), the Obj 3-5 angles, and an imported dataset's sheets on its
#: ground truth (ground_truth_method.tsv) or a loose reference (loose_reference.tsv)
INPUT_KINDS = ("calibrations", "axes", "correlations", "angles", "truth_method", "loose_reference")
#: the analyses a dataset can ask for (config ``analyses``), and the ones aceval adds itself
Analysis = Literal[
    "kong", "box", "ricci", "decision", "methods", "retest", "truth", "loose_reference"
]
ANALYSES: tuple[str, ...] = get_args(Analysis)
#: an output is a table (CSV and Markdown) or a figure (PNG)
Kind = Literal["table", "figure"]


@dataclass(frozen=True)
class Output:
    """One table or figure of a dataset's results (``results/<dataset>/<kind>s/<name>``)."""

    name: str
    kind: Kind
    analysis: Analysis
    paper: str  # the paper item it reproduces, or "beyond the papers"
    inputs: tuple[str, ...]  # kinds of INPUT_KINDS
    title: str  # the table's heading, the figure's caption
    unit: str = ""  # tables: what n counts
    build: Callable | None = None  # tables: data -> DataFrame; figures: (data, png, title) -> None
    markdown: Callable | None = None  # tables: (table, output, dataset, simulated) -> str

    def __post_init__(self):
        if self.kind not in get_args(Kind) or self.analysis not in ANALYSES:
            raise ValueError(
                f"output {self.name}: kind {self.kind!r} (one of {get_args(Kind)}), analysis "
                f"{self.analysis!r} (one of {ANALYSES})"
            )

    @property
    def path(self) -> str:
        """Where it lives under ``results/<dataset>/`` (tables: the CSV; the Markdown beside)."""
        return f"{self.kind}s/{self.name}.{'csv' if self.kind == 'table' else 'png'}"


# --- the registry ------------------------------------------------------------------------------

_KONG_TABLES = {
    3: (
        "Obj 1",
        "Acceleration correlation between the two sensors of one segment (frontal/back vs "
        "lateral set)",
        "subject x IMU x T_ex, each averaged over the repetitions of T_ap",
    ),
    4: (
        "Obj 1, rigid box",
        "Acceleration correlation between the two sensors of each IMU position on a rigid box",
        "repetitions of T_ap (per box, averaged)",
    ),
    5: (
        "Obj 1, rigid box",
        "Angular velocity correlation between the two sensors of each IMU position on a rigid box",
        "repetitions of T_ap (per box, averaged)",
    ),
    6: (
        "Obj 2",
        "Acceleration correlation between segments moved as one rigid body (same sensor set)",
        "subject x sensor set x side x T_ex, each averaged over the repetitions of T_ap",
    ),
    7: (
        "Obj 2",
        "Paired t-test, segment-pair correlation, first vs second sensor set",
        "pairs matched on subject, side, T_ex, T_ap and repetition (paper-style); subjects "
        "(independent units, sides averaged)",
    ),
    8: (
        "Obj 3",
        "Paired t-test, 'incremental' error angle (deg), first vs second sensor set",
        "pairs matched on subject, IMU, T_ex and the two subsets compared (paper-style); subjects "
        "(independent units, IMUs averaged)",
    ),
    9: (
        "Obj 4",
        "Error angle (deg) between different subsets of three repetitions of the same test",
        "subject x set x IMU x pair of 3-repetition subsets",
    ),
    10: (
        "Obj 4",
        "Paired t-test, test-retest error angle (deg), first vs second sensor set",
        "pairs matched on subject, IMU, T_ex and the two subsets compared (paper-style); "
        "subjects (independent units, IMUs averaged)",
    ),
    11: (
        "Obj 5",
        "Error angle (deg) between the calibrations from two different tests",
        "subject x set x IMU",
    ),
}
_KONG_FIGURES = {
    6: (
        "Obj 1",
        "correlations",
        "Acceleration correlation between the frontal/back and lateral "
        "sensor of each segment, by the test the matrices are applied to (T_ap) and the test they "
        "come from (T_ex); mean and SD over subjects and sides, each value averaged over the "
        "repetitions",
    ),
    8: (
        "Obj 2",
        "correlations",
        "Acceleration correlation between body segments moved as one "
        "rigid body (same sensor set), by T_ap and T_ex; mean and SD over subjects, sets and sides",
    ),
    9: (
        "Obj 3",
        "angles",
        "'Incremental' error angle: the change of the calibration when one "
        "repetition is added to k repetitions (Kong Eq. 11-12), mean and SD by T_ex and segment",
    ),
    10: (
        "Obj 3",
        "angles",
        "'To last' error angle: calibration from k repetitions vs from all of "
        "them (Kong Eq. 13 is k = 1), mean and SD by T_ex and segment",
    ),
}

_ENTRIES = [
    *(
        Output(
            f"table{n}",
            "table",
            "box" if n in (4, 5) else "kong",
            f"Kong et al. 2016, Table {n} ({objective})",
            ("correlations",) if n <= 7 else ("angles",),
            title,
            unit,
            kong_table(n),
            kong_markdown,
        )
        for n, (objective, title, unit) in _KONG_TABLES.items()
    ),
    Output(
        "set_test_units",
        "table",
        "kong",
        "Kong et al. 2016, Tables 7, 8, 10 (the cells of the tests on subjects and mixed models)",
        ("correlations", "angles"),
        "The cells behind the set comparison on which the claims are judged: per table, row, "
        "subject and IMU (Table 7: side), the mean of the paired values in each sensor set; the "
        "test on subjects averages a subject's cells, the mixed model reads their differences",
        "subject x IMU (Table 7: subject x side), repetitions and subsets averaged inside each",
        builders.set_test_units,
        named_markdown,
    ),
    Output(
        "correlation_factors",
        "table",
        "kong",
        "Kong et al. 2016, Obj 1-2 (Sec. 3.1, 4)",
        ("correlations",),
        "Kong et al. 2016, Obj 1-2: share of the variance of the correlations explained by the "
        "test the matrix comes from (T_ex), the test it is applied to (T_ap) and the segment",
        "Obj 1: subject x IMU x T_ex x T_ap (Table 3's units); Obj 2: subject x set x side x pair x "
        "T_ex x T_ap (Table 6's); eta squared from type II sums of squares of an additive model, low and "
        "high its 95 % interval from 1,000 resamples of the subjects; aliased: how many of the "
        "factor's contrasts the others span (Obj 2's pairs are each recorded in their own tests: "
        "a factor wholly confounded has no share of its own, shown empty)",
        builders.correlation_factors,
        named_markdown,
    ),
    Output(
        "obj1_sensitivity",
        "table",
        "kong",
        "beyond the papers (what Obj 1 can detect)",
        ("correlations",),
        "What Kong's Obj 1 correlation can detect: the frontal vs lateral acceleration correlation "
        "when the lateral calibration is turned by a known heading error, per correlation mode",
        "subject x IMU x T_ex x T_ap (Table 3's units), each averaged over the repetitions",
        builders.correlation_sensitivity,
        named_markdown,
    ),
    Output(
        "reliability",
        "table",
        "kong",
        "beyond the papers (Ricci's index on Kong's tests)",
        ("axes", "calibrations", "angles"),
        "Reliability indices of Kong's tests in Ricci Table 1's layout: rho of the gyroscope "
        "axis and Kong planarity",
        "subject x sensor set x IMU (both from all repetitions of the test)",
        kong_units("kong_reliability_table"),
        named_markdown,
    ),
    Output(
        "reliability_retest",
        "table",
        "kong",
        "beyond the papers",
        ("axes", "calibrations", "angles"),
        "Does a reliability index predict the Obj 4 test-retest angle? Spearman rank correlation",
        "subject x sensor set x IMU x test (index from all repetitions; angle = mean over the "
        "pairs of 3-repetition subsets)",
        kong_units("reliability_vs_retest"),
        named_markdown,
    ),
    Output(
        "variability",
        "table",
        "kong",
        "beyond the papers (what the simulator's variability is set from)",
        ("calibrations", "angles", "correlations"),
        "How variable the motion is, per subject, test and segment: one repetition's calibration "
        "against all of them (Kong Eq. 13, k = 1), the 3-of-5 test-retest (Eq. 15), the "
        "eigenvalue ratio and planarity of all repetitions' accelerations (Eq. 3), two sensors "
        "on one segment (Obj 1): the same statistics on real and simulated data",
        "subject x test x segment, each the median over the subject's IMUs and sensor sets",
        builders.variability_table,
        named_markdown,
    ),
    Output(
        "conditioning",
        "table",
        "kong",
        "beyond the papers (Kong Eq. 3's conditioning)",
        ("calibrations",),
        "How well each test determines each IMU's heading by Kong's plane: eigenvalue ratio "
        "(smallest/middle; above 0.5 undetermined) and planarity, flagged calibrations included",
        "subject x sensor set x IMU x test (the calibration from all repetitions)",
        builders.conditioning_table,
        named_markdown,
    ),
    *(
        Output(
            f"figure{n}",
            "figure",
            "kong",
            f"Kong et al. 2016, Figure {n} ({objective})",
            (source,),
            caption,
            build=kong_figure(n),
        )
        for n, (objective, source, caption) in _KONG_FIGURES.items()
    ),
    Output(
        "obj1_sensitivity",
        "figure",
        "kong",
        "beyond the papers (what Obj 1 can detect)",
        ("correlations",),
        "What Kong's Obj 1 can detect: frontal vs lateral acceleration correlation against a "
        "heading error imposed on the lateral calibration, per correlation mode (mean and SD over "
        "Table 3's units)",
        build=figure("obj1_sensitivity"),
    ),
    Output(
        "reliability",
        "figure",
        "kong",
        "beyond the papers (Ricci's index on Kong's tests)",
        ("axes", "calibrations", "angles"),
        "Reliability index of each Kong test (rho of the gyroscope axis; Kong planarity) against "
        "the Obj 4 test-retest angle, one point per subject x set x IMU x test",
        build=figure("reliability"),
    ),
    Output(
        "ricci_table1",
        "table",
        "ricci",
        "Ricci et al. 2014, Table 1",
        ("axes",),
        "Ricci et al. 2014, Table 1: reliability index rho per movement and segment",
        "subjects (each child's rho pooled over its 3 trials, as Ricci: 9-12 repetitions)",
        builders.rho_table,
        named_markdown,
    ),
    Output(
        "ricci_ttest",
        "table",
        "ricci",
        "Ricci et al. 2014, Sec. 4 (paired t-test)",
        ("axes",),
        "Ricci et al. 2014: paired t-test of rho, supported (bar) vs unsupported movement",
        "children, one pair per child and side (rho pooled over the 3 trials); sides tested "
        "separately; p raw and Holm-corrected within each reading; the paper reports only p < "
        "0.05 for each frame",
        builders.supported_ttest,
        named_markdown,
    ),
    Output(
        "ricci_lm",
        "table",
        "ricci",
        "Ricci et al. 2014, Sec. 3 (LM iterations)",
        ("calibrations",),
        "Ricci et al. 2014: Levenberg-Marquardt iterations per frame, and random starts",
        "IMUs (subject x side); q0 = identity, steps on the unit sphere; columns without a prefix: "
        "Hartley & Zisserman's adaptive damping from lambda = 1e-3 (floored at 1e-6), fixed_*: "
        "lambda fixed at 1e-3; stop at relative cost change < 1e-4 (Eq. 11) with the gradient on "
        "the sphere < 1e-6, converged = that gradient reached; off_optimum: more than 1 deg "
        "from SciPy's closed-form solution; each fit also from random unit quaternions (how many: "
        "random_starts), counted as reaching the optimum when within 1 deg of it (Kong Sec. 3.3)",
        builders.lm_table,
        named_markdown,
    ),
    Output(
        "ricci_residuals",
        "table",
        "ricci",
        "Ricci et al. 2014, Eq. 13, Fig. 5",
        ("axes",),
        "Ricci et al. 2014, Fig. 5 / Eq. 13: residual angle between each reference axis and its "
        "estimate, before (identity) and after the LM fit (deg)",
        "IMUs (subject x side)",
        builders.residual_table,
        named_markdown,
    ),
    Output(
        "ricci_figure4",
        "figure",
        "ricci",
        "Ricci et al. 2014, Figure 4",
        ("axes",),
        "Ricci Fig. 4 in spirit: the LM fit of one thorax frame per iteration (quaternion, "
        "roll/pitch/yaw, residual vector, cost), and the cost from 10 random starts",
        build=figure("ricci_figure4"),
    ),
    Output(
        "ricci_figure5",
        "figure",
        "ricci",
        "Ricci et al. 2014, Figure 5",
        ("axes",),
        "Ricci Fig. 5 in spirit: residual angle between each reference axis and its estimate "
        "before (identity) and after the LM fit, mean and SD over children",
        build=figure("ricci_figure5"),
    ),
    Output(
        "decision",
        "table",
        "decision",
        "beyond the papers (which calibration to use)",
        ("calibrations",),
        "For each IMU, the calibration to use: among its calibrations from all repetitions "
        "(every method and test) that no flag takes out, the method and test with the best "
        "evidence from the other sensors of its segment (accuracy against the ground truth, or "
        "without one repeatability; a tie broken by a stated order); its rotation, uncertainty, "
        "the spread between the methods, the runner-up and the margin, how many calibrations it "
        "rests on, and a verdict against the tolerance (aceval.evaluation.decision)",
        "one row per IMU of a subject",
        builders.decision_table,
        named_markdown,
    ),
    Output(
        "methods",
        "table",
        "methods",
        "beyond the papers (accuracy)",
        ("calibrations",),
        "Every method against the ground truth: error angle to the true mounting (deg)",
        "subjects (each IMU's calibration from all repetitions of the test; Ricci's design: from "
        "all its axes); retest_*: Kong Obj 4 for each method, subject x IMU units (methods_retest)",
        builders.methods_table,
        named_markdown,
    ),
    Output(
        "methods_retest",
        "table",
        "retest",
        "beyond the papers (Kong Obj 4 for every method)",
        ("calibrations",),
        "Every method's test-retest: error angle (deg) between its calibrations from two distinct "
        "subsets of k repetitions of one test (Kong Eq. 15), no ground truth needed",
        "subject x sensor set x IMU (each the mean over the pairs of k-repetition subsets)",
        builders.retest_table,
        named_markdown,
    ),
    Output(
        "uncertainty",
        "table",
        "methods",
        "beyond the papers (an uncertainty with every calibration)",
        ("calibrations",),
        "The uncertainty cone of a calibration (`cone_deg`: the spread of its resampled "
        "repetitions, the other estimates' disagreement, the motion's conditioning, the tilt of "
        "z0 from the accelerometer's bias: docs/uncertainty.md) against its error to the ground "
        "truth: coverage, the share of calibrations whose error lies inside their cone, with its "
        "95 % interval; beside it the coverage of the repetitions' spread alone",
        "calibrations from all repetitions of both sensor sets (unflagged, with a cone); rows "
        "'all': the method over every segment and test",
        builders.uncertainty_table,
        named_markdown,
    ),
    Output(
        "flag_value",
        "table",
        "retest",
        "beyond the papers (what each flag is worth)",
        ("calibrations",),
        "What each flag removes and whether the calibrations it removes are worse: per flag and "
        "method, the calibrations from all repetitions it flags (and those it alone removes), "
        "and the median distance of flagged and unflagged ones to the ground truth, or without "
        "one to the consensus of the other methods' unflagged calibrations "
        "(aceval.evaluation.flag_value)",
        "calibrations from all repetitions (every method, the peers included); p: one-sided "
        "Mann-Whitney, flagged farther than unflagged (calibrations are not independent units: "
        "a screen, not a verdict)",
        builders.flag_value_table,
        named_markdown,
    ),
    Output(
        "methods_best",
        "table",
        "methods",
        "beyond the papers (Kong Sec. 4's recommendation)",
        ("calibrations",),
        "Which test to use for which segment: smallest median error per method, beside Kong's "
        "recommendation (T3 upper body, T6 thighs and shanks)",
        "calibrations of both sensor sets",
        builders.best_tests,
        named_markdown,
    ),
    Output(
        "methods_ranking",
        "table",
        "methods",
        "beyond the papers (accuracy, on the subjects)",
        ("calibrations",),
        "The methods ranked by their error to the ground truth (deg) on the cells every compared "
        "method shares, with intervals over the subjects; each method's difference to the first",
        "subjects (each subject's mean error over its calibrations in the shared segment x test x "
        "set cells: sides and sets inside the subject); mean with its 95 % t-interval; the paired "
        "difference to the first-ranked method with its interval simultaneous over the "
        "comparisons (Bonferroni, difference_level)",
        builders.methods_ranking,
        named_markdown,
    ),
    Output(
        "methods",
        "figure",
        "methods",
        "beyond the papers (accuracy)",
        ("calibrations",),
        "Error angle to the true mounting by method and test, per segment: median and "
        "interquartile range",
        build=figure("methods"),
    ),
    Output(
        "truth_errors",
        "table",
        "truth",
        "beyond the papers (real-data truth)",
        ("calibrations", "truth_method"),
        "Against a marker-based ground truth: each method's error beside the truth's own "
        "uncertainty, the second (marker-frame) truth, and the method's conditioning",
        "one row per sensor, test and method (all repetitions); the truths and their checks are "
        "in the dataset's ground_truth_method.tsv",
        builders.truth_errors,
        named_markdown,
    ),
    Output(
        "loose_reference",
        "table",
        "loose_reference",
        "beyond the papers (orders of magnitude)",
        ("calibrations", "loose_reference"),
        "Orders of magnitude against a loose reference (hand-tuned segment axes, NOT a ground "
        "truth): angle between each calibration's right axis and the reference's, and between "
        "the verticals (deg)",
        "one row per sensor, test and method (all repetitions, flagged calibrations included); "
        "the reference and its standing check are in the dataset's loose_reference.tsv",
        builders.loose_reference_angles,
        named_markdown,
    ),
]
#: every output by (kind, name)
OUTPUTS: dict[tuple[str, str], Output] = {(o.kind, o.name): o for o in _ENTRIES}


def outputs_of(analyses) -> list[Output]:
    """The outputs of these analyses, tables first, in the registry's order."""
    chosen = [o for o in _ENTRIES if o.analysis in set(analyses)]
    return [o for o in chosen if o.kind == "table"] + [o for o in chosen if o.kind == "figure"]


def find(kind: str, name: str) -> Output:
    """The output ``name`` of ``kind`` ('table' or 'figure'); Kong's also by number ('3' ->
    'table3'). ValueError naming the known ones otherwise.
    """
    if name.isdigit():
        name = f"{kind}{name}"
    if (kind, name) not in OUTPUTS:
        known = ", ".join(n for k, n in OUTPUTS if k == kind)
        raise ValueError(f"unknown {kind} {name!r}: one of {known}")
    return OUTPUTS[(kind, name)]
