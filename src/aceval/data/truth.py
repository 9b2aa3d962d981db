"""A sensor's true orientation from optical point accelerations: no marker frame needs to stay fixed
to the sensor while the subject walks.

The marker-frame method (:mod:`aceval.importers.vicon`, ``ground_truth``) fits the gyroscope to the
angular velocity of a segment frame built from markers over the whole walk; where the markers twist
about the segment's long axis relative to the bone under the sensor (soft tissue, wands), that fit
inherits the twist. This method uses the markers only as points whose acceleration is known:

1. Quiet standing gives the sensor's vertical from the accelerometer (``up`` in the sensor frame),
   so its orientation while standing is known up to a heading ``psi`` about the world vertical:
   ``R_ws0 = Rz(psi) R0`` (``R0``: any rotation taking ``up`` to world z).
2. The gyroscope (bias from the standing period removed) propagates that orientation through the
   first straight walking bout: ``R_ws(t) = Rz(psi) R0 dR(t)``.
3. The sensor's specific force in the world frame, ``R_ws(t) f(t)``, must equal the optical
   acceleration of the sensor's location minus gravity. The location is a point ``P`` rigid with
   the segment (a joint centre on the long axis, so a twist about that axis does not move it)
   plus an unknown lever arm ``d`` (sensor frame), whose acceleration the gyroscope gives:
   ``a_s = a_P + R_ws (alpha x d + omega x (omega x d))``.
4. ``psi`` and ``d`` minimise the misfit (alternating: a 2-D Procrustes for ``psi``, least squares
   for ``d``). Everything is low-passed alike (6 Hz).

Uncertainty: the RMS misfit (m/s^2), the heading from each half of the bout (``split_half_deg``)
and the lever arm itself (where the sensor sits).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.data.contract import GRAVITY

LOWPASS_HZ = 6.0
#: gravity in a world frame with z up: specific force = acceleration - this
GRAVITY_UP_WORLD = np.array([0.0, 0.0, -GRAVITY])


def lowpass(x: np.ndarray, fs_hz: float, cutoff_hz: float = LOWPASS_HZ) -> np.ndarray:
    """Zero-phase 2nd-order Butterworth low-pass along the first axis."""
    from scipy.signal import butter, sosfiltfilt  # here: its import costs about 1 s (SciPy 1.17)

    return sosfiltfilt(butter(2, cutoff_hz, fs=fs_hz, output="sos"), x, axis=0)


def propagate(gyr: np.ndarray, fs_hz: float) -> Rotation:
    """Orientation relative to the first sample, ``dR(t)`` (sensor at t -> sensor at 0), by
    composing the gyroscope's increments (rad/s, sensor frame): ``dR(t+1) = dR(t) exp(w(t) dt)``.
    """
    steps = Rotation.from_rotvec(np.asarray(gyr, float)[:-1] / fs_hz)
    out = [Rotation.identity()]
    for step in steps:
        out.append(out[-1] * step)
    return Rotation.concatenate(out)


def point_acceleration(position: np.ndarray, fs_hz: float) -> np.ndarray:
    """Second derivative (m/s^2) of a low-passed trajectory (N, 3) in metres."""
    smooth = lowpass(position, fs_hz)
    return np.gradient(np.gradient(smooth, 1.0 / fs_hz, axis=0), 1.0 / fs_hz, axis=0)


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _fit(Q: np.ndarray, f: np.ndarray, K: np.ndarray, w: np.ndarray, iterations: int = 50) -> tuple:
    """Heading psi (rad) and lever arm d (m) minimising |Rz(psi) Q (f - K d) - w|^2 over samples."""
    d, psi = np.zeros(3), 0.0
    QK = np.einsum("nij,njk->nik", Q, K)
    Qf = np.einsum("nij,nj->ni", Q, f)
    for _ in range(iterations):
        v = Qf - np.einsum("nij,j->ni", QK, d)
        previous = psi
        psi = float(np.arctan2(np.sum(v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]),
                               np.sum(v[:, 0] * w[:, 0] + v[:, 1] * w[:, 1])))  # fmt: skip
        back = Rotation.from_euler("z", -psi).apply(w)  # Rz(psi)^T w
        d, *_ = np.linalg.lstsq(QK.reshape(-1, 3), (Qf - back).reshape(-1), rcond=None)
        if abs(psi - previous) < 1e-10:
            break
    v = Qf - np.einsum("nij,j->ni", QK, d)
    residual = Rotation.from_euler("z", psi).apply(v) - w
    return psi, d, float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def acceleration_truth(
    acc: np.ndarray,
    gyr: np.ndarray,
    point_world: np.ndarray,
    standing: tuple[int, int],
    bout: tuple[int, int],
    fs_hz: float,
    lag: int = 0,
) -> dict:
    """The sensor's orientation while standing (``R_ws0``: sensor -> world, world z up) from
    quiet standing and the optical acceleration of a point ``point_world`` (N, 3, metres, world
    frame) rigid with the segment, over the walking ``bout`` (module docstring).

    ``acc`` (m/s^2) and ``gyr`` (rad/s) are the sensor's (N, 3) samples; IMU sample ``t + lag``
    matches optical sample ``t``. Returns ``R_ws0`` (Rotation), ``lever_arm_m`` (sensor frame, from
    the point to the sensor), ``rms_misfit_m_s2``, ``split_half_deg`` and ``n_samples``.
    """
    acc, gyr = np.asarray(acc, float), np.asarray(gyr, float)
    s0, s1 = standing
    a, b = bout
    up = np.median(acc[s0:s1], axis=0)
    R0, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [up / np.linalg.norm(up)])
    bias = gyr[s0:s1].mean(axis=0)
    start = s1 - 1  # the last standing sample: its orientation is R_ws0
    delta = propagate(gyr[start + lag : b + lag] - bias, fs_hz)  # sensor(t) -> sensor(start)
    span = slice(a - start, b - start)
    Q = (R0 * delta[span]).as_matrix()
    f = lowpass(acc, fs_hz)[a + lag : b + lag]
    omega = lowpass(gyr - bias, fs_hz)
    alpha = np.gradient(omega, 1.0 / fs_hz, axis=0)[a + lag : b + lag]
    omega = omega[a + lag : b + lag]
    K = _skew(alpha) + _skew(omega) @ _skew(omega)
    w = point_acceleration(point_world, fs_hz)[a:b] - GRAVITY_UP_WORLD
    psi, lever, rms = _fit(Q, f, K, w)
    half = (b - a) // 2
    halves = [
        _fit(Q[part], f[part], K[part], w[part])[0] for part in (slice(0, half), slice(half, None))
    ]
    split = abs((halves[0] - halves[1] + np.pi) % (2 * np.pi) - np.pi)
    return {
        "R_ws0": Rotation.from_euler("z", psi) * R0,
        "lever_arm_m": lever,
        "rms_misfit_m_s2": rms,
        "split_half_deg": float(np.degrees(split)),
        "n_samples": b - a,
        # the sensor's orientation (sensor -> world) from the end of standing to the end of the
        # bout, optical samples [start, b): for the marker-frame twist check
        "orientation": Rotation.from_euler("z", psi) * R0 * delta,
        "start": start,
    }


def twist_about_axis(
    frames: Rotation, sensor: Rotation, axis: np.ndarray, start: int
) -> np.ndarray:
    """Marker frame vs IMU: the rotation of the segment frame relative to the sensor since sample
    ``start`` (deg, about the segment's long ``axis``, segment frame), per sample. Zero when the
    marker frame stays fixed to the sensor; a soft-tissue or wand twist shows here.
    """
    relative = frames.inv() * sensor  # sensor -> segment, per sample
    change = relative * relative[start].inv()  # the mounting's apparent change since standing
    return np.degrees(change.as_rotvec() @ (np.asarray(axis, float) / np.linalg.norm(axis)))


def pair_consistency_deg(
    gyr_a: np.ndarray, gyr_b: np.ndarray, R_a: np.ndarray, R_b: np.ndarray
) -> float:
    """Two sensors on one segment: the rotation between them measured by their gyroscopes (the
    one mapping b's angular velocity onto a's, ``Rotation.align_vectors``) against the one their
    truths imply (``R_a^T R_b``: b -> body -> a). The angle between the two (deg).
    """
    measured, _ = Rotation.align_vectors(gyr_a, gyr_b)
    implied = Rotation.from_matrix(np.asarray(R_a, float).T @ np.asarray(R_b, float))
    return float(np.degrees((measured * implied.inv()).magnitude()))
