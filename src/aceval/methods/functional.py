"""Functional axes of recordings and the calibrations built from axes (Ricci et al. 2014).

Each recording is reduced once to the moments of its unit-normalised samples (accelerometer for a
static test, trimmed gyroscope for a motion test; :func:`recording_moments`). The axis and the
reliability index rho of any union of recordings then follow from the summed moments
(:func:`pool`). Three methods turn axes into a rotation R (sensor -> body/segment frame):

* ``ricci_lm``: Ricci's rho-weighted Levenberg-Marquardt from the identity (Eq. 3-11);
* ``align_vectors``: the closed-form optimum of the same weighted cost (SciPy, Wahba's problem);
* ``triad``: two axes, the primary kept exactly.

Two designs say which axes go into one calibration:

* **sagittal** (Kong's protocol): for each motion test, the static z0 (down, from quiet stance)
  and the gyroscope axis of the motion test as y, oriented along the IMU's ``right_axis``;
  TRIAD keeps z0 exactly, as Kong's method does (:func:`sagittal_fits`);
* **functional** (Ricci's protocol, ``functional_axes.tsv``): every axis the sheet lists for the
  IMU's segment, movement axes oriented by their first phase; TRIAD uses the most reliable axis
  and the most reliable one whose reference is not parallel to it (:func:`functional_fits`).
"""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.data.errors import CalibrationError
from aceval.data.rotations import axis_vector, error_angle_deg
from aceval.methods.align_vectors import wahba_fit
from aceval.methods.moments import (
    MOMENT_COLUMNS,
    AxisEstimate,
    axis_from_moments,
)
from aceval.methods.registry import classes, functional_design
from aceval.methods.ricci import lm_fit, lm_fit_batch
from aceval.methods.sagittal import AxisLimits
from aceval.methods.sufficient import Pooled
from aceval.methods.triad import triad

#: the axis methods (Ricci's LM, the closed-form optimum, TRIAD): Ricci's functional design fits them
AXIS_METHODS = functional_design()

#: random starting quaternions per LM fit (Ricci Sec. 3: "converges from random initial values")
RANDOM_STARTS = 5
#: a start "reaches the optimum" when its result is within this angle of the closed-form optimum:
#: Kong's own threshold for a calibration that no longer changes ("after including three
#: repetitions the change ... is less than one degree", Kong et al. 2016, Sec. 3.3)
SAME_SOLUTION_DEG = 1.0


def pool(recordings: pd.DataFrame, orient: str | np.ndarray = "mean") -> AxisEstimate:
    """Axis and rho of the union of ``recordings`` (rows with ``MOMENT_COLUMNS``).

    ``orient``: ``'mean'`` (along the mean sample: static postures), ``'phase'`` (the summed
    first-phase axes of the recordings: movements whose protocol fixes the first direction), or a
    vector the axis should point along (e.g. the IMU's right axis).
    """
    summed = recordings[MOMENT_COLUMNS].sum(axis=0, min_count=0)  # NaN phases (static) are skipped
    return pool_summed(summed.to_numpy(float), orient)


def pool_summed(summed: np.ndarray, orient: str | np.ndarray = "mean") -> AxisEstimate:
    """:func:`pool` from the already summed ``MOMENT_COLUMNS`` (one row, in that order)."""
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


def _distance_deg(R: np.ndarray, optimum: np.ndarray | None) -> float:
    """Angle (deg) between a fitted rotation and the closed-form optimum (NaN without one)."""
    return float("nan") if optimum is None else float(error_angle_deg(R, optimum))


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
    """R (sensor -> body) by each of ``AXIS_METHODS`` from axis pairs ``v_ref ~ R v_est``.

    ``rho`` weights the axes (Ricci Eq. 7); ``triad_pair`` = (primary, secondary) row indices.
    Each method's entry: ``R`` (or None) and ``flag``/``message`` when it failed. The LM entry
    (adaptive damping) adds its accepted and rejected steps, convergence, final cost, distance to
    the closed-form optimum (deg), the same three for the fixed-damping LM (``fixed_*``), residual
    angles (deg) before/after and, with ``random_starts``, how many random starts reach the
    closed-form optimum and their iterations. ``diagnostics=False`` leaves out the fixed-damping
    LM (the rotations are the same; for the many subset calibrations of Obj 4).
    """
    out: dict[str, dict] = {}
    try:
        optimum = wahba_fit(v_ref, v_est, rho).as_matrix()
        out["align_vectors"] = {"R": optimum}
    except (CalibrationError, ValueError) as exc:
        optimum = None
        out["align_vectors"] = _failed(exc)
    try:
        fit = lm_fit(v_ref, v_est, rho)  # Hartley & Zisserman's adaptive damping, as Ricci cites
        entry = {
            "R": fit.R,
            "n_iterations": fit.n_iterations,
            "n_rejected": fit.n_rejected,
            "converged": fit.converged,
            "cost": fit.cost,
            "optimum_distance_deg": _distance_deg(fit.R, optimum),
            "residual_before_deg": fit.residual_angle_before_deg,
            "residual_after_deg": fit.residual_angle_after_deg,
        }
        if diagnostics:  # lambda fixed at 1e-3: Eq. 9-10 read literally
            fixed = lm_fit(v_ref, v_est, rho, adaptive=False)
            entry.update(
                fixed_n_iterations=fixed.n_iterations,
                fixed_cost=fixed.cost,
                fixed_converged=fixed.converged,
                fixed_optimum_distance_deg=_distance_deg(fixed.R, optimum),
            )
        if random_starts and optimum is not None:
            starts = Rotation.random(random_starts, random_state=seed).as_quat(scalar_first=True)
            runs = lm_fit_batch(
                v_ref,
                np.broadcast_to(v_est, (random_starts, *np.shape(v_est))),
                np.broadcast_to(rho, (random_starts, len(rho))),
                q0_wxyz=starts,
            )
            reached = error_angle_deg(runs.R, optimum) <= SAME_SOLUTION_DEG
            entry.update(
                random_starts=random_starts,
                random_starts_optimum=int(np.sum(reached)),
                random_start_iterations_mean=float(np.mean(runs.n_iterations)),
                random_start_iterations_max=int(np.max(runs.n_iterations)),
            )
        out["ricci_lm"] = entry
    except (CalibrationError, ValueError) as exc:
        out["ricci_lm"] = _failed(exc)
    try:
        primary, secondary = triad_pair
        out["triad"] = {"R": triad(v_ref[[primary, secondary]], v_est[[primary, secondary]])}
    except (CalibrationError, ValueError) as exc:
        out["triad"] = _failed(exc)
    return out


def _flag_all(fits: dict[str, dict], code: str, message: str) -> dict[str, dict]:
    for fit in fits.values():
        if not fit.get("flag"):
            fit.update(flag=code, message=message)
    return fits


def sagittal_fits(
    z0: np.ndarray,
    rho_static: float,
    motion_axis: np.ndarray,
    rho_motion: float,
    spread_deg: float = float("nan"),
    diagnostics: bool = True,
) -> dict[str, dict]:
    """Kong's protocol, the axis methods of one IMU and test (:data:`AXIS_METHODS`, by their
    modules in :mod:`aceval.methods.registry`): body z (down) <- z0 from quiet stance, body y
    (right) <- the gyroscope axis of the motion test (already oriented to the right), weighted by
    their rho. Flagged beyond :class:`aceval.methods.sagittal.AxisLimits`: ``low_rho``,
    ``axis_near_vertical``, ``axes_disagree`` (``spread_deg``: the median angle of the
    repetitions' own axes to the pooled one). ``diagnostics``: the LM with lambda fixed too (a
    calibration from all repetitions). Each method's entry: ``R`` (None where it failed),
    ``flag`` and its diagnostics.
    """
    pooled = Pooled.of_axes(z0, rho_static, motion_axis, rho_motion, spread_deg, diagnostics)
    out = {}
    for name, cls in classes(AXIS_METHODS).items():
        fit = cls().fit(pooled, {})
        R = fit.rotation_[0] if np.isfinite(fit.rotation_[0]).all() else None
        values = {k: v[0] for k, v in fit.diagnostics_.items()}
        out[name] = {"R": R, "flag": fit.flag_[0]} | {
            k: v
            for k, v in values.items()
            if v is not None and not (isinstance(v, float) and np.isnan(v))
        }
    return out


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
    residual = fits["ricci_lm"].get("residual_after_deg")
    if residual is not None and np.max(residual) > limits.max_residual_deg:
        return _flag_all(
            fits,
            "axes_inconsistent",
            f"an axis is {np.max(residual):.0f} deg from its reference "
            f"after the fit (> {limits.max_residual_deg:g}): the axes do "
            f"not form one frame",
        )
    return fits
