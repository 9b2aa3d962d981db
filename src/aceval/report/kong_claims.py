"""Kong et al. 2016's claims (reference/kong2016/headline_findings.md) as rules on this dataset's
subjects, each with a verdict of :mod:`aceval.report.claims` and its numbers; the code checks and
the ground-truth check beside them. Every number a rule compares with is the paper's (its words,
its tables' values and SDs) or a cited convention, and the rule says which.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.evaluation.stats import smallest_sign_flip_p
from aceval.report.claims import (
    CODE,
    FAILS,
    GROUND_TRUTH,
    HOLDS,
    INCONCLUSIVE,
    UNTESTABLE,
    UPPER,
    Rule,
    beyond,
    cell_estimates,
    equivalent,
    equivalent_to,
    every,
    interval,
    resampled,
    subject_cells,
)
from aceval.report.kong_angle_claims import (
    ABOUT_5_DEG,
    SAME_CALIBRATION_DEG,
    about_z0,
    angles_below,
    cross_large,
    cross_small,
    lower_than_upper,
    recommendation,
    recommended_most_accurate,
    t6_faster,
)
from aceval.report.kong_evidence import Evidence, cells_against

# --- Obj 1 ------------------------------------------------------------------------------------


def _mostly_above(e: Evidence) -> tuple[str, str]:
    cells = e.obj1
    if cells.empty:
        return UNTESTABLE, "needs two sensor sets on the same body segments (Table 3)"
    wide = cells.pivot_table(index="subject", columns=["t_ap", "segment"], values="correlation")
    share, low, high = resampled(wide, lambda v: np.mean(np.nanmean(v, axis=0) > 0.95))
    lowest = cell_estimates(cells, ["t_ap", "segment"], "correlation").sort_values("mean").iloc[0]
    numbers = (
        f"share of {wide.shape[1]} cells > 0.95: {interval(share, low, high)}; lowest "
        f"{lowest['segment']} {lowest['t_ap']} {lowest['mean']:.3f}; paper: 29 of 36 cells (81 %), "
        f"lowest 0.803 (foot T6)" + _insensitivity(e.tables.get("obj1_sensitivity"))
    )
    return beyond(low, high, 0.5, ">"), numbers


def _insensitivity(sensitivity) -> str:
    """What Obj 1's correlation does with a large heading error (table ``obj1_sensitivity``,
    concatenated mode): the sensitivity curve beside the claims it would decide.
    """
    if sensitivity is None or sensitivity.empty:
        return ""
    curve = sensitivity[sensitivity["mode"] == "concatenated"].sort_values("heading_error_deg")
    if curve.empty:
        return ""
    start, end = curve.iloc[0], curve.iloc[-1]
    blind = (
        f": still above 0.95, so the claim cannot tell a right calibration from one "
        f"{end['heading_error_deg']:.0f} deg off"
        if end["mean"] > 0.95
        else ""
    )
    detected = curve[curve["detected_share"] >= 0.5]
    smallest = (
        f"; the smallest heading error detected in at least half of the units (below the 5th "
        f"percentile of correct calibrations in their own segment and T_ap): "
        f"{detected['heading_error_deg'].iloc[0]:.0f} deg"
        if len(detected)
        else "; no heading error up to the largest tried is detected in half of the units"
    )
    return (
        f"; with the lateral calibration turned {end['heading_error_deg']:.0f} deg the mean moves "
        f"{start['mean']:.3f} -> {end['mean']:.3f} (table obj1_sensitivity){blind}{smallest}"
    )


#: Kong Table 3, feet in T6: the lowest cell (mean, SD over subjects and T_ex)
FOOT_T6 = (0.803, 0.069)


def _minimum_feet_t6(e: Evidence) -> tuple[str, str]:
    cells = e.obj1
    if cells.empty:
        return UNTESTABLE, "needs two sensor sets on the same segments (Table 3)"
    wide = cells.pivot_table(index="subject", columns=["t_ap", "segment"], values="correlation")
    if ("T6", "foot") not in wide.columns:
        return UNTESTABLE, "needs the feet in T6"
    at = list(wide.columns).index(("T6", "foot"))
    share, low, high = resampled(wide, lambda v: float(np.nanargmin(np.nanmean(v, axis=0)) == at))
    lowest_verdict = HOLDS if low == 1.0 else FAILS if high == 0.0 else INCONCLUSIVE
    foot = cell_estimates(
        cells[(cells["t_ap"] == "T6") & (cells["segment"] == "foot")], ["t_ap"], "correlation"
    ).iloc[0]
    about = equivalent_to(foot, *FOOT_T6)
    numbers = (
        f"feet T6 the lowest cell in {share:.0%} of the subjects' resamples; feet T6 "
        f"{interval(foot['mean'], foot['low'], foot['high'], 3)} (paper {FOOT_T6[0]} +- {FOOT_T6[1]})"
    )
    return every([lowest_verdict, about]), numbers


#: "not related" / "highly related" as effect sizes: eta squared below a small effect (0.01) and
#: at least a large one (0.14) (Cohen 1988, Statistical Power Analysis, ch. 8)
SMALL_ETA2, LARGE_ETA2 = 0.01, 0.14


def _factors(e: Evidence) -> tuple[str, str]:
    factors = e.tables.get("correlation_factors")
    rows = (
        factors[factors["objective"] == "Obj 1"]
        if factors is not None and len(factors)
        else pd.DataFrame()
    )
    if rows.empty or not np.isfinite(rows["eta_squared"]).any():
        return UNTESTABLE, "needs two sensor sets and several T_ex and T_ap (Table 3)"
    share = rows.set_index("factor")
    if "aliased" in share and share["aliased"].any():
        return UNTESTABLE, "the design confounds T_ex, T_ap and segment (table correlation_factors)"
    verdicts = [beyond(share.loc["t_ex", "low"], share.loc["t_ex", "high"], SMALL_ETA2, "<")]
    verdicts += [
        beyond(share.loc[f, "low"], share.loc[f, "high"], LARGE_ETA2, ">=")
        for f in ("t_ap", "segment")
    ]
    numbers = "; ".join(
        f"{f}: {interval(share.loc[f, 'eta_squared'], share.loc[f, 'low'], share.loc[f, 'high'], 3)}"
        for f in ("t_ex", "t_ap", "segment")
    )
    return every(verdicts), f"shares of variance {numbers} (n {int(rows['n'].iloc[0])} units)"


def _box(e: Evidence) -> tuple[str, str]:
    box, gyro = _present(e.tables.get(4)), _present(e.tables.get(5))
    if box.empty or gyro.empty:
        return UNTESTABLE, "needs the rigid-box recordings (Tables 4-5)"
    edge = box[box["t_ap"] == "around_one_edge"].set_index("imu")["mean"]
    random = box[box["t_ap"] == "random_rotation"].set_index("imu")["mean"]
    ok = (
        len(edge)
        and edge.min() >= 0.998
        and len(random)
        and random.between(0.947, 0.976).all()
        and (random < edge.reindex(random.index)).all()
        and gyro["mean"].min() >= 0.988
    )
    return HOLDS if ok else FAILS, (
        f"edge {edge.min():.4f}-{edge.max():.4f}; random {random.min():.4f}-{random.max():.4f}; "
        f"gyro min {gyro['mean'].min():.4f} (paper: edge 0.998-0.999, random 0.947-0.976, gyro "
        f"min 0.988)"
    )


def _present(table: pd.DataFrame | None) -> pd.DataFrame:
    return table[table["n"] > 0] if table is not None and len(table) else pd.DataFrame()


# --- Obj 2 ------------------------------------------------------------------------------------


def _rigid_pairs(e: Evidence) -> tuple[str, str]:
    c = e.correlations
    if c is None or c.empty or not (c["objective"] == "segment_pair").any():
        return UNTESTABLE, "needs head/chest or thigh/shank sensors in the rigid-body tests"
    chosen = (c["objective"] == "segment_pair") & (c["signal"] == "acc") & unflagged(c)
    cells = subject_cells(c[chosen], ["pair", "t_ap"], "correlation")
    return cells_against(cells, ["pair", "t_ap"], "correlation", 0.95, ">=", 3)


def _set_rows(e: Evidence, number: int) -> pd.DataFrame:
    """The subject-level test's rows of Table 7, 8 or 10."""
    from aceval.report.set_tests import DEFENSIBLE_TEST

    table = _present(e.tables.get(number))
    return table[table["test"] == DEFENSIBLE_TEST] if len(table) else table


def _unattainable(rows: pd.DataFrame, paper_p: float) -> str:
    n = int(rows["n"].max()) if len(rows) else 0
    smallest = smallest_sign_flip_p(n)
    return (
        f"; with {n} subjects an exact test cannot go below p {smallest:.3g}: the paper's "
        f"p < {paper_p:g} is out of reach by design"
        if smallest > paper_p
        else ""
    )


#: Kong Table 7, thighs-shanks: the between-subject SD of the correlation (frontal 0.019,
#: lateral 0.021): a set difference within it is "no difference"
NO_DIFFERENCE_MARGIN = 0.019


def _segment_pair_sets(e: Evidence) -> tuple[str, str]:
    rows = _set_rows(e, 7)
    if not {"head-chest", "thighs-shanks"} <= set(rows.get("pair", [])):
        return UNTESTABLE, "needs both segment pairs in both sensor sets"
    hc, ts = rows.set_index("pair").loc["head-chest"], rows.set_index("pair").loc["thighs-shanks"]
    lateral_better = beyond(-hc["ci95_high"], -hc["ci95_low"], 0.0, ">")  # a - b < 0
    ts_low90, ts_high90 = _ci90(ts)
    same = equivalent(ts_low90, ts_high90, ts["ci95_low"], ts["ci95_high"], NO_DIFFERENCE_MARGIN)
    hc_interval = interval(hc["mean_difference"], hc["ci95_low"], hc["ci95_high"], 4)
    ts_interval = interval(ts["mean_difference"], ts["ci95_low"], ts["ci95_high"], 4)
    return every([lateral_better, same]), (
        f"head-chest frontal - lateral {hc_interval}; thighs-shanks {ts_interval} (margin "
        f"+-{NO_DIFFERENCE_MARGIN}); n {int(ts['n'])} subjects; the paper-style test on pooled units "
        f"is in Table 7" + _unattainable(rows, 0.01)
    )


def _ci90(row) -> tuple[float, float]:
    """The 90 % interval of a test row's mean difference, from its 95 % one (t, n - 1 df)."""
    from scipy import stats

    n = int(row["n"])
    if n < 2 or not np.isfinite(row["ci95_low"]):
        return float("nan"), float("nan")
    half95 = (row["ci95_high"] - row["ci95_low"]) / 2
    half90 = half95 * stats.t.ppf(0.95, n - 1) / stats.t.ppf(0.975, n - 1)
    return row["mean_difference"] - half90, row["mean_difference"] + half90


def _set_preference(number: int):
    """Table ``number`` (8 or 10): the paper's better set for every segment (frontal for the
    upper body, lateral for the lower), judged on the subjects' interval of the difference.
    """

    def judge(e: Evidence) -> tuple[str, str]:
        rows = _set_rows(e, number)
        if rows.empty:
            return UNTESTABLE, "needs two sensor sets"
        verdicts, parts = [], []
        for _, r in rows.iterrows():  # difference a - b: the frontal (a) better where negative
            expected_a = r["segment"] in UPPER
            lo, hi = (
                (r["ci95_low"], r["ci95_high"])
                if not expected_a
                else (-r["ci95_high"], -r["ci95_low"])
            )
            verdicts.append(beyond(lo, hi, 0.0, ">"))
            parts.append(
                f"{r['segment']} {interval(r['mean_difference'], r['ci95_low'], r['ci95_high'])}"
            )
        return every(verdicts), (
            f"frontal - lateral (deg): {'; '.join(parts)}; n {int(rows['n'].max())} subjects"
            + _unattainable(rows, 0.001)
        )

    return judge


RULES = [
    Rule(
        "Obj 1",
        "Frontal vs lateral acceleration correlation is mostly > 0.95",
        "the share of Table 3 cells (T_ap x segment) whose subject mean is > 0.95 is above 50 % "
        '("mostly"), its interval from resampling the subjects',
        _mostly_above,
    ),
    Rule(
        "Obj 1",
        "The minimum, about 0.8, is the feet in T6",
        "feet T6 is the lowest Table 3 cell in every resample of the subjects, and its mean is "
        f"within the paper's SD of the paper's value ({FOOT_T6[0]} +- {FOOT_T6[1]}, Table 3: two "
        "one-sided tests)",
        _minimum_feet_t6,
    ),
    Rule(
        "Obj 1-2",
        "The correlation is not related with T_ex but highly related with T_ap and body segment",
        f"share of variance (eta squared, type II, additive model of the Obj 1 units) of T_ex below a "
        f"small effect ({SMALL_ETA2}), of T_ap and of segment each at least a large one "
        f"({LARGE_ETA2}) (Cohen 1988); intervals from resampling the subjects",
        _factors,
    ),
    Rule(
        "Obj 1 (box)",
        "Rigid box: acceleration correlation >= 0.998 for rotation about one edge, "
        "about 0.95-0.98 for random rotation; gyro >= 0.988",
        "one box (no subjects: judged on its values): Table 4 'around_one_edge' >= 0.998 for every "
        "IMU; 'random_rotation' within the paper's range 0.947-0.976 and below the edge value; "
        "Table 5 >= 0.988 everywhere (the paper's values)",
        _box,
    ),
    Rule(
        "Obj 2",
        "Head-chest and thighs-shanks correlations are high, 0.956-0.979 (Table 6)",
        "every Table 6 cell's subject mean >= 0.95 (the paper's own threshold for a high "
        "correlation, Sec. 3.1)",
        _rigid_pairs,
    ),
    Rule(
        "Obj 2",
        "Paired t-test: lateral set better for head-chest (p < 0.01); thighs-shanks no "
        "difference (p = 0.682)",
        "on the subjects (Table 7): head-chest, the interval of frontal - lateral below 0; "
        f"thighs-shanks, its 90 % interval within +-{NO_DIFFERENCE_MARGIN} (the paper's SD of "
        "that correlation, Table 7: two one-sided tests)",
        _segment_pair_sets,
    ),
    Rule(
        "Obj 3",
        "'Incremental' error angle < 2.5 deg on average for every T_ex and segment",
        "every (T_ex, segment, k) cell's subject mean < 2.5 deg",
        angles_below("incremental", ["test", "segment", "k"], 2.5),
    ),
    Rule(
        "Obj 3",
        "< 1 deg once 3 repetitions are included",
        "every cell with k >= 3: subject mean < 1 deg",
        angles_below("incremental", ["test", "segment", "k"], 1.0, lambda c: c["k"] >= 3),
    ),
    Rule(
        "Obj 3",
        "'To last' (1 vs all repetitions) < 3 deg",
        "every (T_ex, segment, k) cell's subject mean < 3 deg",
        angles_below("to_last", ["test", "segment", "k"], 3.0),
    ),
    Rule(
        "Obj 3",
        "Lower limbs change more than the upper body ('to last')",
        "per subject, the mean to-last angle of thigh/shank/foot minus head/chest/waist > 0",
        lower_than_upper,
    ),
    Rule(
        "Obj 3",
        "T6 (walking) converges faster than T5 (leg swing)",
        "per subject and lower-limb segment, the mean to-last angle from T5 minus T6 > 0",
        t6_faster,
    ),
    Rule(
        "Obj 3",
        "Frontal set better for the upper body, lateral for the lower body, all p < 0.001 "
        "(Table 8)",
        "on the subjects (Table 8): for every segment the interval of frontal - lateral excludes 0 "
        "on the paper's side (frontal smaller for head/chest/waist, lateral for thigh/shank/foot)",
        _set_preference(8),
    ),
    Rule(
        "Obj 4",
        "Any-3-of-5 test-retest error angle < 2.1 deg on average",
        "every Table 9 cell's subject mean < 2.1 deg",
        angles_below("test_retest", ["test", "segment"], 2.1),
    ),
    Rule(
        "Obj 4",
        "< 1 deg excluding T5 and the feet",
        "every other Table 9 cell's subject mean < 1 deg",
        angles_below(
            "test_retest",
            ["test", "segment"],
            1.0,
            lambda c: (c["test"] != "T5") & (c["segment"] != "foot"),
        ),
    ),
    Rule(
        "Obj 4",
        "Same set preference as Obj 3 (Table 10)",
        "as Obj 3's, on Table 10",
        _set_preference(10),
    ),
    Rule(
        "Obj 5",
        "Cross-test error angles <= about 5 deg except the feet and the thighs with T3",
        f"every other Table 11 cell's subject mean <= {ABOUT_5_DEG} deg (the paper's largest such "
        f"cell, waist T1-T3: what its 'about 5' reaches)",
        cross_small,
    ),
    Rule(
        "Obj 5",
        "Feet (8-10 deg) and thighs with T3 (10-14 deg) are larger",
        f"every foot and T3-thigh cell's subject mean > {ABOUT_5_DEG} deg (larger than every "
        f"other cell of the paper)",
        cross_large,
    ),
    Rule(
        "Obj 5",
        "Recommendation: T3 (sit-to-stand) for head/chest/waist, T6 (walking) for "
        "thighs/shanks: competitive with the designed tests, error angle at most 5.39 / below "
        "5.12 deg (Table 11)",
        "every Table 11 cell comparing the recommended test with a designed one (head/chest/"
        "waist: T1-T3, T2-T3, subject mean <= 5.39; thigh: T5-T6; shank: T4-T6, T5-T6, < 5.12 deg: "
        "the paper's words)",
        recommendation,
    ),
    Rule(
        "Obj 3-5",
        "Every error angle is a rotation about z0 (all calibrations of an IMU share z0 "
        "from T0): true by construction, so a check of the code, not a finding",
        "smallest share of the error rotation about the body vertical > 0.999",
        about_z0,
        CODE,
    ),
    Rule(
        "ground truth",
        "Kong's recommended test is (nearly) the most accurate one for its segments",
        f"with ground truth, per segment with two tests or more: the recommended test is the "
        f"best, or its error minus the best test's (per subject) is below {SAME_CALIBRATION_DEG} "
        f"deg (Kong's test-retest bound, Obj 4: calibrations closer are not told apart)",
        recommended_most_accurate,
        GROUND_TRUTH,
    ),
]


def kong_claims(tables: dict, data: dict) -> list:
    """Every Kong et al. 2016 claim (:data:`RULES`) from the Kong tables and the tidy tables of
    ``data`` (correlations, angles, calibrations); the ground-truth check only with a truth.
    """
    evidence = Evidence(
        tables, data.get("correlations"), data.get("angles"), data.get("calibrations")
    )
    found = [rule.apply(evidence) for rule in RULES]
    return [
        c
        for c in found
        if not (
            c.section == GROUND_TRUTH and c.verdict == UNTESTABLE and c.numbers == "no ground truth"
        )
    ]
