"""Kong's protocol for the axis methods (Ricci's LM, ``align_vectors``, TRIAD): body z (down) from
the static z0, body y (right) from the gyroscope's principal axis in the motion test, weighted by
their reliability rho (Ricci Eq. 1-2, 7), and the limits beyond which such a calibration is
flagged (also in Ricci's functional design). Shared by the three methods' modules
(:mod:`aceval.methods.ricci`, :mod:`aceval.methods.align_vectors`, :mod:`aceval.methods.triad`) and
the combined heading; :func:`sagittal_fits` fits them all on one IMU and test.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aceval.data.errors import CalibrationError
from aceval.methods.interface import CalibrationMethod
from aceval.methods.registry import classes
from aceval.methods.sufficient import GYRO_MOMENTS, Pooled

#: body z (down) and y (right): the references of Kong's protocol for the axis methods
SAGITTAL_REFERENCE = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
#: TRIAD's smallest angle (deg) between its two axes: closer, there is no second direction
TRIAD_MIN_ANGLE_DEG = 5.0


@dataclass(frozen=True)
class AxisLimits:
    """Limits beyond which a calibration of the axis methods is flagged (like
    :class:`aceval.methods.kong.KongLimits`):

    * ``min_rho``: a movement axis with a lower rho has no preferred direction (0.40; samples spread
      evenly in 3-D give 1/3, simulated random hand-held rotation 0.37-0.49 per recording, Kong's
      simulated sagittal tests 0.43-0.77 over 5 repetitions);
    * ``min_vertical_angle_deg``: the sagittal design's movement axis (body y) must be at least this
      far from z0 (45 deg, as Kong's plane normal);
    * ``max_spread_deg``: the repetitions' own axes must agree: median angle between each
      repetition's axis and the pooled one at most 40 deg (axes drawn at random give 60 deg; the
      simulated Kong protocol up to 31 deg, in the leg swing T5);
    * ``max_residual_deg``: Ricci's functional design, the largest residual angle between a
      reference axis and its fitted estimate (30 deg): beyond it the axes do not form one frame.
    """

    min_rho: float = 0.40
    min_vertical_angle_deg: float = 45.0
    max_spread_deg: float = 40.0
    max_residual_deg: float = 30.0


def sagittal_problems(pooled: Pooled, limits: AxisLimits = AxisLimits()) -> np.ndarray:
    """The axis methods' flag of each pooled row beyond :class:`AxisLimits` (the first that
    holds of ``low_rho``, ``axis_near_vertical``, ``axes_disagree``; '' when none). An axis that
    is not finite counts as vertical.
    """
    cos = np.fmin(1.0, np.abs(np.einsum("bi,bi->b", pooled.z0, pooled.gyro_axis)))
    vertical_angle = np.degrees(np.arccos(cos))
    return np.select(
        [
            pooled.gyro_rho < limits.min_rho,
            vertical_angle < limits.min_vertical_angle_deg,
            pooled.spread_deg > limits.max_spread_deg,
        ],
        ["low_rho", "axis_near_vertical", "axes_disagree"],
        "",
    ).astype(object)


def regular_axes(pooled: Pooled) -> np.ndarray:
    """(B,) the rows whose gyroscope axis and rho are finite and at least TRIAD's 5 deg from z0:
    each axis method fits them all at once, and the others one at a time, their errors becoming
    their flags (:func:`axis_method_fit`).
    """
    finite = np.isfinite(pooled.gyro_axis).all(axis=1) & np.isfinite(pooled.gyro_rho)
    cos = np.abs(np.einsum("bi,bi->b", pooled.z0, np.where(finite[:, None], pooled.gyro_axis, 0)))
    return finite & (cos < np.cos(np.radians(TRIAD_MIN_ANGLE_DEG)))


def sagittal_axes(pooled: Pooled) -> tuple[np.ndarray, np.ndarray]:
    """``(v_est, weights)`` of each row: z0 and the gyroscope axis (B, 2, 3), to be mapped onto
    :data:`SAGITTAL_REFERENCE`, weighted by their rho (B, 2) (Ricci Eq. 7).
    """
    v_est = np.stack([pooled.z0, pooled.gyro_axis], axis=1)
    return v_est, np.column_stack([pooled.rho_static, pooled.gyro_rho])


def usable_axes(pooled: Pooled, limits: AxisLimits = AxisLimits()) -> np.ndarray:
    """(B,) the bootstrap resamples whose gyroscope axis the axis methods would use: rho at least
    ``min_rho`` and at least ``min_vertical_angle_deg`` from z0 (the spread is a subset's, not a
    resample's).
    """
    min_cos = np.cos(np.radians(limits.min_vertical_angle_deg))
    cos = np.abs(np.einsum("bi,bi->b", pooled.gyro_axis, pooled.z0))
    return (pooled.gyro_rho >= limits.min_rho) & (cos <= min_cos)


def axis_method_fit(
    pooled: Pooled,
    batch: Callable[[Pooled, np.ndarray], tuple[np.ndarray, dict]],
    single: Callable[[Pooled, int], tuple[np.ndarray, dict]],
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """``(R, flag, columns)`` of one axis method on every pooled row: ``batch(pooled, rows)`` fits
    the :func:`regular_axes` rows at once (R (n, 3, 3), columns name -> (n,)), ``single(pooled,
    row)`` each of the others (R (3, 3), columns name -> value), a
    :class:`aceval.data.errors.CalibrationError` or ValueError becoming that row's flag (its
    ``code``; ``calibration_error`` without one). Rows the method fitted get
    :func:`sagittal_problems`' flag. True/False columns stay booleans (None where missing).
    """
    n = len(pooled)
    regular = np.flatnonzero(regular_axes(pooled))
    R = np.full((n, 3, 3), np.nan)
    failed = np.full(n, "", dtype=object)
    found: dict[str, list] = {}
    results = [(regular, *batch(pooled, regular))] if len(regular) else []
    for row in np.flatnonzero(~regular_axes(pooled)):
        try:
            R_row, columns = single(pooled, row)
        except (CalibrationError, ValueError) as exc:
            failed[row] = getattr(exc, "code", "calibration_error")
            continue
        results.append((np.array([row]), R_row[None], {k: [v] for k, v in columns.items()}))
    for rows, R_rows, columns in results:
        R[rows] = R_rows
        for name, values in columns.items():
            found.setdefault(name, []).append((rows, np.asarray(values)))
    flag = np.where(failed != "", failed, sagittal_problems(pooled)).astype(object)
    return R, flag, {name: _column(n, parts) for name, parts in found.items()}


def _column(n: int, parts: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """A column of ``n`` rows from ``(rows, values)`` parts: float with NaN where missing, or (parts
    of True/False) an object column with None where missing.
    """
    logical = all(values.dtype in (bool, object) for _, values in parts)
    column = np.full(n, None if logical else np.nan, dtype=object if logical else float)
    for rows, values in parts:
        column[rows] = values
    return column


class AxisMethod(CalibrationMethod):
    """An axis method of Kong's protocol (Ricci's LM, ``align_vectors``, TRIAD): z0 and the motion
    test's gyroscope axis onto body z and y (:data:`SAGITTAL_REFERENCE`), flagged beyond
    :class:`AxisLimits` (:func:`axis_method_fit`). Subclasses give ``_batch(pooled, rows)`` (the
    :func:`regular_axes` rows at once) and ``_single(pooled, row)`` (one other row).
    """

    statistics = (GYRO_MOMENTS,)
    signal = "gyr"

    def _batch(self, pooled: Pooled, rows: np.ndarray) -> tuple[np.ndarray, dict]:
        raise NotImplementedError

    def _single(self, pooled: Pooled, row: int) -> tuple[np.ndarray, dict]:
        raise NotImplementedError

    def fit(self, pooled: Pooled, fitted=None) -> AxisMethod:
        """Every row's calibration, flagged as the axis methods are (:func:`axis_method_fit`)."""
        return self._set(*axis_method_fit(pooled, self._batch, self._single))


def sagittal_fits(
    z0: np.ndarray,
    rho_static: float,
    motion_axis: np.ndarray,
    rho_motion: float,
    spread_deg: float = float("nan"),
    diagnostics: bool = True,
) -> dict[str, dict]:
    """Every axis method of the registry (:class:`AxisMethod`) on one IMU and test: body z (down)
    <- z0 from quiet stance, body y (right) <- the gyroscope axis of the motion test (already
    oriented to the right), weighted by their rho. Flagged beyond :class:`AxisLimits`:
    ``low_rho``, ``axis_near_vertical``, ``axes_disagree`` (``spread_deg``: the median angle of
    the repetitions' own axes to the pooled one). ``diagnostics``: the LM with lambda fixed too (a
    calibration from all repetitions). Each method's entry: ``R`` (None where it failed),
    ``flag`` and its diagnostics.
    """
    pooled = Pooled.of_axes(z0, rho_static, motion_axis, rho_motion, spread_deg, diagnostics)
    out = {}
    for name, cls in classes().items():
        if not issubclass(cls, AxisMethod):
            continue
        fit = cls().fit(pooled, {})
        R = fit.rotation_[0] if np.isfinite(fit.rotation_[0]).all() else None
        values = {k: v[0] for k, v in fit.diagnostics_.items()}
        out[name] = {"R": R, "flag": fit.flag_[0]} | {
            k: v
            for k, v in values.items()
            if v is not None and not (isinstance(v, float) and np.isnan(v))
        }
    return out
