"""Functional axes of recordings and the calibrations built from axes (Ricci et al. 2014).

Each recording is reduced once to the moments of its unit-normalised samples (accelerometer for a
static test, trimmed gyroscope for a motion test; :func:`recording_moments`). The axis and the
reliability index rho of any union of recordings then follow from the summed moments
(:func:`axis_of_recordings`). Every method of the registry with a ``fit_functional`` (Ricci's
LM, the closed-form optimum, TRIAD: :mod:`aceval.methods.interface`) turns axes into a rotation R
(sensor -> body/segment frame).

Ricci's functional design (``functional_axes.tsv``): every axis the sheet lists for the IMU's
segment, movement axes oriented by their first phase; TRIAD uses the most reliable axis and the
most reliable one whose reference is not parallel to it (:func:`functional_fits`). Kong's
sagittal design of the same methods is :mod:`aceval.methods.sagittal`'s.
"""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd

from aceval.data.errors import CalibrationError
from aceval.data.rotations import axis_vector
from aceval.methods.interface import AxisProblem
from aceval.methods.moments import (
    MOMENT_COLUMNS,
    AxisEstimate,
    axis_from_moments,
)
from aceval.methods.registry import classes, functional_design, paper_method
from aceval.methods.sagittal import AxisLimits

#: random starting quaternions per LM fit (Ricci Sec. 3: "converges from random initial values")
RANDOM_STARTS = 5


def axis_of_recordings(recordings: pd.DataFrame, orient: str | np.ndarray = "mean") -> AxisEstimate:
    """Axis and rho of the union of ``recordings`` (rows with ``MOMENT_COLUMNS``).

    ``orient``: ``'mean'`` (along the mean sample: static postures), ``'phase'`` (the summed
    first-phase axes of the recordings: movements whose protocol fixes the first direction), or a
    vector the axis should point along (e.g. the IMU's right axis).
    """
    summed = recordings[MOMENT_COLUMNS].sum(axis=0, min_count=0)  # NaN phases (static) are skipped
    return axis_of_sums(summed.to_numpy(float), orient)


def axis_of_sums(summed: np.ndarray, orient: str | np.ndarray = "mean") -> AxisEstimate:
    """:func:`axis_of_recordings` from the already summed ``MOMENT_COLUMNS`` (one row, in that order)."""
    estimate = axis_from_moments(summed[0:3], summed[3:12].reshape(3, 3), int(summed[12]))
    if isinstance(orient, str) and orient == "mean":
        return estimate
    hint = summed[13:16] if isinstance(orient, str) else orient
    if float(estimate.axis @ hint) < 0:
        return AxisEstimate(
            -estimate.axis, estimate.rho, estimate.singular_values, estimate.n_samples
        )
    return estimate


def stable_seed(*key) -> int:
    """A random seed fixed by a calibration's identity (the same results on every run)."""
    return zlib.crc32("|".join(map(str, key)).encode())


def _failed(exc: Exception) -> dict:
    """A method's entry when it could not calibrate: no R, the error's code as flag, its message."""
    return {"R": None, "flag": getattr(exc, "code", "calibration_error"), "message": str(exc)}


def fit_axes(
    v_ref: np.ndarray,
    v_est: np.ndarray,
    rho: np.ndarray,
    triad_pair: tuple[int, int],
    random_starts: int = 0,
    seed: int = 0,
    diagnostics: bool = True,
) -> dict[str, dict]:
    """R (sensor -> body) by every method of the registry that serves Ricci's functional design
    (:meth:`aceval.methods.interface.CalibrationMethod.fit_functional`), in the registry's order,
    from axis pairs ``v_ref ~ R v_est`` (:class:`aceval.methods.interface.AxisProblem`: ``rho``
    weights the axes, Ricci Eq. 7; ``triad_pair`` = (primary, secondary) row indices; with
    ``random_starts``, the LM's starts from random rotations; ``diagnostics=False`` leaves out the
    fixed-damping LM). Each method's entry: ``R`` and its diagnostics, or (``R`` None) the
    error's code as ``flag`` and its ``message`` where it could not calibrate.
    """
    problem = AxisProblem(v_ref, v_est, rho, triad_pair, random_starts, seed, diagnostics)
    out: dict[str, dict] = {}
    for name, cls in classes(functional_design()).items():
        try:
            out[name] = cls.fit_functional(problem)
        except (CalibrationError, ValueError) as exc:
            out[name] = _failed(exc)
    return out


def _flag_all(fits: dict[str, dict], code: str, message: str) -> dict[str, dict]:
    for fit in fits.values():
        if not fit.get("flag"):
            fit.update(flag=code, message=message)
    return fits


def triad_pair(v_ref: np.ndarray, rho: np.ndarray, min_angle_deg: float = 30.0) -> tuple[int, int]:
    """The most reliable axis, and the most reliable one whose reference is at least
    ``min_angle_deg`` from it (Ricci's functional frames repeat some references, e.g. two
    flexion-extensions about one axis).
    """
    order = [int(i) for i in np.argsort(-np.asarray(rho), kind="stable")]
    primary = order[0]
    limit = np.cos(np.radians(min_angle_deg))
    for index in order[1:]:
        if abs(float(v_ref[primary] @ v_ref[index])) < limit:
            return primary, index
    return primary, order[1] if len(order) > 1 else primary


def functional_fits(
    axes: pd.DataFrame,
    random_starts: int = RANDOM_STARTS,
    seed_key=(),
    limits: AxisLimits = AxisLimits(),
) -> dict[str, dict]:
    """Ricci's protocol: one calibration per IMU from every axis in ``axes`` (rows with
    ``reference`` ('+x', ...), ``axis_x/y/z`` and ``rho``). Flagged (every method) beyond
    :class:`AxisLimits`: ``low_rho`` (fewer than 2 axes with rho >= min_rho), ``axes_inconsistent``
    (an LM residual above max_residual_deg).
    """
    v_ref = np.stack([axis_vector(a) for a in axes["reference"]])
    v_est = axes[["axis_x", "axis_y", "axis_z"]].to_numpy(float)
    rho = axes["rho"].to_numpy(float)
    fits = fit_axes(
        v_ref, v_est, rho, triad_pair(v_ref, rho), random_starts, stable_seed(*seed_key)
    )
    if np.sum(rho >= limits.min_rho) < 2:
        return _flag_all(
            fits,
            "low_rho",
            f"fewer than 2 axes with rho >= {limits.min_rho} "
            f"({', '.join(f'{r:.2f}' for r in rho)})",
        )
    residual = fits[paper_method("ricci2014")].get("residual_after_deg")
    if residual is not None and np.max(residual) > limits.max_residual_deg:
        return _flag_all(
            fits,
            "axes_inconsistent",
            f"an axis is {np.max(residual):.0f} deg from its reference "
            f"after the fit (> {limits.max_residual_deg:g}): the axes do "
            f"not form one frame",
        )
    return fits
