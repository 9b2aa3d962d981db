"""A combined heading: Kong's plane normal and the gyroscope's principal axis, weighted by how well
each is conditioned (beyond the papers).

Both of Kong's protocol estimates of the body's right axis are horizontal once made orthogonal to
z0 from quiet standing (Kong Eq. 5): the normal of the plane of accelerations (Kong Eq. 3-4) and the
principal axis of the unit gyroscope samples (Ricci Eq. 1; orthogonalised to z0 this is TRIAD with
z0 primary, and the principle of gaitmap's ``PcaAlignment``). With z0 held exactly, the weighted
Wahba problem for the remaining heading has a closed form: the right axis is the normalised
weighted sum of the two horizontal unit vectors.

The weights are conditioning indices, each 0 at its own method's flag limit and 1 when perfectly
conditioned: Kong ``1 - normal_ratio / max_normal_ratio`` (smallest/middle eigenvalue: 0 for a
plane, :class:`KongLimits`), the gyroscope ``(rho - min_rho) / (1 - min_rho)`` (Ricci's reliability
index, 1 for a rotation about one axis, :class:`aceval.methods.functional.AxisLimits`). A heuristic that
lets the better-determined estimate lead, not a variance model; a flagged estimate weighs 0, and
when both weigh 0 the heading is undetermined (NaN).
"""

from __future__ import annotations

import numpy as np


def kong_weight(normal_ratio, planarity, max_normal_ratio: float, max_planarity: float):
    """Conditioning weight (0-1) of Kong's plane normal: ``1 - normal_ratio / max_normal_ratio``,
    0 where the accelerations are not planar (``planarity > max_planarity``) or NaN.
    """
    weight = np.clip(1.0 - np.asarray(normal_ratio, float) / max_normal_ratio, 0.0, 1.0)
    ok = np.asarray(planarity, float) <= max_planarity
    return np.where(ok & np.isfinite(weight), weight, 0.0)


def gyro_weight(rho, min_rho: float):
    """Conditioning weight (0-1) of the gyroscope axis: ``(rho - min_rho) / (1 - min_rho)``."""
    weight = np.clip((np.asarray(rho, float) - min_rho) / (1.0 - min_rho), 0.0, 1.0)
    return np.where(np.isfinite(weight), weight, 0.0)


def horizontal_right(axis, z0, right):
    """``axis`` (..., 3) made orthogonal to ``z0`` and unit, its sign chosen to point along
    ``right`` (the declared right axis); NaN where it is parallel to z0.
    """
    axis, z0 = np.asarray(axis, float), np.asarray(z0, float)
    y = axis - np.sum(axis * z0, axis=-1, keepdims=True) * z0
    norm = np.linalg.norm(y, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        y = np.where(norm > 1e-9, y / norm, np.nan)
    sign = np.where(np.sum(y * np.asarray(right, float), axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return y * sign


def combined_rotation(z0, y_kong, y_gyro, w_kong, w_gyro) -> np.ndarray:
    """R (..., 3, 3), sensor -> body, rows x, y, z: z = z0 exactly, y the normalised weighted sum
    of the horizontal right axes ``y_kong`` and ``y_gyro`` (unit, orthogonal to z0, pointing
    right; :func:`horizontal_right`), x = y x z. NaN where both weights are 0.
    """
    z0 = np.asarray(z0, float)
    w_kong = np.asarray(w_kong, float)[..., None]
    w_gyro = np.asarray(w_gyro, float)[..., None]
    y_kong = np.nan_to_num(np.asarray(y_kong, float)) * (w_kong > 0)
    y_gyro = np.nan_to_num(np.asarray(y_gyro, float)) * (w_gyro > 0)
    y = w_kong * y_kong + w_gyro * y_gyro
    norm = np.linalg.norm(y, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        y = np.where(norm > 1e-12, y / norm, np.nan)
    z = np.where(np.isfinite(y), z0, np.nan)  # an undetermined heading leaves no rotation
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-2)
