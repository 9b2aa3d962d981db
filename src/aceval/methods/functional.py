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
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.data.errors import CalibrationError
from aceval.data.rotations import axis_vector, error_angle_deg
from aceval.methods.ricci import (
    AxisEstimate,
    axis_from_moments,
    first_phase_sign,
    lm_fit,
    lm_fit_batch,
    unit_moments,
    wahba_batch,
    wahba_fit,
)
from aceval.methods.triad import MIN_ANGLE_DEG as TRIAD_MIN_ANGLE_DEG
from aceval.methods.triad import triad, triad_batch

SUM_COLUMNS = ["m_x", "m_y", "m_z"]
SCATTER_COLUMNS = [f"u{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
PHASE_COLUMNS = ["phase_x", "phase_y", "phase_z"]
MOMENT_COLUMNS = SUM_COLUMNS + SCATTER_COLUMNS + ["n_unit"] + PHASE_COLUMNS
AXIS_METHODS = ["ricci_lm", "align_vectors", "triad"]
#: random starting quaternions per LM fit (Ricci Sec. 3: "converges from random initial values")
RANDOM_STARTS = 5
#: a start "reaches the optimum" when its result is within this angle of the closed-form optimum
SAME_SOLUTION_DEG = 0.1


def recording_moments(samples, fs_hz: float, motion: bool) -> dict:
    """Moments of one recording's unit samples (columns ``MOMENT_COLUMNS``).

    ``samples``: accelerometer (static test) or the trimmed gyroscope samples (motion test).
    For a motion test, ``phase_*`` is the recording's own axis signed by the direction of its
    first movement phase (:func:`first_phase_sign`); NaN for a static test.
    """
    unit_sum, scatter, n = unit_moments(samples)
    row = (
        dict(zip(SUM_COLUMNS, unit_sum))
        | dict(zip(SCATTER_COLUMNS, scatter.ravel()))
        | {"n_unit": n}
    )
    phase = np.full(3, np.nan)
    if motion and n >= 3:
        axis = axis_from_moments(unit_sum, scatter, n).axis
        phase = axis * first_phase_sign(samples, axis, fs_hz)
    return row | dict(zip(PHASE_COLUMNS, phase))


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
            runs = [lm_fit(v_ref, v_est, rho, q0_wxyz=q) for q in starts]
            reached = [_distance_deg(r.R, optimum) <= SAME_SOLUTION_DEG for r in runs]
            entry.update(
                random_starts=random_starts,
                random_starts_optimum=int(np.sum(reached)),
                random_start_iterations_mean=float(np.mean([r.n_iterations for r in runs])),
                random_start_iterations_max=int(max(r.n_iterations for r in runs)),
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


@dataclass(frozen=True)
class AxisLimits:
    """Limits beyond which a calibration of the axis methods is flagged (like :class:`KongLimits`):

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


def axis_spread_deg(repetition_axes: np.ndarray, pooled: np.ndarray) -> float:
    """Median angle (deg, sign ignored) between each repetition's own axis (rows; NaN rows skipped)
    and the pooled axis; NaN with no repetition axis.
    """
    axes = np.asarray(repetition_axes, float)
    axes = axes[np.isfinite(axes).all(axis=1)]
    if not len(axes):
        return float("nan")
    cos = np.abs(axes @ np.asarray(pooled, float)) / np.linalg.norm(axes, axis=1)
    return float(np.degrees(np.median(np.arccos(np.clip(cos, 0.0, 1.0)))))


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
    limits: AxisLimits = AxisLimits(),
    diagnostics: bool = True,
) -> dict[str, dict]:
    """Kong's protocol, axis methods: body z (down) <- z0 from quiet stance, body y (right) <- the
    gyroscope axis of the motion test (already oriented to the right), weighted by their rho.
    Flagged (every method) beyond :class:`AxisLimits`: ``low_rho``, ``axis_near_vertical``,
    ``axes_disagree`` (``spread_deg``: :func:`axis_spread_deg` of the repetitions).
    """
    v_est = np.array([z0, motion_axis])
    fits = fit_axes(
        SAGITTAL_REFERENCE,
        v_est,
        np.array([rho_static, rho_motion]),
        (0, 1),
        diagnostics=diagnostics,
    )
    problem = _sagittal_problem(z0, motion_axis, rho_motion, spread_deg, limits)
    return _flag_all(fits, *problem) if problem else fits


#: body z (down) and y (right): the references of Kong's protocol for the axis methods
SAGITTAL_REFERENCE = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])


def _sagittal_problem(z0, motion_axis, rho_motion, spread_deg, limits) -> tuple[str, str] | None:
    """The flag and message of :func:`sagittal_fits` beyond :class:`AxisLimits`, or None."""
    vertical_angle = float(np.degrees(np.arccos(min(1.0, abs(float(np.dot(z0, motion_axis)))))))
    if rho_motion < limits.min_rho:
        return (
            "low_rho",
            f"rho of the movement axis {rho_motion:.2f} < {limits.min_rho}: "
            f"no preferred rotation axis",
        )
    if vertical_angle < limits.min_vertical_angle_deg:
        return (
            "axis_near_vertical",
            f"movement axis {vertical_angle:.0f} deg from z0 "
            f"(< {limits.min_vertical_angle_deg:g}): not a sagittal motion",
        )
    if spread_deg > limits.max_spread_deg:
        return (
            "axes_disagree",
            f"the repetitions' axes are {spread_deg:.0f} deg (median) from "
            f"the pooled one (> {limits.max_spread_deg:g})",
        )
    return None


def sagittal_fits_batch(
    z0: np.ndarray,
    rho_static: float,
    motion_axes: np.ndarray,
    rho_motion: np.ndarray,
    spread_deg: np.ndarray,
    limits: AxisLimits = AxisLimits(),
) -> list[dict[str, dict]]:
    """:func:`sagittal_fits` (``diagnostics=False``) of a stack of unit gyroscope axes (B, 3), with
    their rho and spread (B,), against one unit ``z0`` at once: the LM (:func:`lm_fit_batch`),
    the weighted Wahba optimum (:func:`wahba_batch`) and TRIAD (:func:`triad_batch`) of all of
    them, flagged as
    :func:`sagittal_fits` flags; an axis that is not finite or within TRIAD's 5 deg of z0 is
    fitted alone by :func:`sagittal_fits` (its errors as there). Equal to the single calls to
    rounding (tested).
    """
    motion_axes = np.asarray(motion_axes, float)
    rho_motion = np.asarray(rho_motion, float)
    finite = np.isfinite(motion_axes).all(axis=1) & np.isfinite(rho_motion)
    cos = np.abs(np.where(finite[:, None], motion_axes, 0.0) @ z0)
    regular = np.flatnonzero(finite & (cos < np.cos(np.radians(TRIAD_MIN_ANGLE_DEG))))
    out: list[dict[str, dict] | None] = [None] * len(motion_axes)
    if len(regular):
        axes = motion_axes[regular]
        v_est = np.stack([np.broadcast_to(z0, axes.shape), axes], axis=1)
        weights = np.column_stack([np.full(len(regular), rho_static), rho_motion[regular]])
        optimum = wahba_batch(SAGITTAL_REFERENCE, v_est, weights)
        lm = lm_fit_batch(SAGITTAL_REFERENCE, v_est, weights)
        triads = triad_batch(z0, axes, rho_static, rho_motion[regular])
        distance = error_angle_deg(lm.R, optimum)
        for k, row in enumerate(regular):
            fits = {
                "align_vectors": {"R": optimum[k]},
                "ricci_lm": {
                    "R": lm.R[k],
                    "n_iterations": int(lm.n_iterations[k]),
                    "n_rejected": int(lm.n_rejected[k]),
                    "converged": bool(lm.converged[k]),
                    "cost": float(lm.cost[k]),
                    "optimum_distance_deg": float(distance[k]),
                },
                "triad": {"R": triads[k]},
            }
            problem = _sagittal_problem(
                z0, motion_axes[row], rho_motion[row], spread_deg[row], limits
            )
            out[row] = _flag_all(fits, *problem) if problem else fits
    for row in [r for r, fits in enumerate(out) if fits is None]:
        out[row] = sagittal_fits(
            z0, rho_static, motion_axes[row], rho_motion[row], spread_deg[row], limits, False
        )
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


def subset_axes(scatters: np.ndarray, membership: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rho (Ricci Eq. 2) and axis (unit, sign arbitrary) of every subset of repetitions at once:
    ``scatters`` (n_rep, 3, 3) unit scatters, ``membership`` (n_subsets, n_rep) 0/1.
    """
    total = np.einsum("sr,rij->sij", membership, scatters)
    eigenvalues, vectors = np.linalg.eigh(total)
    singular = np.sqrt(np.clip(eigenvalues, 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        return singular[:, -1] / singular.sum(axis=1), vectors[:, :, -1]
