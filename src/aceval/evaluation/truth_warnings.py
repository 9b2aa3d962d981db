"""Warnings about a dataset's ground truth from the calibrations' errors to it: a truth that
most IMUs' calibrations of every method disagree with is likelier wrong than the methods (a
transposed matrix, rows given to the wrong IMUs), and an IMU whose calibrations are its truth
turned 180 deg about the body's right axis shows an accelerometer read with the other sign.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.data.contract import R_COLUMNS
from aceval.data.rotations import error_angle_deg
from aceval.evaluation.methods_comparison import full_set_errors

#: a ground truth disagreeing by more than this with most IMUs' calibrations is suspect
SUSPECT_TRUTH_DEG = 90.0
#: a warning's explanation of an IMU's error to the truth holds when its calibrations from all
#: repetitions are, in the median, within this (deg) of what the explanation predicts
EXPLAINED_DEG = 20.0
#: the calibration an accelerometer read with the other sign gives: z0 and the forward axis
#: turned over, y kept by the declared right axis (180 deg about the body's right axis)
REVERSED = np.diag([-1.0, 1.0, -1.0])


def _explained(data: pd.DataFrame, ground_truth: pd.DataFrame) -> pd.DataFrame:
    """Per IMU (subject, set, IMU), the median angle (deg) of its calibrations ``data`` to the
    truth turned about the right axis (``reversed``) and to the truth transposed (``transposed``).
    """
    keys = list(zip(data["subject"], data["sensor_set"], data["imu"]))
    known = np.array([key in ground_truth.index for key in keys], dtype=bool)
    data = data[known]
    truth = (
        ground_truth.loc[[k for k, ok in zip(keys, known) if ok], R_COLUMNS]
        .to_numpy(float)
        .reshape(-1, 3, 3)
    )
    R = data[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    angles = data[["subject", "sensor_set", "imu"]].assign(
        reversed=error_angle_deg(R, REVERSED @ truth),
        transposed=error_angle_deg(R, np.transpose(truth, (0, 2, 1))),
    )
    return angles.groupby(["subject", "sensor_set", "imu"])[["reversed", "transposed"]].median()


def truth_warning(calibrations: pd.DataFrame, ground_truth: pd.DataFrame | None = None) -> str:
    """Warnings (lines) from each IMU's valid calibrations from all repetitions
    (:func:`full_set_errors`) against the truth (``ground_truth``: indexed by subject, set, IMU,
    with r11..r33): the IMUs whose calibrations are the truth turned 180 deg about the body's
    right axis (:data:`REVERSED`: an accelerometer read with the other sign), named however
    few; and, when most IMUs are more than 90 deg from the truth and a transposed truth
    (sensor <- body instead of body <- sensor) alone explains as many of them as a reversed
    accelerometer alone, that (or rows given to the wrong IMUs), likelier than a method that
    far off (a sensor mounted 90 deg about the right axis cannot tell the two apart: both are
    said). Without ``ground_truth`` only the
    second, from the errors alone. '' when neither.
    """
    if "error_deg" not in calibrations:
        return ""
    data = full_set_errors(calibrations)
    per_imu = data.groupby(["subject", "sensor_set", "imu"])["error_deg"].median()
    if per_imu.empty:
        return ""
    far = per_imu > SUSPECT_TRUTH_DEG
    lines, reversed_only, transposed_only = [], 0, int(far.sum())
    if ground_truth is not None and far.any():
        explained = _explained(data, ground_truth).reindex(per_imu.index)
        reversed_ = far & (explained["reversed"] < EXPLAINED_DEG)
        either = reversed_ & (explained["transposed"] < EXPLAINED_DEG)
        reversed_only = int((reversed_ & ~either).sum())
        transposed_only = int((far & (explained["transposed"] < EXPLAINED_DEG) & ~either).sum())
        if reversed_.any():
            names = ", ".join(" ".join(map(str, key)) for key in reversed_.index[reversed_][:6])
            more = " ..." if reversed_.sum() > 6 else ""
            lines.append(
                f"WARNING: for {int(reversed_.sum())} of {len(per_imu)} IMUs ({names}{more}) "
                "every method is the truth of ground_truth.tsv turned 180 deg about the body's "
                "right axis: what an accelerometer read with the other sign gives. Does it read "
                "up at rest (specific force: dataset.yaml acc_at_rest: up, the default) or down "
                "(gravity: acc_at_rest: down)? Or is one sensor's accelerometer reversed?"
                + (
                    f" (for {int(either.sum())} of them a transposed truth would give the same)"
                    if either.any()
                    else ""
                )
            )
    if far.mean() > 0.5 and transposed_only >= reversed_only:
        lines.append(
            f"WARNING: for {int(far.sum())} of {len(per_imu)} IMUs every method is more than "
            f"{SUSPECT_TRUTH_DEG:g} deg from ground_truth.tsv: is the truth transposed (R must "
            "map sensor to body, d_body = R d_sensor) or given to the wrong IMUs?"
        )
    return "\n".join(lines)
