"""Kong Tables 7, 8 and 10: the first vs the second sensor set, three tests of the same contrast
per row (the paper's on pooled units, one on the subjects, a mixed model of the IMUs within the
subjects), and the cells behind the last two (committed, so that their p can be recomputed).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.evaluation.stats import cell_means_by_set

#: the tests of a set comparison, in the order they are shown (Tables 7, 8, 10)
SET_TESTS = {
    "paper": "paper-style paired t-test on pooled dependent units",
    "units": "paired t-test on subjects (each subject's mean over its IMUs, or sides)",
    "mixed": "mixed model of the IMUs' (Table 7: sides') mean paired differences, random "
    "intercept per subject",
}
#: the test on which set-preference claims are judged
DEFENSIBLE_TEST = "units"
TTEST_TABLE_COLUMNS = [
    "test",
    "mean_a",
    "sd_a",
    "mean_b",
    "sd_b",
    "mean_difference",
    "ci95_low",
    "ci95_high",
    "cohens_dz",
    "n",
    "n_groups",
    "t",
    "df",
    "p",
    "smallest_p",
    "note",
    "fit_flags",
]


def _compared(number: int, correlations, angles) -> tuple:
    """(rows compared, the table's row column, value, the cell within the subject, the paper's
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
    """The cells behind the tests on subjects and the mixed models of Tables 7, 8 and 10: per
    table, table row, subject and cell (IMU; Table 7: side), the mean of the paired values in
    each set (``mean_a``: the first set). The committed table lets anyone recompute both tests'
    p (tests/test_tables.py); the paper-style test reads every pooled pair, too many to commit.
    """
    columns = ["table", "row", "subject", "cell", "set_a", "set_b", "mean_a", "mean_b"]
    sets = list(sensor_sets)[:2]
    out = []
    for number, source in ((7, correlations), (8, angles), (10, angles)):
        if source is None or source.empty or len(sets) < 2:
            continue
        data, rows, value, cell, pair_on = _compared(number, correlations, angles)
        for key, group in data.groupby(rows, sort=False):
            cells = cell_means_by_set(group, value, pair_on, ["subject", cell], sets)
            out.append(
                cells.rename(columns={cell: "cell"}).assign(
                    table=number, row=key, set_a=sets[0], set_b=sets[1]
                )
            )
    if not out:
        return pd.DataFrame(columns=columns)
    # 10 decimals: enough to recompute each p to its third digit, and stable across machines
    return pd.concat(out, ignore_index=True)[columns].round({"mean_a": 10, "mean_b": 10})


def ttest_table(
    number: int,
    correlations: pd.DataFrame | None,
    angles: pd.DataFrame | None,
    sensor_sets: list[str],
    published: pd.DataFrame,
) -> pd.DataFrame:
    """First vs second sensor set of the dataset (the paper's frontal/back vs lateral): per row of
    the paper's table, three tests of the same contrast (:data:`SET_TESTS`): the paper-style
    paired t-test on pooled units (what the paper did: repetitions, subsets and T_ex are not
    independent, so its p is optimistic), a paired t-test on the subjects (the independent unit: a
    subject's left and right thighs are not two), and a mixed model of the cells (each IMU's, or
    side's, mean paired difference, a random intercept per subject). ``smallest_p``: what an exact
    test on these subjects can reach. ``p_holm`` corrects each test's p within the table (one
    family per test; a failed fit has no p and is not in it).
    """
    from aceval.evaluation.stats import holm, mixed_model_of_cells, paired_by_set, subject_test

    set_a, set_b = (list(sensor_sets) + ["(no second set)"] * 2)[:2]  # one set: n = 0
    sets = [set_a, set_b]
    data, rows, value, cell, pair_on = _compared(number, correlations, angles)
    results = []
    for key, group in data.groupby(rows, sort=False):
        cells = cell_means_by_set(group, value, pair_on, ["subject", cell], sets)
        tests = {
            "paper": paired_by_set(group, value, pair_on, sets),
            "units": subject_test(cells),
            "mixed": mixed_model_of_cells(cells),
        }
        results += [{rows: key, "test": test, **result} for test, result in tests.items()]
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
