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
index, 1 for a rotation about one axis, :class:`aceval.methods.sagittal.AxisLimits`). A heuristic that
lets the better-determined estimate lead, not a variance model; a flagged estimate weighs 0, and
when both weigh 0 the heading is undetermined (NaN).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from aceval.methods.interface import CalibrationMethod, combine_flags
from aceval.methods.kong import KongLimits
from aceval.methods.sagittal import AxisLimits
from aceval.methods.sufficient import ACC_SCATTER, GYRO_MOMENTS, Pooled


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


# --- the method's interface in Kong's protocol (aceval.methods.interface) -----------------------


def _weights(
    pooled: Pooled, kong: CalibrationMethod, gyro_usable: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Kong's and the gyroscope's weights of each row: 0 where Kong's calibration is flagged or the
    gyroscope axis is not ``gyro_usable``.
    """
    limits = KongLimits()
    w_kong = np.where(
        kong.flag_ == "",
        kong_weight(
            kong.diagnostics_["normal_ratio"],
            kong.diagnostics_["planarity"],
            limits.max_normal_ratio,
            limits.max_planarity,
        ),
        0.0,
    )
    w_gyro = np.where(gyro_usable, gyro_weight(pooled.gyro_rho, AxisLimits().min_rho), 0.0)
    return w_kong, w_gyro


def _rotation(pooled: Pooled, kong: CalibrationMethod, w_kong, w_gyro) -> np.ndarray:
    """The combined heading's R of each row (:func:`combined_rotation`)."""
    return combined_rotation(
        pooled.z0,
        kong.rotation_[:, 1],
        horizontal_right(pooled.gyro_axis, pooled.z0, pooled.right),
        w_kong,
        w_gyro,
    )


class Combined(CalibrationMethod):
    """The combined heading of each row from Kong's calibration of the same repetitions
    (``fitted['kong']``) and their gyroscope axis, unless the axis methods flag it (TRIAD's flag,
    ``fitted['triad']``); both weights 0: no calibration, flagged with both estimates' flags
    (``not_planar`` when neither has one), and ``weight_switch`` where a unit's calibrations do
    not all use the same estimates. Diagnostics: ``weight_kong``, ``weight_gyro``.
    """

    statistics = (ACC_SCATTER, GYRO_MOMENTS)
    needs = ("kong", "triad")
    diagnostics = ("weight_kong", "weight_gyro")
    signal = "acc+gyr"

    def fit(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod]) -> Combined:
        """The combined heading of each row (class docstring)."""
        kong, axis_flag = fitted["kong"], fitted["triad"].flag_
        w_kong, w_gyro = _weights(pooled, kong, axis_flag == "")
        R = _rotation(pooled, kong, w_kong, w_gyro)
        undetermined = w_kong + w_gyro <= 0
        switches = _weight_switches(pooled.unit, w_kong, w_gyro)
        flag = [
            combine_flags(k, a) or "not_planar" if none else ("weight_switch" if switch else "")
            for k, a, none, switch in zip(kong.flag_, axis_flag, undetermined, switches)
        ]
        return self._set(R, flag, {"weight_kong": w_kong, "weight_gyro": w_gyro})

    def resample(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod]) -> Combined:
        """The combined heading of bootstrap resamples, as :meth:`fit` weighs it: Kong's resampled
        calibrations (``fitted['kong']``, weight 0 where flagged) and the resampled gyroscope axis
        (weight 0 where the axis methods flag it, ``fitted['triad']``).
        """
        kong = fitted["kong"]
        w_kong, w_gyro = _weights(pooled, kong, fitted["triad"].flag_ == "")
        R = _rotation(pooled, kong, w_kong, w_gyro)
        return self._set(R, np.where(np.isfinite(R).all(axis=(1, 2)), "", "not_planar"))


def _weight_switches(unit: np.ndarray, w_kong: np.ndarray, w_gyro: np.ndarray) -> np.ndarray:
    """True for every row of a unit whose calibrations (all repetitions and the subsets) do not
    all use the same estimates: one of the two weights 0 in some and not in others. The heading
    then jumps with the choice of repetitions (10-12 deg on real walking), however
    repeatable each estimate is: flagged ``weight_switch``.
    """
    switch = np.zeros(len(unit), dtype=bool)
    for weight in (w_kong, w_gyro):
        used = (weight > 0).astype(float)
        some = np.bincount(unit, used, minlength=unit.max() + 1 if len(unit) else 0)
        count = np.bincount(unit, minlength=len(some))
        mixed = (some > 0) & (some < count)
        switch |= mixed[unit]
    return switch
