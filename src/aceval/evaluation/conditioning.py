"""Beyond both papers: how well each of Kong's motion tests determines a calibration, by two
reliability indices (rho of the gyroscope axis, Ricci Eq. 2; Kong's planarity) and by the
conditioning of Kong's plane (its eigenvalue ratio), and how these indices rank against the
Obj 4 test-retest angle.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import CALIBRATION_KEY, full_set_rows, full_sets, rows_of_method
from aceval.evaluation.stats import holm
from aceval.methods.kong import KongLimits


def kong_units(
    axes: pd.DataFrame, calibrations: pd.DataFrame, angles: pd.DataFrame | None
) -> pd.DataFrame:
    """One row per (subject, set, IMU, motion test): rho of the gyroscope axis (Ricci), Kong's
    planarity (smallest/largest eigenvalue of the acceleration second moment; 0 = a perfect
    plane), both from all repetitions, and the mean Obj 4 test-retest angle (deg).
    """
    key = ["subject", "sensor_set", "imu", "test"]
    motion = axes[axes["kind"] == "motion"][key + ["segment", "side", "rho"]]
    units = motion.merge(full_sets(calibrations)[key + ["planarity"]], on=key, how="left")
    if angles is not None and len(angles):
        retest = (
            angles[angles["comparison"] == "test_retest"]
            .groupby(key)["error_angle_deg"]
            .mean()
            .rename("test_retest_deg")
            .reset_index()
        )
        units = units.merge(retest, on=key, how="left")
    else:
        units["test_retest_deg"] = np.nan
    return units


INDICES = {
    "rho_gyro": "rho of the gyroscope axis (Ricci Eq. 2; 1 = one axis)",
    "planarity": "Kong planarity (smallest/largest eigenvalue; 0 = one plane)",
}


def kong_reliability_table(units: pd.DataFrame) -> pd.DataFrame:
    """Both indices in Table 1's layout: mean, SD and n per test and segment."""
    long = units.rename(columns={"rho": "rho_gyro"}).melt(
        id_vars=["test", "segment"], value_vars=list(INDICES), var_name="index", value_name="value"
    )
    return (
        long.groupby(["index", "test", "segment"])["value"]
        .agg(mean="mean", sd="std", n="count")
        .reset_index()
    )


def heading_status(normal_ratio: pd.Series) -> pd.Series:
    """'determined' where Kong's smallest/middle eigenvalue ratio is at most
    :attr:`KongLimits.max_normal_ratio` (0.5), 'undetermined' above (the plane's normal cannot be
    told from the in-plane axis), '' where there is no ratio.
    """
    limit = KongLimits().max_normal_ratio
    return pd.Series(
        np.where(
            normal_ratio > limit,
            "undetermined",
            np.where(normal_ratio.notna(), "determined", ""),
        ),
        index=normal_ratio.index,
    )


def conditioning_table(calibrations: pd.DataFrame) -> pd.DataFrame:
    """How well each test determines each IMU's heading by Kong's plane: per (subject, set, IMU,
    test), from the calibration of all repetitions, flagged ones included, the eigenvalue ratio
    (smallest/middle; above 0.5 the heading is 'undetermined'), the planarity (smallest/largest)
    and the calibration's flag.
    """
    columns = CALIBRATION_KEY + [
        "segment",
        "side",
        "n_reps",
        "normal_ratio",
        "planarity",
        "heading",
        "flag",
    ]
    kong = rows_of_method(calibrations)
    if kong.empty or "normal_ratio" not in kong:
        return pd.DataFrame(columns=columns)
    full = full_set_rows(kong).copy()
    full["heading"] = heading_status(full["normal_ratio"])
    full["flag"] = full["flag"].astype(object).fillna("")
    return full.sort_values(CALIBRATION_KEY)[columns].reset_index(drop=True)


def reliability_vs_retest(units: pd.DataFrame) -> pd.DataFrame:
    """Spearman rank correlation of each index with the test-retest angle, over all units and
    within each test (n = units).
    """
    rows = []
    data = units.rename(columns={"rho": "rho_gyro"})
    for index in INDICES:
        for test, group in [("all", data), *data.groupby("test", sort=True)]:
            pair = group[[index, "test_retest_deg"]].dropna()
            if (
                len(pair) >= 3
                and pair[index].nunique() > 1
                and pair["test_retest_deg"].nunique() > 1
            ):
                from scipy import stats

                result = stats.spearmanr(pair[index], pair["test_retest_deg"])
                rho_s, p = float(result.statistic), float(result.pvalue)
            else:
                rho_s, p = np.nan, np.nan
            rows.append({"index": index, "test": test, "spearman_r": rho_s, "p": p, "n": len(pair)})
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"])
    return table
