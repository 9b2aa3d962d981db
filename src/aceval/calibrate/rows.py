"""The rows of the calibrations and axes tables: one row per method's fit (R, diagnostics, flag;
the errors to the truth left empty for evaluation to fill), from the fits of the sagittal design
(:func:`calibration_rows`, :func:`motion_axes`) or one design's dicts (:func:`method_rows`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.plan import SENSOR_COLUMNS, Plan, Subsets
from aceval.calibrate.table import IDENTITY_COLUMNS
from aceval.data.contract import R_COLUMNS
from aceval.methods import registry
from aceval.methods.interface import Fit, combine_flags
from aceval.methods.sufficient import Pooled
from aceval.methods.uncertainty import undetermined


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
        declared = registry.method(method).load().diagnostics
        row.update({k: v for k, v in fit.items() if k in declared})
        rows.append(row)
    return rows


#: the columns every calibration of the sagittal design has, in the table's order; each method's
#: declared ``diagnostics`` follow (:func:`table_columns`)
SHARED_COLUMNS = [
    *IDENTITY_COLUMNS,
    *R_COLUMNS,
    "n_samples",
    "rho_static",
    "rho_motion",
    "z0_tests",
    "first_phase_agreement",
    "right_axis_angle_deg",
    "right_axis_sign_verified",
    "gyro_acc_agreement",
    "gyro_acc_evidence_deg",
    "static_vertical_angle_deg",
    "gyro_bias_deg_s",
    "static_spread_deg",
    "vendor_up_angle_deg",
    "acc_sign_agreement",
    "flag",
    "sensor_flag",
    "error_deg",
    "error_vertical_share",
    "cone_deg",
    "cone_fit",
    "spread95_deg",
    "spread_vertical_share",
    "heading_signals_deg",
    "heading_tests_deg",
    "conditioning_deg",
    "axis_spread_deg",
    "full_set_angle_deg",
]


def table_columns() -> list[str]:
    """The calibrations table's columns, in order: :data:`SHARED_COLUMNS`, then every
    method's declared diagnostics in the registry's order (those a dataset's methods never fill
    are left out of its table).
    """
    return SHARED_COLUMNS + [c for c in registry.diagnostics() if c not in SHARED_COLUMNS]


def calibration_rows(
    plan: Plan,
    subsets: Subsets,
    pooled: Pooled,
    method: str,
    fit: Fit,
    order: int,
    cones: dict,
    full: np.ndarray,
    chosen: np.ndarray | None = None,
    block: bool = True,
) -> pd.DataFrame:
    """The calibrations table's rows of one method's ``fit`` of ``subsets`` (pooled as ``pooled``),
    those ``chosen`` (default all): identity, R, flag, the method's diagnostics, the statistics
    they came from and, on the rows from all repetitions (``full``: each unit's row), the
    uncertainty (``cones``: method -> column -> one value per unit, :func:`aceval.methods.
    uncertainty.calibration_cones`: the spread between its repetitions, the other estimates'
    disagreement, the conditioning and the cone ``cone_deg``), flagged ``heading_undetermined``
    where the cone is no cone (:func:`aceval.methods.uncertainty.undetermined`). The
    columns ``_unit``, ``_block`` (0: a method fitted on every subset, ``block`` False; else 1:
    all repetitions, 2: a test-retest subset), ``_subset`` and ``_method`` (``order``) sort the
    table.
    """
    unit = subsets.unit
    identity = plan.identity.iloc[unit].reset_index(drop=True)
    columns = {
        **{k: identity[k].to_numpy() for k in ["subject", "sensor_set", "imu", "segment", "side"]},
        "test": identity["test"].to_numpy(),
        "repetitions": subsets.label,
        "n_reps": subsets.n_reps,
        "method": np.full(len(unit), method, dtype=object),
        **dict(zip(R_COLUMNS, fit.R.reshape(-1, 9).T)),
        "n_samples": pooled.n_samples.astype(int),
        "rho_static": plan.units.rho_static[unit],
        "rho_motion": pooled.gyro_rho,
        "z0_tests": identity["z0_tests"].to_numpy(),
        **{k: identity[k].to_numpy() for k in SENSOR_COLUMNS},
        "flag": fit.flag,
        "sensor_flag": identity["sensor_flag"].to_numpy(),
        "error_deg": np.full(len(unit), np.nan),
        "error_vertical_share": np.full(len(unit), np.nan),
    }
    columns["axis_spread_deg"] = pooled.spread_deg
    columns |= fit.columns
    if method in cones:
        at = full[unit] == np.arange(len(unit))
        for name, values in cones[method].items():
            columns[name] = np.where(at, values[unit], np.nan)
        # a calibration from all repetitions whose cone is no cone (beyond 90 deg, or no spread)
        calibrated = at & np.isfinite(fit.R).all(axis=(1, 2))
        lost = calibrated & undetermined(columns["cone_deg"], columns["spread95_deg"])
        columns["flag"] = np.array(
            [combine_flags(f, "heading_undetermined") if u else f for f, u in zip(fit.flag, lost)],
            dtype=object,
        )
    first = np.searchsorted(unit, unit)  # the units' rows are contiguous, in unit order
    columns |= {
        "_unit": unit,
        "_block": np.where(pooled.all_repetitions, 1, 2) if block else 0,
        "_subset": np.arange(len(unit)) - first,
        "_method": order,
    }
    table = pd.DataFrame(columns)
    table = table if chosen is None else table[chosen]
    known = table_columns()
    return table[[c for c in known if c in table] + [c for c in table if c not in known]]


def motion_axes(plan: Plan, pooled: Pooled, full: np.ndarray) -> pd.DataFrame:
    """The axes table's row of each unit's gyroscope axis from all its repetitions (the pooled
    ``full`` rows of ``pooled``).
    """
    identity = plan.identity
    return pd.DataFrame(
        {
            **{
                k: identity[k].to_numpy()
                for k in ["subject", "sensor_set", "imu", "segment", "side", "test"]
            },
            "kind": "motion",
            "signal": "gyr",
            "n_recordings": plan.units.present.sum(axis=1),
            "n_samples": pooled.n_unit[full].astype(int),
            "axis_x": pooled.gyro_axis[full, 0],
            "axis_y": pooled.gyro_axis[full, 1],
            "axis_z": pooled.gyro_axis[full, 2],
            "rho": pooled.gyro_rho[full],
            "reference": "+y",
            "residual_before_deg": np.nan,
            "residual_after_deg": np.nan,
        }
    )
