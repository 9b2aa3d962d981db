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

Uncertainty: the RMS misfit (m/s^2), the spread of the headings fitted on each stride alone
(weighted by how much the point accelerates: ``stride_sd_deg``, ``stride_se_deg``), and, from the
caller (:func:`aceval.importers.vicon.truth_rows`), the spread over other points of the segment and
over +-1 sample of time offset; the lever arm itself says where the sensor sits.
:func:`long_axis_heading_deg` checks a heading without any marker frame.
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
        psi = float(
            np.arctan2(
                np.sum(v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]),
                np.sum(v[:, 0] * w[:, 0] + v[:, 1] * w[:, 1]),
            )
        )
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
    strides: list[tuple[int, int]] | None = None,
) -> dict:
    """The sensor's orientation while standing (``R_ws0``: sensor -> world, world z up) from
    quiet standing and the optical acceleration of a point ``point_world`` (N, 3, metres, world
    frame) rigid with the segment, over the walking ``bout`` (module docstring).

    ``acc`` (m/s^2) and ``gyr`` (rad/s) are the sensor's (N, 3) samples; IMU sample ``t + lag``
    matches optical sample ``t``. Returns ``R_ws0`` (Rotation), ``heading_rad`` (its heading
    ``psi``), ``lever_arm_m`` (sensor frame, from the point to the sensor), ``rms_misfit_m_s2``,
    ``n_samples`` and, per stride of ``strides`` (sample ranges within the bout; the bout's start
    before the first one counts as one more), the heading fitted on that stride alone with the
    lever arm held: ``stride_sd_deg``, their SD about ``psi`` weighted by each stride's horizontal
    acceleration power (gait initiation, where the point hardly accelerates, weighs little), and
    ``stride_se_deg``, that SD over the square root of the strides' effective number.
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
    sd, se, n_strides = _stride_spread(Q, f, K, w, lever, psi, _chunks(strides, a, b))
    return {
        "R_ws0": Rotation.from_euler("z", psi) * R0,
        "heading_rad": psi,
        "lever_arm_m": lever,
        "rms_misfit_m_s2": rms,
        "stride_sd_deg": sd,
        "stride_se_deg": se,
        "n_strides": n_strides,
        "n_samples": b - a,
        # the sensor's orientation (sensor -> world) from the end of standing to the end of the
        # bout, optical samples [start, b): for the marker-frame twist check
        "orientation": Rotation.from_euler("z", psi) * R0 * delta,
        "start": start,
    }


def _chunks(strides, a: int, b: int) -> list[slice]:
    """The strides within the bout ``[a, b)`` as slices of it, the bout's start before the first
    one as one more; one chunk per second when no strides are given.
    """
    inside = sorted((max(s, a), min(e, b)) for s, e in (strides or []) if min(e, b) > max(s, a))
    if not inside:
        step = max(1, (b - a) // max(1, round((b - a) / 100)))  # about 1 s at 100 Hz
        return [slice(k, min(k + step, b - a)) for k in range(0, b - a, step)]
    chunks = [slice(0, inside[0][0] - a)] if inside[0][0] > a else []
    return chunks + [slice(s - a, e - a) for s, e in inside]


def _heading(Q, f, K, w, lever) -> float:
    """The heading (rad) that best maps the sensor's specific force onto the optical one, the
    lever arm held (the 2-D Procrustes step of :func:`_fit`).
    """
    v = np.einsum("nij,nj->ni", Q, f) - np.einsum("nij,njk,k->ni", Q, K, lever)
    return float(
        np.arctan2(
            np.sum(v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]),
            np.sum(v[:, 0] * w[:, 0] + v[:, 1] * w[:, 1]),
        )
    )


def _stride_spread(Q, f, K, w, lever, psi: float, chunks: list[slice]) -> tuple[float, float, int]:
    """Weighted SD (deg) of the chunks' own headings about ``psi``, its standard error (the
    weight: each chunk's horizontal optical acceleration power) and the number of chunks.
    """
    weights, offsets = [], []
    for chunk in chunks:
        if chunk.stop - chunk.start < 3:
            continue
        weights.append(float(np.sum(w[chunk, :2] ** 2)))
        own = _heading(Q[chunk], f[chunk], K[chunk], w[chunk], lever)
        offsets.append((own - psi + np.pi) % (2 * np.pi) - np.pi)
    weights, offsets = np.asarray(weights), np.asarray(offsets)
    if len(weights) < 2 or weights.sum() <= 0:
        return float("nan"), float("nan"), len(weights)
    sd = float(np.sqrt(np.sum(weights * offsets**2) / weights.sum()))
    n_effective = weights.sum() ** 2 / np.sum(weights**2)
    return float(np.degrees(sd)), float(np.degrees(sd / np.sqrt(n_effective))), len(weights)


def long_axis_heading_deg(
    orientation: Rotation, gyr: np.ndarray, line_from: np.ndarray, line_to: np.ndarray, fs_hz: float
) -> float:
    """An optical check of a sensor's heading that uses no marker frame: the angular velocity of
    a line rigid with the segment (two markers or joint centres, e.g. the knee and ankle centres
    for the shank) is seen directly across the line, ``u x du/dt``; the gyroscope, turned into
    the world by ``orientation`` (sensor -> world per sample, from a truth), must show the same.
    Returns the heading correction (deg, about the world vertical) that best matches them, from
    -180 to 180: near 0 when the truth's heading is right. ``gyr`` (rad/s, bias removed) and the
    lines' world trajectories (N, 3, m) share ``orientation``'s samples.
    """
    u = lowpass(np.asarray(line_to, float) - np.asarray(line_from, float), fs_hz)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    across = np.cross(u, np.gradient(u, 1.0 / fs_hz, axis=0))
    g = orientation.apply(lowpass(np.asarray(gyr, float), fs_hz))
    best, cost = 0.0, np.inf
    for heading in np.radians(np.arange(-180.0, 180.0, 0.5)):
        turned = Rotation.from_euler("z", heading).apply(g)
        perpendicular = turned - np.sum(turned * u, axis=1, keepdims=True) * u
        value = float(np.sum((perpendicular - across) ** 2))
        if value < cost:
            best, cost = heading, value
    return float(np.degrees(best))


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
) -> tuple[float, float]:
    """Two sensors on one segment: the rotation between them measured by their gyroscopes (the
    one mapping b's angular velocity onto a's, ``Rotation.align_vectors``) against the one their
    truths imply (``R_a^T R_b``: b -> body -> a). Their difference, expressed in the body frame,
    split into its part about the body vertical (``heading``, deg: what Kong's calibration
    estimates) and the rest (``tilt``, deg: which both truths share from the accelerometers'
    vertical), as ``(heading_deg, tilt_deg)``.
    """
    measured, _ = Rotation.align_vectors(gyr_a, gyr_b)
    implied = Rotation.from_matrix(np.asarray(R_a, float).T @ np.asarray(R_b, float))
    body = Rotation.from_matrix(np.asarray(R_a, float))  # sensor a -> body
    difference = body * (measured * implied.inv()) * body.inv()
    return swing_twist_deg(difference)


def swing_twist_deg(rotation: Rotation) -> tuple[float, float]:
    """``(twist, swing)`` (deg) of a rotation about the z axis: the angle of its part about z and
    of the rest (swing-twist decomposition, ``R = swing * twist``).
    """
    x, y, z, w = rotation.as_quat()
    norm = np.hypot(z, w)
    twist = Rotation.from_quat([0.0, 0.0, z / norm, w / norm]) if norm > 0 else Rotation.identity()
    swing = rotation * twist.inv()
    return float(np.degrees(twist.magnitude())), float(np.degrees(swing.magnitude()))
