"""The rows of the calibrations and axes tables: an IMU's identity, one row per method's fit
(R, diagnostics, flag; the errors to the truth left empty for evaluation to fill), one row per
functional axis.
"""

from __future__ import annotations

import numpy as np

from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import Dataset


def imu_identity(dataset: Dataset, subject: str, sensor_set: str, imu: str) -> dict:
    """The key and place columns of an IMU's rows: subject, set, IMU, segment and side."""
    segment, side = dataset.imus.loc[(sensor_set, imu), ["segment", "side"]]
    return {
        "subject": subject,
        "sensor_set": sensor_set,
        "imu": imu,
        "segment": segment,
        "side": side,
    }


def error_placeholders(R) -> dict:
    """Empty ``error_deg`` and ``error_vertical_share`` for ``R`` (3x3 or a stack): calibration
    knows no truth; :func:`aceval.evaluation.methods_comparison.with_truth` fills them in.
    """
    shape = np.shape(R)[:-2] if R is not None else ()
    return {"error_deg": np.full(shape, np.nan), "error_vertical_share": np.full(shape, np.nan)}


def method_rows(base: dict, fits: dict) -> list[dict]:
    """One calibration row per method of ``fits`` (R, diagnostics, flag; the errors to the truth
    empty).
    """
    rows = []
    for method, fit in fits.items():
        R = fit.get("R")
        row = {
            **base,
            "method": method,
            **dict(zip(R_COLUMNS, R.ravel() if R is not None else [np.nan] * 9)),
            "flag": fit.get("flag", ""),
            **{k: float(v) for k, v in error_placeholders(R).items()},
        }
        row.update({k: v for k, v in fit.items() if k in FIT_COLUMNS})
        rows.append(row)
    return rows


FIT_COLUMNS = [
    "n_iterations",
    "n_rejected",
    "optimum_distance_deg",
    "fixed_n_iterations",
    "fixed_cost",
    "fixed_optimum_distance_deg",
    "fixed_converged",
    "converged",
    "cost",
    "random_starts",
    "random_starts_optimum",
    "random_start_iterations_mean",
    "random_start_iterations_max",
    "first_phase_agreement",
    "right_axis_angle_deg",
    "weight_kong",
    "weight_gyro",
    "cone95_deg",
    "cone_vertical_share",
    "step_ratio",
    "step_hz",
    "note",
]


AXES_COLUMNS = [
    "subject",
    "sensor_set",
    "imu",
    "segment",
    "side",
    "test",
    "kind",
    "signal",
    "n_recordings",
    "n_samples",
    "axis_x",
    "axis_y",
    "axis_z",
    "rho",
    "reference",
    "residual_before_deg",
    "residual_after_deg",
]


def axis_row(
    identity: dict, test: str, kind: str, estimate, reference: str, n_recordings: int | None = None
) -> dict:
    """One row of the axes table (:data:`AXES_COLUMNS`) from a functional axis ``estimate``."""
    return {
        **identity,
        "test": test,
        "kind": kind,
        "signal": "acc" if kind == "static" else "gyr",
        "n_recordings": n_recordings,
        "n_samples": estimate.n_samples,
        "axis_x": estimate.axis[0],
        "axis_y": estimate.axis[1],
        "axis_z": estimate.axis[2],
        "rho": estimate.rho,
        "reference": reference,
        "residual_before_deg": np.nan,
        "residual_after_deg": np.nan,
    }
