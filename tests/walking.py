"""Analytic walking of a foot and a trunk, seen by a sensor of known mounting: the two physical
cues of the right axis's sign (aceval.signals.gait_sign) with their size and order set by hand."""

import numpy as np
from scipy.spatial.transform import Rotation

FS = 100.0
GRAVITY_UP = np.array([0.0, 0.0, -9.81])  # specific force at rest, body frame (z down)


def _hann(tau: np.ndarray, start: float, end: float) -> np.ndarray:
    inside = (tau >= start) & (tau <= end)
    return np.where(inside, np.sin(np.pi * (tau - start) / (end - start)) ** 2, 0.0)


def foot_pitch(strides=8, down_deg=60.0, up_deg=20.0, rest_s=0.35, swing_s=0.75, reverse=False):
    """(N,) a foot's pitch about body y (deg, + toe-up): per stride foot flat for ``rest_s``, then
    toe-down to ``-down_deg`` (push-off) and toe-up to ``+up_deg`` (heel strike) within
    ``swing_s``, back to flat; ``reverse``: played backwards (walking backwards)."""
    rest = np.zeros(int(rest_s * FS))
    tau = np.linspace(0.0, 1.0, int(swing_s * FS))
    swing = -down_deg * _hann(tau, 0.0, 0.55) + up_deg * _hann(tau, 0.45, 1.0)
    angle = np.concatenate([rest] + [np.concatenate([swing, rest]) for _ in range(strides)])
    return angle[::-1] if reverse else angle


def foot_walk(mount: np.ndarray, seed=0, **pitch_options) -> tuple[np.ndarray, np.ndarray]:
    """(acc, gyr) of a foot walking with :func:`foot_pitch`, seen by a sensor mounted with
    ``mount`` (sensor -> body); SI."""
    rng = np.random.default_rng(seed)
    pitch = np.radians(foot_pitch(**pitch_options))
    rate = np.gradient(pitch) * FS
    body = Rotation.from_rotvec(np.outer(pitch, [0.0, 1.0, 0.0]))
    acc = body.inv().apply(GRAVITY_UP) + rng.normal(0, 0.3, (len(pitch), 3))
    gyr = np.column_stack([0 * rate, rate, 0 * rate]) + rng.normal(0, 0.02, (len(pitch), 3))
    return acc @ mount, gyr @ mount  # row vectors: v_sensor = mount^T v_body


def trunk_walk(mount: np.ndarray, seconds=10.0, running=False, seed=0):
    """(acc, gyr) of a trunk walking as an inverted pendulum (fastest at its lowest point, +-2.5
    cm at 1.8 steps/s) or, ``running``, as a bouncing mass (fastest at its highest), swaying
    +-2 deg about y, seen by a sensor mounted with ``mount`` (sensor -> body); SI."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    w = 2 * np.pi * 1.8
    down = 0.025 * np.cos(w * t)  # body z points down: the lowest point at t = 0
    surge = (-1.0 if running else 1.0) * 0.15 * np.cos(w * t)  # forward speed's fluctuation
    acc_body = np.column_stack([np.gradient(surge) * FS, 0 * t, np.gradient(np.gradient(down))])
    acc_body[:, 2] *= FS**2
    sway = np.radians(2.0) * np.sin(w * t + 0.4)
    tilt = Rotation.from_rotvec(np.outer(sway, [0.0, 1.0, 0.0]))
    acc = tilt.inv().apply(acc_body + GRAVITY_UP) + rng.normal(0, 0.1, (len(t), 3))
    gyr = np.column_stack([0 * t, np.gradient(sway) * FS, 0 * t]) + rng.normal(0, 0.02, (len(t), 3))
    return acc @ mount, gyr @ mount
