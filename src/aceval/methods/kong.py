"""Kong et al. 2016 sagittal-plane calibration (Sections 2.1 and 2.4.1, Eq. 1-6).

* z0: the downward vertical in the sensor frame from quiet stance (Eq. 2). Accelerometers report
  specific force, which points *up* at rest, so ``z0 = -median(acc) / |median(acc)|``.
* n: the normal of the plane through the origin that best fits the motion-test accelerations,
  i.e. the eigenvector of the smallest eigenvalue of the scatter of {a_k} U {-a_k} (Eq. 3, Fig. 2).
  That set has zero mean, so its covariance is ``sum(a_k a_k^T) / N``: the plane is found from the
  per-repetition scatter matrices alone, and the scatter of a union of repetitions is their sum.
* x0 = n x z0 (Eq. 4), y0 = z0 x x0 (Eq. 5), ``R = [x0 y0 z0]^T`` (Eq. 1) maps sensor to body.
  The sign of n is chosen so that y0 points along the IMU's declared ``right_axis``.

Diagnostics for each calibration: number of samples, the three eigenvalues of the second-moment
matrix ``sum(a a^T)/N`` (m^2/s^4, descending), planarity = smallest/largest eigenvalue, the ratio
smallest/middle eigenvalue (near 1 when the normal is undetermined) and the angle (deg, 0-90)
between n and z0 before orthogonalisation (90 for a perfectly sagittal motion).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from aceval.data.errors import NormalParallelToVerticalError, NotPlanarError, TooFewSamplesError
from aceval.data.rotations import axis_vector, vector_angle_deg
from aceval.methods.interface import CalibrationMethod
from aceval.methods.moments import MIN_GRAVITY, MIN_SAMPLES, scatter, vertical_axis
from aceval.methods.sufficient import ACC_SCATTER, GYRO_MOMENTS, Pooled


@dataclass(frozen=True)
class KongLimits:
    """Limits beyond which a calibration is refused (or flagged). Documented defaults:

    * ``min_samples``: fewer samples cannot define a plane robustly (10).
    * ``min_gravity``: a quiet-stance median below this (m/s^2) is not gravity (0.5).
    * ``max_planarity``: smallest/largest eigenvalue above this means the accelerations do not lie
      near a plane (0.1; a sagittal motion has values near 0.01).
    * ``max_normal_ratio``: smallest/middle eigenvalue above this means the two smallest
      principal axes cannot be told apart, so the normal is undetermined (0.5; e.g. a motion with no
      rotation, whose accelerations stay along gravity).
    * ``min_normal_vertical_angle_deg``: the normal must be at least this far from z0 (45 deg):
      closer, the motion plane is more horizontal than vertical.
    """

    min_samples: int = MIN_SAMPLES
    min_gravity: float = MIN_GRAVITY
    max_planarity: float = 0.1
    max_normal_ratio: float = 0.5
    min_normal_vertical_angle_deg: float = 45.0


@dataclass
class KongResult:
    """Calibrations of a batch: leading shape ``B`` (e.g. IMUs x subsets).

    ``R`` (B, 3, 3) maps sensor to body; ``flag`` is '' where valid, else the error code.
    """

    R: np.ndarray
    n_samples: np.ndarray
    eigenvalues: np.ndarray
    planarity: np.ndarray
    normal_ratio: np.ndarray
    normal_vertical_angle_deg: np.ndarray
    flag: np.ndarray
    messages: list[str] = field(default_factory=list)

    @property
    def valid(self) -> np.ndarray:
        """True where the calibration is not flagged."""
        return self.flag == ""


def _subset_membership(subsets: Sequence[Sequence[int]], n_rep: int) -> np.ndarray:
    membership = np.zeros((len(subsets), n_rep))
    for row, subset in enumerate(subsets):
        if len(subset) == 0:
            raise ValueError(f"subset {row} is empty")
        for rep in subset:
            if not 0 <= rep < n_rep:
                raise ValueError(f"subset {row} names repetition index {rep}; there are {n_rep}")
            membership[row, rep] = 1.0
    return membership


def kong_from_scatters(
    scatters,
    counts,
    z0,
    right_axis,
    subsets: Sequence[Sequence[int]] | None = None,
    limits: KongLimits = KongLimits(),
    strict: bool = True,
    weights: np.ndarray | None = None,
) -> KongResult:
    """Kong calibration for any subsets of repetitions, from per-repetition scatters.

    Parameters
    ----------
    scatters: (..., n_rep, 3, 3) ``sum a a^T`` of each repetition's trimmed accelerations (m^2/s^4).
    counts: (..., n_rep) number of samples of each repetition.
    z0: (..., 3) downward vertical of each IMU (from :func:`vertical_axis`).
    right_axis: signed sensor axis ('+y', ...) or unit vector(s) (..., 3) pointing roughly right.
    subsets: list of repetition-index lists (0-based); default: all repetitions together.
    strict: raise on the first invalid calibration; otherwise return it flagged.
    weights: (n_subsets, n_rep) how often each repetition counts, instead of ``subsets`` (a
        bootstrap resample counts a repetition 0, 1, 2... times).

    Returns a :class:`KongResult` of leading shape (..., n_subsets). Cost: one 3x3 sum and one
    ``eigh`` per subset, vectorised over IMUs and subsets; samples are never touched again.
    """
    scatters = np.asarray(scatters, dtype=float)
    counts = np.asarray(counts, dtype=float)
    if scatters.shape[-2:] != (3, 3) or scatters.shape[:-2] != counts.shape:
        raise ValueError(
            f"scatters {scatters.shape} and counts {counts.shape} do not match (..., n_rep, 3, 3)"
        )
    batch, n_rep = counts.shape[:-1], counts.shape[-1]
    if weights is not None:
        membership = np.asarray(weights, dtype=float)
    else:
        membership = _subset_membership([list(range(n_rep))] if subsets is None else subsets, n_rep)

    total = np.einsum("sr,...rij->...sij", membership, scatters)
    n_samples = np.einsum("sr,...r->...s", membership, counts)
    with np.errstate(invalid="ignore", divide="ignore"):
        moment = total / n_samples[..., None, None]
    moment = np.where(n_samples[..., None, None] > 0, moment, 0.0)
    eigenvalues, eigenvectors = np.linalg.eigh(moment)  # ascending
    normal = eigenvectors[..., :, 0]

    z0 = np.broadcast_to(np.asarray(z0, dtype=float)[..., None, :], normal.shape)
    right = np.broadcast_to(_right_vectors(right_axis)[..., None, :], normal.shape)

    # y0 is the part of n orthogonal to z0 (Eq. 5 after Eq. 4): flip n so that y0 points right
    y_raw = normal - np.sum(normal * z0, axis=-1, keepdims=True) * z0
    sign = np.where(np.sum(y_raw * right, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    normal = normal * sign
    x0 = np.cross(normal, z0)
    x_norm = np.linalg.norm(x0, axis=-1, keepdims=True)
    x0 = x0 / np.where(x_norm > 0, x_norm, 1.0)
    y0 = np.cross(z0, x0)
    R = np.stack([x0, y0, z0], axis=-2)

    cos_nz = np.clip(np.abs(np.sum(normal * z0, axis=-1)), 0.0, 1.0)
    angle = np.degrees(np.arccos(cos_nz))
    eig_desc = eigenvalues[..., ::-1]
    with np.errstate(invalid="ignore", divide="ignore"):
        planarity = eig_desc[..., 2] / eig_desc[..., 0]
        normal_ratio = eig_desc[..., 2] / eig_desc[..., 1]

    flag, messages = _limit_flags(n_samples, planarity, normal_ratio, angle, limits, strict, batch)
    return KongResult(
        R=R,
        n_samples=n_samples.astype(int),
        eigenvalues=eig_desc,
        planarity=planarity,
        normal_ratio=normal_ratio,
        normal_vertical_angle_deg=angle,
        flag=flag,
        messages=messages,
    )


def _right_vectors(right_axis) -> np.ndarray:
    """Unit vectors (..., 3) of declared right axes given as '+y'-style names or vectors."""
    if isinstance(right_axis, str):
        return axis_vector(right_axis)
    right = np.asarray(right_axis)
    if right.dtype.kind in "UO":
        right = np.stack([axis_vector(a) for a in right.ravel()]).reshape(*right.shape, 3)
    return np.asarray(right, dtype=float)


def _limit_flags(
    n_samples, planarity, normal_ratio, angle, limits: KongLimits, strict: bool, batch
):
    """Each calibration's flag beyond :class:`KongLimits` ('' when valid; the first limit it
    fails, in the order below) and a message per kind of flag; ``strict``: raise on the first.
    """
    flag = np.full(n_samples.shape, "", dtype=object)
    messages: list[str] = []
    checks = [
        (
            n_samples < limits.min_samples,
            TooFewSamplesError,
            lambda i: (
                f"{int(n_samples[i])} motion samples, at least {limits.min_samples} are needed"
            ),
        ),
        (
            ~(planarity <= limits.max_planarity),
            NotPlanarError,
            lambda i: (
                f"accelerations are not planar: planarity {planarity[i]:.3f} > "
                f"{limits.max_planarity} (smallest/largest eigenvalue)"
            ),
        ),
        (
            ~(normal_ratio <= limits.max_normal_ratio),
            NotPlanarError,
            lambda i: (
                f"plane normal undetermined: smallest/middle eigenvalue {normal_ratio[i]:.3f} > "
                f"{limits.max_normal_ratio}"
            ),
        ),
        (
            angle < limits.min_normal_vertical_angle_deg,
            NormalParallelToVerticalError,
            lambda i: (
                f"plane normal is {angle[i]:.1f} deg from the vertical z0 "
                f"(< {limits.min_normal_vertical_angle_deg} deg): the motion is not sagittal"
            ),
        ),
    ]
    for bad, error, describe in checks:
        bad = bad & (flag == "")
        if bad.any():
            index = tuple(np.argwhere(bad)[0])
            message = describe(index)
            if strict:
                where = f" (batch index {index})" if len(index) > 1 or batch else ""
                raise error(message + where)
            flag[bad] = error.code
            messages.append(f"{int(bad.sum())} calibrations flagged {error.code}, e.g. {message}")

    return flag, messages


def kong_calibrate(
    acc_static,
    acc_motion,
    right_axis,
    limits: KongLimits = KongLimits(),
) -> KongResult:
    """Kong calibration of one IMU from quiet stance and (already trimmed) motion accelerations.

    ``acc_motion`` is an (N, 3) array or a list of per-repetition arrays, all joined (Section
    2.4.1). Returns a :class:`KongResult` with ``R`` of shape (3, 3); raises on bad input.
    """
    z0 = vertical_axis(acc_static, limits.min_samples, limits.min_gravity)
    # a list or tuple holds repetitions (of any lengths); anything else is one (N, 3) array
    repetitions = list(acc_motion) if isinstance(acc_motion, (list, tuple)) else [acc_motion]
    scatters = np.stack([scatter(rep) for rep in repetitions])
    counts = np.array([len(rep) for rep in repetitions])
    result = kong_from_scatters(scatters, counts, z0, right_axis, limits=limits, strict=True)
    return KongResult(
        R=result.R[0],
        n_samples=result.n_samples[0],
        eigenvalues=result.eigenvalues[0],
        planarity=result.planarity[0],
        normal_ratio=result.normal_ratio[0],
        normal_vertical_angle_deg=result.normal_vertical_angle_deg[0],
        flag=result.flag[0],
        messages=result.messages,
    )


# --- the method's interface (aceval.methods.interface) ------------------------------------------


class Kong(CalibrationMethod):
    """Kong's calibration (Eq. 1-6) of each pooled row, on every subset of a unit's repetitions.

    Parameters
    ----------
    limits
        :class:`KongLimits`: the planarity, normal-ratio and normal-vertical limits beyond which
        a calibration is flagged.

    Attributes
    ----------
    rotation_, flag_
        R (B, 3, 3) and its flag beyond ``limits``.
    diagnostics_
        The eigenvalues of the second moment (``eig1..3``, m^2/s^4, descending),
        ``planarity``, ``normal_ratio``, ``normal_vertical_angle_deg``;
        ``normal_gyro_angle_deg``: the angle (deg) of the gyroscope axis of the same repetitions
        to Kong's body y. The accelerations' reference in the others' cones.

    Examples
    --------
    >>> from aceval.methods.sufficient import Units, pool
    >>> import numpy as np
    >>> hinge = np.diag([1.0, 0.0, 1.0]) * 100.0  # accelerations in the x-z plane
    >>> units = Units.of_repetitions([0, 0, 1], [0, 1, 0], [hinge] * 3, [100] * 3, [np.eye(3)] * 3)
    >>> pooled = pool(units, [0], [[1.0, 1.0, 1.0]])
    >>> np.round(Kong().fit(pooled, {}).rotation_[0], 6) + 0.0
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """

    statistics = (ACC_SCATTER, GYRO_MOMENTS)
    every_subset = True
    diagnostics = (
        "eig1",
        "eig2",
        "eig3",
        "planarity",
        "normal_ratio",
        "normal_vertical_angle_deg",
        "normal_gyro_angle_deg",
    )
    signal = "acc"
    cone_reference = True

    def __init__(self, limits: KongLimits = KongLimits()):
        self.limits = limits

    def fit(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod] | None = None) -> Kong:
        """Kong's calibration of each row of ``pooled`` (class docstring)."""
        result = kong_from_scatters(
            pooled.scatter[:, None],
            pooled.n_samples[:, None],
            pooled.z0,
            pooled.right,
            limits=self.limits,
            strict=False,
        )
        R = result.R[:, 0]
        gyro_angle = vector_angle_deg(R[:, 1], pooled.gyro_axis, sign_free=True)
        eigenvalues = result.eigenvalues[:, 0]
        columns = {
            **{f"eig{k + 1}": eigenvalues[:, k] for k in range(3)},
            "planarity": result.planarity[:, 0],
            "normal_ratio": result.normal_ratio[:, 0],
            "normal_vertical_angle_deg": result.normal_vertical_angle_deg[:, 0],
            "normal_gyro_angle_deg": gyro_angle,
        }
        return self._set(R, result.flag[:, 0], columns)

    def resample(
        self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod] | None = None
    ) -> Kong:
        """:meth:`fit` of bootstrap resamples, R NaN where a resample is flagged."""
        self.fit(pooled)
        valid = (self.flag_ == "")[:, None, None]
        return self._set(np.where(valid, self.rotation_, np.nan), self.flag_, self.diagnostics_)
