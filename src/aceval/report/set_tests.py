"""Kong Tables 7, 8 and 10: the first vs the second sensor set, four tests of the same contrast per
row (the paper's on pooled units, one on the subjects, two mixed models), and the subject-level
units behind the test on which the claims are judged (committed, so that its p can be recomputed).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import unflagged

#: the tests of a set comparison, in the order they are shown (Tables 7, 8, 10)
SET_TESTS = {
    "paper": "paper-style paired t-test on pooled dependent units",
    "units": "paired t-test on subjects (per-subject means: its IMUs and sides averaged)",
    "mixed": "mixed model of the paired differences, random intercept per subject",
    "mixed_nested": "mixed model of the paired differences, subject and IMU (Table 7: side) "
    "within subject",
}
#: the test on which set-preference claims are judged
DEFENSIBLE_TEST = "units"
TTEST_TABLE_COLUMNS = [
    "test", "mean_a", "sd_a", "mean_b", "sd_b", "mean_difference", "ci95_low", "ci95_high",
    "cohens_dz", "n", "n_groups", "t", "z", "p", "note", "fit_flags",
]  # fmt: skip


def _compared(number: int, correlations, angles) -> tuple:
    """(rows compared, the table's row column, value, the level nested in the subject, the paper's
    pairing) of Table ``number``.
    """
    if number == 7:
        data = correlations[(correlations["objective"] == "segment_pair") & unflagged(correlations)]
        return data, "pair", "correlation", "side", ["subject", "side", "t_ex", "t_ap", "rep"]
    comparison = "incremental" if number == 8 else "test_retest"
    data = angles[angles["comparison"] == comparison]
    pair_on = ["subject", "imu", "test", "calibration_a", "calibration_b"]
    return data, "segment", "error_angle_deg", "imu", pair_on


def set_test_units(
    sensor_sets: list[str], correlations: pd.DataFrame | None, angles: pd.DataFrame | None
) -> pd.DataFrame:
    """The units of the test on which the set-preference claims are judged
    (:data:`DEFENSIBLE_TEST`), for Tables 7, 8 and 10: each subject's mean per set (its IMUs and
    sides averaged), one row per table, table row and subject with both sets (``mean_a``: the
    first set). The committed table lets anyone recompute that test's p (tests/test_tables.py).
    """
    columns = ["table", "row", "subject", "set_a", "set_b", "mean_a", "mean_b"]
    sets = list(sensor_sets)[:2]
    out = []
    for number, source in ((7, correlations), (8, angles), (10, angles)):
        if source is None or source.empty or len(sets) < 2:
            continue
        data, rows, value, _, _ = _compared(number, correlations, angles)
        wide = data.pivot_table(index=[rows, "subject"], columns="sensor_set", values=value)
        if not set(sets) <= set(wide.columns):
            continue
        wide = wide[sets].dropna().reset_index()
        out.append(
            pd.DataFrame({"table": number, "row": wide[rows], "subject": wide["subject"],
                          "set_a": sets[0], "set_b": sets[1], "mean_a": wide[sets[0]],
                          "mean_b": wide[sets[1]]})
        )  # fmt: skip
    if not out:
        return pd.DataFrame(columns=columns)
    # 10 decimals: enough to recompute each p to its third digit, and stable across machines
    return pd.concat(out, ignore_index=True).round({"mean_a": 10, "mean_b": 10})


def ttest_table(
    number: int,
    correlations: pd.DataFrame | None,
    angles: pd.DataFrame | None,
    sensor_sets: list[str],
    published: pd.DataFrame,
) -> pd.DataFrame:
    """First vs second sensor set of the dataset (the paper's frontal/back vs lateral): per row of
    the paper's table, four tests of the same contrast (:data:`SET_TESTS`): the paper-style paired
    t-test on pooled units (what the paper did: repetitions, subsets and T_ex are not independent,
    so its p is optimistic), a paired t-test on per-subject means (the subject is the independent
    unit: a subject's left and right thighs are not two), and two mixed models of the paired
    differences. ``p_holm`` corrects each test's p within the table (one family per test; a
    failed fit has no p and is not in it).
    """
    from aceval.evaluation.stats import holm, mixed_model_by_set, paired_by_set, unit_means_by_set

    set_a, set_b = (list(sensor_sets) + ["(no second set)"] * 2)[:2]  # one set: n = 0
    sets = [set_a, set_b]
    data, rows, value, nested, pair_on = _compared(number, correlations, angles)
    results = []
    for key, group in data.groupby(rows, sort=False):
        for test in SET_TESTS:
            if test == "paper":
                result = paired_by_set(group, value, pair_on, sets)
            elif test == "units":
                result = unit_means_by_set(group, value, ["subject"], sets)
            else:
                result = mixed_model_by_set(
                    group, value, pair_on, sets, nested=nested if test == "mixed_nested" else None
                )
            results.append({rows: key, "test": test, **result})
    result = pd.DataFrame(results, columns=[rows, *TTEST_TABLE_COLUMNS])
    result["p_holm"] = np.nan
    for _, index in result.groupby("test", sort=False).groups.items():
        result.loc[index, "p_holm"] = holm(result.loc[index, "p"])
    # for an angle the smaller set is the better one (the paper's grey cells); for a correlation
    # the larger one (Table 7 marks none)
    better_a = (
        result["mean_a"] > result["mean_b"] if number == 7 else result["mean_a"] < result["mean_b"]
    )
    better_b = (
        result["mean_b"] > result["mean_a"] if number == 7 else result["mean_b"] < result["mean_a"]
    )
    result["better"] = np.where(better_a, set_a, np.where(better_b, set_b, ""))
    suffix = "" if number == 7 else "_deg"
    published = published.rename(
        columns={
            f"frontal_mean{suffix}": "published_mean_a",
            f"lateral_mean{suffix}": "published_mean_b",
            "frontal_sd": "published_sd_a",
            "lateral_sd": "published_sd_b",
            "p_value": "published_p",
        }
    )
    merged = result.merge(published, on=rows, how="outer")
    high, low = ("frontal", "lateral")
    published_a_better = (
        merged["published_mean_a"] > merged["published_mean_b"]
        if number == 7
        else merged["published_mean_a"] < merged["published_mean_b"]
    )
    published_b_better = (
        merged["published_mean_b"] > merged["published_mean_a"]
        if number == 7
        else merged["published_mean_b"] < merged["published_mean_a"]
    )
    merged["published_better"] = np.where(
        published_a_better, high, np.where(published_b_better, low, "")
    )
    merged["test"] = merged["test"].fillna("paper")
    merged.insert(1, "set_a", set_a)
    merged.insert(2, "set_b", set_b)
    return merged
