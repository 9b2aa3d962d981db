"""An uncertainty with a calibration: a bootstrap over its repetitions (beyond the papers), for
every calibration aceval makes from a motion test's repetitions: Kong's, the axis methods', the
combined and the step-harmonic (not the peers', which run in their own environments, nor Ricci's
functional design, whose axes pool all trials of several tests).

Every repetition of a motion test is reduced to a 3x3 acceleration scatter and a 3x3 unit
gyroscope scatter (:mod:`aceval.signals.reduction`), so a calibration from any resample of repetitions
costs one weighted 3x3 sum and one ``eigh``. :func:`bootstrap_cone` draws ``n_boot`` resamples
of the repetitions with replacement (Efron's bootstrap, the repetition as the unit), calibrates
each, and reports the 95th percentile of the angle between a resample's calibration and the
calibration from all repetitions (Kong Eq. 11) as the half-angle of a 95 % cone, and the median
share of those deviations about the body vertical.

What it does not see: z0 from quiet standing is held (one static recording gives no resample),
so the cone is the heading's spread only; a bias shared by all repetitions (a sensor that does
not move in the segment's sagittal plane, soft tissue, a tilted stance) moves every resample
alike and is outside the cone. With 5 repetitions a bootstrap also underestimates the spread
(its variance is the plug-in one, (n - 1) / n of the unbiased). ``results/<dataset>/tables/
uncertainty`` measures the cone's coverage against the ground truth.
"""

from __future__ import annotations

import numpy as np

from aceval.data.rotations import error_angle_deg, vertical_share
from aceval.methods.combined import combined_rotation, gyro_weight, horizontal_right, kong_weight
from aceval.methods.functional import SAGITTAL_REFERENCE, AxisLimits, subset_axes
from aceval.methods.kong import KongLimits, kong_from_scatters
from aceval.methods.ricci import wahba_batch
from aceval.methods.step_harmonic import MAX_STEP_RATIO, step_harmonic_rotation
from aceval.methods.triad import triad_batch

#: resamples per calibration (the 95th percentile of 200 angles: its 10th largest)
N_BOOT = 200
#: the cone's coverage level
LEVEL = 0.95


def resample_weights(n_rep: int, n_boot: int = N_BOOT, seed: int = 0) -> np.ndarray:
    """(n_boot, n_rep): how often each repetition is drawn in each bootstrap resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_rep, np.full(n_rep, 1.0 / n_rep), size=n_boot).astype(float)


def cone(resampled: np.ndarray, R: np.ndarray) -> tuple[float, float]:
    """``(cone95_deg, cone_vertical_share)`` of resampled calibrations (B, 3, 3) about ``R``;
    NaN when ``R`` or fewer than half of the resamples are finite.
    """
    ok = np.isfinite(resampled).all(axis=(1, 2))
    if not np.isfinite(R).all() or ok.sum() < len(resampled) / 2:
        return float("nan"), float("nan")
    angles = error_angle_deg(resampled[ok], R)
    share = vertical_share(resampled[ok], R)
    share = share[np.isfinite(share)]
    return (
        float(np.percentile(angles, 100 * LEVEL)),
        float(np.median(share)) if len(share) else float("nan"),
    )


def _axis_method_cones(rho, axes, z0, right, rho_static, R_axis, rho_min) -> dict:
    """The cones of the axis methods from the resampled gyroscope axes (``rho``, ``axes``: one per
    resample): TRIAD (the more reliable axis exact, Ricci's choice) and the weighted Wahba
    optimum (``align_vectors``). Ricci's LM minimises the same cost and reaches that optimum
    (``optimum_distance_deg`` in its calibration), so its cone is the optimum's resampled spread,
    not 200 LM runs. A resample whose axis would be flagged (``low_rho``, ``axis_near_vertical``:
    :class:`aceval.methods.functional.AxisLimits`) counts as NaN.
    """
    if not R_axis:
        return {}
    axes = axes * np.where(axes @ np.asarray(right, float) < 0, -1.0, 1.0)[:, None]
    min_cos = np.cos(np.radians(AxisLimits().min_vertical_angle_deg))
    usable = ((rho >= rho_min) & (np.abs(axes @ z0) <= min_cos))[:, None, None]
    v_est = np.stack([np.broadcast_to(z0, axes.shape), axes], axis=1)
    weights = np.column_stack([np.full(len(rho), rho_static), rho])
    optimum = np.where(usable, wahba_batch(SAGITTAL_REFERENCE, v_est, weights), np.nan)
    resampled = {
        "align_vectors": optimum,
        "ricci_lm": optimum,
        "triad": np.where(usable, triad_batch(z0, axes, rho_static, rho), np.nan),
    }
    return {
        method: cone(resampled[method], R_axis[method])
        for method in resampled
        if R_axis.get(method) is not None
    }


def bootstrap_cone(
    scatters,
    counts,
    unit_scatters,
    z0,
    right,
    R_kong,
    R_combined,
    rho_min: float,
    limits: KongLimits = KongLimits(),
    n_boot: int = N_BOOT,
    seed: int = 0,
    step_scatters=None,
    R_step=None,
    rho_static: float = 1.0,
    R_axis: dict | None = None,
) -> dict[str, tuple[float, float]]:
    """The 95 % cones of Kong's and the combined calibration of one IMU and test from all its
    repetitions: ``{'kong': (cone95_deg, vertical_share), 'combined': (...)}``; with
    ``step_scatters`` (n_rep, 3, 3) and ``R_step``, also ``'step_harmonic'``; with ``R_axis``
    (method -> R from all repetitions of the axis methods), theirs (:func:`_axis_method_cones`).

    ``scatters``, ``unit_scatters``: (n_rep, 3, 3) per repetition (acceleration, m^2/s^4; unit
    gyroscope); ``counts``: (n_rep,) samples; ``z0``, ``right``: (3,); ``R_kong``, ``R_combined``:
    the calibrations from all repetitions; ``rho_min``: the gyroscope axis's flag limit. A resample
    that Kong's limits flag counts as NaN for Kong (and weighs 0 in the combined heading), as the
    calibration itself would be.
    """
    weights = resample_weights(len(counts), n_boot, seed)
    kong = kong_from_scatters(
        scatters, counts, z0, right, weights=weights, limits=limits, strict=False
    )
    R = np.where((kong.flag == "")[:, None, None], kong.R, np.nan)
    rho, axes = subset_axes(unit_scatters, weights)
    combined = combined_rotation(
        z0,
        kong.R[:, 1],
        horizontal_right(axes, z0, right),
        np.where(
            kong.flag == "",
            kong_weight(
                kong.normal_ratio, kong.planarity, limits.max_normal_ratio, limits.max_planarity
            ),
            0.0,
        ),
        gyro_weight(rho, rho_min),
    )
    cones = {"kong": cone(R, R_kong), "combined": cone(combined, R_combined)}
    cones.update(_axis_method_cones(rho, axes, z0, right, rho_static, R_axis or {}, rho_min))
    if step_scatters is not None and R_step is not None:
        step, ratio = step_harmonic_rotation(
            np.einsum("br,rij->bij", weights, step_scatters), z0, right
        )
        step = np.where((ratio <= MAX_STEP_RATIO)[:, None, None], step, np.nan)
        cones["step_harmonic"] = cone(step, R_step)
    return cones
