"""Synthetic, exactly known signals shared by the tests."""

import numpy as np
from scipy.spatial.transform import Rotation

G = 9.81


def pitch_motion(n: int = 400, amplitude_deg: float = 40.0, seed: int = 0) -> np.ndarray:
    """Body-frame specific force (N, 3) of a segment pitching about y (sagittal plane), with a
    tangential acceleration along x: all samples lie in the body x-z plane (exact, noise-free)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4 * np.pi, n)
    theta = np.radians(amplitude_deg) * np.sin(t) + rng.normal(0, 0.01, n)
    rest = np.array([0.0, 0.0, -G])  # specific force points up (z is down)
    pitched = Rotation.from_euler("y", theta[:, None]).inv().apply(rest)
    pitched[:, 0] += 2.0 * np.cos(t)  # tangential acceleration in the sagittal plane
    return pitched


def right_axis_of(R: np.ndarray) -> str:
    """The signed sensor axis closest to the body's right (y0 in the sensor frame = R[1])."""
    y0 = R[1]
    k = int(np.argmax(np.abs(y0)))
    return ("+" if y0[k] > 0 else "-") + "xyz"[k]
