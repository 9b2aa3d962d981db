"""The equations behind the sufficient statistics every method pools (Kong Eq. 2-3, Ricci Eq. 1-2):
functions of one recording's samples, and of summed moments, that know no method.

* :func:`vertical_axis`: the downward vertical z0 from quiet stance (Kong Eq. 2);
* :func:`scatter`: the scatter ``sum a a^T`` of accelerations, whose sum over repetitions is the
  scatter of their union (Kong Eq. 3);
* :func:`unit_moments`, :func:`axis_from_moments`, :func:`functional_axis`: the functional axis and
  its reliability rho from the moments of unit-normalised samples (Ricci Eq. 1-2);
* :func:`first_phase_sign` and :func:`recording_moments`: one recording's moments with its own
  axis signed by the first movement phase.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aceval.data.errors import TooFewSamplesError, ZeroGravityError, check_samples

#: fewer quiet-stance samples cannot give a robust vertical (:class:`aceval.methods.kong.KongLimits`)
MIN_SAMPLES = 10
#: a quiet-stance median below this (m/s^2) is not gravity
MIN_GRAVITY = 0.5


def vertical_axis(
    acc_static, min_samples: int = MIN_SAMPLES, min_gravity: float = MIN_GRAVITY
) -> np.ndarray:
    """Downward vertical z0 (unit, sensor frame) from quiet-stance specific force (Kong Eq. 2).

    ``acc_static`` (N, 3) in m/s^2. The median makes z0 robust to brief movements.
    """
    acc = check_samples(acc_static, name="quiet-stance acceleration", min_samples=min_samples)
    median = np.median(acc, axis=0)
    norm = float(np.linalg.norm(median))
    if norm < min_gravity:
        raise ZeroGravityError(
            f"quiet-stance acceleration has median length {norm:.3g} m/s^2 "
            f"(< {min_gravity}): no gravity direction can be found"
        )
    return -median / norm


def scatter(acc) -> np.ndarray:
    """Scatter matrix ``sum_k a_k a_k^T`` (3x3, m^2/s^4) of accelerations (N, 3)."""
    acc = check_samples(acc, name="motion acceleration", min_samples=1)
    return acc.T @ acc


@dataclass(frozen=True)
class AxisEstimate:
    """A functional axis (unit, sensor frame), its reliability rho and the singular values."""

    axis: np.ndarray
    rho: float
    singular_values: np.ndarray
    n_samples: int


def unit_moments(samples, min_norm: float = 1e-9) -> tuple[np.ndarray, np.ndarray, int]:
    """Sum (3,) and scatter ``sum u u^T`` (3, 3) of the unit-normalised samples (Ricci Sec. 2.2.2).

    Samples with norm below ``min_norm`` cannot be normalised and are left out; the count of the
    others is returned. The singular values of the (N, 3) matrix of unit samples are the square
    roots of the scatter's eigenvalues, so the axis and rho of any union of recordings follow from
    the sum of their moments (:func:`axis_from_moments`) without reading the samples again.
    """
    samples = check_samples(samples, name="functional-axis samples", min_samples=1)
    norms = np.linalg.norm(samples, axis=1)
    keep = norms >= min_norm
    unit = samples[keep] / norms[keep, None]
    return unit.sum(axis=0), unit.T @ unit, int(keep.sum())


def axis_from_moments(unit_sum, unit_scatter, n_samples: int, min_samples: int = 3) -> AxisEstimate:
    """Axis (first right singular vector) and ``rho = s1 / (s1 + s2 + s3)`` (Ricci Eq. 1-2) from
    the moments of :func:`unit_moments`.

    Sign (SVD leaves it arbitrary): the axis points to the side where the samples' mean projection
    is positive - for a static posture, along the measured vector. For a back-and-forth rotation
    that mean is near zero, so callers orient movement axes themselves (by the declared right
    axis, or by the first movement phase: :func:`first_phase_sign`). On an exact tie the largest
    component is made positive.
    """
    if n_samples < min_samples:
        raise TooFewSamplesError(
            f"functional axis: {n_samples} samples with a non-zero norm, at least {min_samples} are needed"
        )
    eigenvalues, vectors = np.linalg.eigh(np.asarray(unit_scatter, dtype=float))
    singular_values = np.sqrt(np.clip(eigenvalues[::-1], 0.0, None))
    axis = vectors[:, -1]
    projection = float(np.asarray(unit_sum, dtype=float) @ axis) / n_samples
    if abs(projection) > 1e-12:
        axis = axis * np.sign(projection)
    elif axis[np.argmax(np.abs(axis))] < 0:
        axis = -axis
    rho = float(singular_values[0] / singular_values.sum())
    return AxisEstimate(
        axis=axis, rho=rho, singular_values=singular_values, n_samples=int(n_samples)
    )


def functional_axis(samples, min_samples: int = 3, min_norm: float = 1e-9) -> AxisEstimate:
    """Axis and reliability index of gyroscope or accelerometer samples (Ricci Eq. 1-2).

    Samples with norm below ``min_norm`` cannot be unit-normalised and are dropped (trim rest
    periods first). The sign rule is that of :func:`axis_from_moments`.
    """
    return axis_from_moments(*unit_moments(samples, min_norm), min_samples=min_samples)


def first_phase_sign(gyr, axis, fs_hz: float) -> float:
    """+1 when the first half-movement about ``axis`` is a positive (right-hand) rotation, -1 when
    negative, 0 when there is no rotation about it.

    ``gyr`` (N, 3, rad/s) are the movement samples of one recording. The rotation angle about the
    axis, ``theta = cumsum(gyr . axis) / fs``, is followed until ``|theta|`` first reaches half
    its largest value; its sign there is the direction of the first phase (a flexion-first
    protocol gives the flexion direction even when each repetition returns to the start).
    """
    theta = np.cumsum(np.asarray(gyr, dtype=float) @ np.asarray(axis, dtype=float)) / fs_hz
    peak = float(np.max(np.abs(theta))) if len(theta) else 0.0
    if peak == 0.0:
        return 0.0
    first = int(np.argmax(np.abs(theta) >= 0.5 * peak))
    return float(np.sign(theta[first]))


#: the summary columns of one recording's statistics: Kong's scatter (:func:`scatter`), and the
#: unit-sample moments of :func:`recording_moments` (their sum, scatter, count and first-phase axis)
ACC_SCATTER_COLUMNS = [f"s{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
SUM_COLUMNS = ["m_x", "m_y", "m_z"]
UNIT_SCATTER_COLUMNS = [f"u{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
PHASE_COLUMNS = ["phase_x", "phase_y", "phase_z"]
MOMENT_COLUMNS = SUM_COLUMNS + UNIT_SCATTER_COLUMNS + ["n_unit"] + PHASE_COLUMNS


def recording_moments(samples, fs_hz: float, motion: bool) -> dict:
    """Moments of one recording's unit samples (columns ``MOMENT_COLUMNS``).

    ``samples``: accelerometer (static test) or the trimmed gyroscope samples (motion test).
    For a motion test, ``phase_*`` is the recording's own axis signed by the direction of its
    first movement phase (:func:`first_phase_sign`); NaN for a static test.
    """
    unit_sum, scatter, n = unit_moments(samples)
    row = (
        dict(zip(SUM_COLUMNS, unit_sum))
        | dict(zip(UNIT_SCATTER_COLUMNS, scatter.ravel()))
        | {"n_unit": n}
    )
    phase = np.full(3, np.nan)
    if motion and n >= 3:
        axis = axis_from_moments(unit_sum, scatter, n).axis
        phase = axis * first_phase_sign(samples, axis, fs_hz)
    return row | dict(zip(PHASE_COLUMNS, phase))
