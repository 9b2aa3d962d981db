"""TRIAD: the rotation from two non-aligned axes, the first (primary) kept exactly."""

from __future__ import annotations

import numpy as np

from aceval.data.errors import AlignedAxesError, TooFewAxesError
from aceval.methods.interface import AxisProblem
from aceval.methods.sagittal import (
    SAGITTAL_REFERENCE,
    TRIAD_MIN_ANGLE_DEG,
    AxisMethod,
    sagittal_axes,
    usable_axes,
)
from aceval.methods.sufficient import Pooled


def _frame(primary: np.ndarray, secondary: np.ndarray, min_sin: float, name: str) -> np.ndarray:
    t1 = primary / np.linalg.norm(primary)
    cross = np.cross(t1, secondary / np.linalg.norm(secondary))
    sin = float(np.linalg.norm(cross))
    if sin < min_sin:
        raise AlignedAxesError(
            f"TRIAD: the two {name} axes are {np.degrees(np.arcsin(min(sin, 1.0))):.2f} deg apart "
            f"(< {np.degrees(np.arcsin(min_sin)):.1f} deg): no second direction"
        )
    t2 = cross / sin
    return np.column_stack([t1, t2, np.cross(t1, t2)])


#: TRIAD's smallest angle (deg) between its two axes: closer, there is no second direction
MIN_ANGLE_DEG = TRIAD_MIN_ANGLE_DEG


def triad(v_ref, v_est, min_angle_deg: float = MIN_ANGLE_DEG) -> np.ndarray:
    """Rotation R (3x3) with ``R @ v_est[0] == v_ref[0]`` exactly and ``R @ v_est[1]`` in the plane
    of ``v_ref[0], v_ref[1]``. ``v_ref`` are axes in the body/functional frame, ``v_est`` the same
    axes measured in the sensor frame, each of shape (2, 3): row 0 primary, row 1 secondary.
    """
    v_ref = np.atleast_2d(np.asarray(v_ref, dtype=float))
    v_est = np.atleast_2d(np.asarray(v_est, dtype=float))
    if len(v_ref) < 2 or len(v_est) < 2:
        raise TooFewAxesError(
            f"TRIAD needs a primary and a secondary axis, got {len(v_ref)} reference and "
            f"{len(v_est)} measured axes"
        )
    if v_ref.shape != (2, 3) or v_est.shape != (2, 3):
        raise ValueError(f"TRIAD takes exactly 2 axes, got {v_ref.shape} and {v_est.shape}")
    if not (np.isfinite(v_ref).all() and np.isfinite(v_est).all()):
        raise ValueError("TRIAD: axes contain NaN or inf")
    min_sin = np.sin(np.radians(min_angle_deg))
    ref_frame = _frame(v_ref[0], v_ref[1], min_sin, "reference")
    est_frame = _frame(v_est[0], v_est[1], min_sin, "measured")
    return ref_frame @ est_frame.T


def _frames(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """TRIAD's frames (B, 3, 3; columns t1, t2, t3) of rows of primary and secondary axes."""
    t1 = primary / np.linalg.norm(primary, axis=-1, keepdims=True)
    t2 = np.cross(t1, secondary)
    t2 = t2 / np.linalg.norm(t2, axis=-1, keepdims=True)
    return np.stack([t1, t2, np.cross(t1, t2)], axis=-1)


def triad_batch(z0: np.ndarray, axes: np.ndarray, rho_static: float, rho: np.ndarray) -> np.ndarray:
    """:func:`triad` of Kong's protocol for a stack of gyroscope axes (B, 3) at once (the bootstrap
    of :mod:`aceval.methods.uncertainty`): the more reliable of z0 (body z) and the axis (body y) kept
    exactly, as :func:`aceval.methods.functional.triad_pair` chooses (z0 on a tie); no aligned-axes check
    (the caller leaves out axes near z0).
    """
    z_first = (rho_static >= rho)[:, None]
    ez, ey = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    z0s = np.broadcast_to(z0, axes.shape)
    reference = _frames(np.where(z_first, ez, ey), np.where(z_first, ey, ez))
    measured = _frames(np.where(z_first, z0s, axes), np.where(z_first, axes, z0s))
    return reference @ np.swapaxes(measured, -1, -2)


# --- the method's interface in Kong's protocol (aceval.methods.interface) -----------------------


class Triad(AxisMethod):
    """TRIAD of z0 and the gyroscope axis onto body z and y, the more reliable (rho) kept exactly
    (z0, whose static rho is near 1, in practice), flagged as the axis methods are
    (:class:`aceval.methods.sagittal.AxisMethod`).
    """

    @classmethod
    def fit_functional(cls, problem: AxisProblem) -> dict:
        """TRIAD of the problem's ``triad_pair`` of axes, the primary kept exactly (Ricci's
        functional design).
        """
        pair = list(problem.triad_pair)
        return {"R": triad(problem.v_ref[pair], problem.v_est[pair])}

    def _batch(self, pooled: Pooled, rows: np.ndarray) -> tuple[np.ndarray, dict]:
        return triad_batch(
            pooled.z0[rows], pooled.gyro_axis[rows], pooled.rho_static[rows], pooled.gyro_rho[rows]
        ), {}

    def _single(self, pooled: Pooled, row: int) -> tuple[np.ndarray, dict]:
        v_est, _ = sagittal_axes(pooled)
        return triad(SAGITTAL_REFERENCE, v_est[row]), {}

    def resample(self, pooled: Pooled, fitted=None) -> Triad:
        """TRIAD of each bootstrap resample, NaN where its axis would be flagged."""
        usable = usable_axes(pooled)
        R = triad_batch(pooled.z0, pooled.gyro_axis, pooled.rho_static, pooled.gyro_rho)
        return self._set(
            np.where(usable[:, None, None], R, np.nan), np.where(usable, "", "low_rho")
        )
