"""Every calibration method side by side against the ground truth (beyond both papers).

Input: the calibrations table of ``aceval calibrate`` on a dataset with ``ground_truth.tsv``
(``error_deg`` = angle of R R_true^T, Kong Eq. 11; ``error_vertical_share`` = the part of that
rotation about the body vertical). Each method is judged on its calibration from all repetitions
of a test (Ricci's functional design: from all its axes).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .objectives import unflagged
from .tables import SEGMENT_ORDER

#: Kong et al. 2016 Sec. 4: the test recommended for each segment
KONG_RECOMMENDATION = {"head": "T3", "chest": "T3", "waist": "T3", "thigh": "T6", "shank": "T6"}
METHOD_ORDER = ["kong", "ricci_lm", "align_vectors", "triad"]
KEY = ["subject", "sensor_set", "imu", "test", "method"]


def full_set_errors(calibrations: pd.DataFrame) -> pd.DataFrame:
    """The unflagged calibrations from all repetitions, with a finite error to the truth."""
    data = calibrations[unflagged(calibrations)]
    data = data[data["n_reps"] == data.groupby(KEY[:-1] + ["method"])["n_reps"].transform("max")]
    return data[np.isfinite(data["error_deg"])]


def _p95(values: pd.Series) -> float:
    return float(np.percentile(values, 95))


def methods_table(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Error to the true mounting (deg) per method x test x segment x sensor set: mean, SD,
    median, 95th percentile, n, and the median share of the error about the vertical axis.
    """
    data = full_set_errors(calibrations)
    table = (
        data.groupby(["segment", "test", "sensor_set", "method"])
        .agg(
            mean=("error_deg", "mean"),
            sd=("error_deg", "std"),
            median=("error_deg", "median"),
            p95=("error_deg", _p95),
            n=("error_deg", "count"),
            vertical_share=("error_vertical_share", "median"),
        )
        .reset_index()
    )
    table["method_rank"] = table["method"].map({m: i for i, m in enumerate(METHOD_ORDER)})
    return table.sort_values(["segment", "test", "sensor_set", "method_rank"]).drop(
        columns="method_rank"
    )


def method_medians(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Per method: the median error over all calibrations and the median of the per-segment medians."""
    data = full_set_errors(calibrations)
    per_segment = data.groupby(["method", "segment"])["error_deg"].median()
    return pd.DataFrame(
        {
            "median_deg": data.groupby("method")["error_deg"].median(),
            "median_of_segment_medians_deg": per_segment.groupby("method").median(),
            "n": data.groupby("method")["error_deg"].count(),
        }
    ).reset_index()


def best_tests(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Per segment and method, the test whose calibrations have the smallest median error (both
    sensor sets pooled), with Kong's recommended test and its median error beside it.
    """
    data = full_set_errors(calibrations)
    medians = data.groupby(["segment", "method", "test"])["error_deg"].median().reset_index()
    rows = []
    for (segment, method), group in medians.groupby(["segment", "method"], sort=True):
        best = group.loc[group["error_deg"].idxmin()]
        recommended = KONG_RECOMMENDATION.get(segment, "")
        at_recommended = group.loc[group["test"] == recommended, "error_deg"]
        rows.append(
            {
                "segment": segment,
                "method": method,
                "best_test": best["test"],
                "best_median_deg": best["error_deg"],
                "kong_recommends": recommended,
                "recommended_median_deg": float(at_recommended.iloc[0])
                if len(at_recommended)
                else np.nan,
            }
        )
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    rank = table["segment"].map(
        lambda s: SEGMENT_ORDER.index(s) if s in SEGMENT_ORDER else len(SEGMENT_ORDER)
    )
    table["method_rank"] = table["method"].map({m: i for i, m in enumerate(METHOD_ORDER)})
    return (
        table.assign(segment_rank=rank)
        .sort_values(["segment_rank", "segment", "method_rank"])
        .drop(columns=["segment_rank", "method_rank"])
    )


#: a ground truth disagreeing by more than this with most IMUs' calibrations is suspect
SUSPECT_TRUTH_DEG = 90.0


def truth_warning(calibrations: pd.DataFrame) -> str:
    """A warning when, for most IMUs with a ground truth, the median error of their valid
    calibrations exceeds 90 deg: a transposed matrix (sensor <- body instead of body <- sensor) or
    rows given to the wrong IMUs is likelier than a method that far off. '' otherwise.
    """
    if "error_deg" not in calibrations:
        return ""
    data = calibrations[(unflagged(calibrations)) & np.isfinite(calibrations["error_deg"])]
    per_imu = data.groupby(["subject", "sensor_set", "imu"])["error_deg"].median()
    if per_imu.empty or (per_imu > SUSPECT_TRUTH_DEG).mean() <= 0.5:
        return ""
    return (
        f"WARNING: for {int((per_imu > SUSPECT_TRUTH_DEG).sum())} of {len(per_imu)} IMUs every method "
        f"is more than {SUSPECT_TRUTH_DEG:g} deg from ground_truth.tsv: is the truth transposed (R must "
        f"map sensor to body, d_body = R d_sensor) or given to the wrong IMUs?"
    )
