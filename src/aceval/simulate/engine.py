"""Physics of a body-worn IMU: from a sensor's pose over time to what it measures.

The simulator describes every sensor by its orientation ``R_ws`` (sensor -> world, (M, 3, 3)) and
position ``p_w`` (m, (M, 3)) on a fine time grid (``OVERSAMPLE`` x the output rate). World frame:
x forward, y right, z down (gravity +z). From the pose:

* angular velocity in the sensor frame: ``w = vee(R^T dR/dt)``, central differences;
* specific force in the sensor frame: ``f = R^T (d2p/dt2 - g)``, central differences, which holds
  gravity, tangential and centripetal terms at the lever arm, and points up (-z) at rest;

then decimated to the output rate. The datasheet error model adds white noise, a constant bias per
recording and saturation at the range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.data.contract import GRAVITY

#: fine grid = OVERSAMPLE x the output rate; with the 5-point (4th-order) central differences
#: below, 4x differs from a 20x grid by < 1 mg and < 0.05 deg/s (docs/simulation.md)
OVERSAMPLE = 4
PAD = 2  # extra fine samples at each end for the 5-point stencil


def fine_time(duration_s: float, fs_hz: float) -> np.ndarray:
    """Fine time grid (s) covering ``duration_s`` with ``PAD`` extra points at each end."""
    n_out = int(round(duration_s * fs_hz))
    dt = 1.0 / (fs_hz * OVERSAMPLE)
    return (np.arange(n_out * OVERSAMPLE + 2 * PAD) - PAD) * dt


def each_times(R: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """``R @ factor`` for a stack ``R`` (..., 3, 3) and one (3, 3) matrix or (3,) vector, as one
    two-dimensional product: NumPy multiplies a stack matrix by matrix, 30 times slower on 5,000
    samples. Every element is the same three-term dot product: the values are the same to the
    bit (the committed simulated datasets are: ``diff -r``).
    """
    factor = np.asarray(factor, dtype=float)
    flat = np.ascontiguousarray(R).reshape(-1, 3) @ factor
    return flat.reshape(R.shape if factor.ndim == 2 else R.shape[:-1])


def measure(R_ws: np.ndarray, p_w: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Ideal gyroscope (rad/s) and accelerometer (m/s^2) of a sensor pose on the fine grid.

    Returns arrays of shape (n_out, 3) at ``fs_hz`` (every OVERSAMPLE-th interior sample).
    """
    dt = 1.0 / (fs_hz * OVERSAMPLE)
    idx = np.arange(PAD, len(p_w) - PAD, OVERSAMPLE)
    R = R_ws[idx]
    # 5-point central differences (error O(dt^4))
    dR = (R_ws[idx - 2] - 8 * R_ws[idx - 1] + 8 * R_ws[idx + 1] - R_ws[idx + 2]) / (12 * dt)
    omega_skew = np.swapaxes(R, 1, 2) @ dR
    gyr = 0.5 * np.stack(
        [
            omega_skew[:, 2, 1] - omega_skew[:, 1, 2],
            omega_skew[:, 0, 2] - omega_skew[:, 2, 0],
            omega_skew[:, 1, 0] - omega_skew[:, 0, 1],
        ],
        axis=1,
    )
    acc_w = (
        -p_w[idx - 2] + 16 * p_w[idx - 1] - 30 * p_w[idx] + 16 * p_w[idx + 1] - p_w[idx + 2]
    ) / (12 * dt**2)
    specific_force_w = acc_w - np.array([0.0, 0.0, GRAVITY])
    acc = np.einsum("nji,nj->ni", R, specific_force_w)
    return gyr, acc


@dataclass(frozen=True)
class ImuErrorModel:
    """Sensor errors of a MEMS IMU class, from the InvenSense MPU-9250 datasheet (rev. 1.1):

    * accelerometer noise density 300 ug/sqrt(Hz); gyroscope 0.01 deg/s/sqrt(Hz); both integrated
      over the bandwidth ``fs/2`` to a white-noise SD per sample;
    * zero-g offset +-60 mg and zero-rate offset +-5 deg/s (datasheet tolerances), taken as 3 SD of
      a constant bias drawn per sensor and recording;
    * saturation at the configured range (Kong: +-4 g upper body, +-8 g lower body, +-400 deg/s).
    """

    acc_noise_density_ug: float = 300.0
    gyr_noise_density_dps: float = 0.01
    acc_bias_max_mg: float = 60.0
    gyr_bias_max_dps: float = 5.0
    gyr_range_dps: float = 400.0

    def apply(
        self,
        rng,
        gyr,
        acc,
        fs_hz: float,
        acc_range_g: float,
        enabled: bool = True,
        bias_scale: float = 1.0,
    ):
        """Noisy, biased and saturated copies of ideal (gyr rad/s, acc m/s^2) samples; the
        biases scaled by ``bias_scale`` (the same draws: a halved bias is the same sensor's).
        """
        if not enabled:
            return gyr.copy(), acc.copy()
        bandwidth = fs_hz / 2
        acc_sd = self.acc_noise_density_ug * 1e-6 * GRAVITY * np.sqrt(bandwidth)
        gyr_sd = np.radians(self.gyr_noise_density_dps) * np.sqrt(bandwidth)
        acc_bias = bias_scale * rng.normal(0, self.acc_bias_max_mg * 1e-3 * GRAVITY / 3, 3)
        gyr_bias = bias_scale * rng.normal(0, np.radians(self.gyr_bias_max_dps) / 3, 3)
        acc_out = acc + acc_bias + rng.normal(0, acc_sd, acc.shape)
        gyr_out = gyr + gyr_bias + rng.normal(0, gyr_sd, gyr.shape)
        acc_limit = acc_range_g * GRAVITY
        gyr_limit = np.radians(self.gyr_range_dps)
        return np.clip(gyr_out, -gyr_limit, gyr_limit), np.clip(acc_out, -acc_limit, acc_limit)


def band_noise(
    rng, t: np.ndarray, f_low: float, f_high: float, n_components: int = 12
) -> np.ndarray:
    """Smooth random signal with unit RMS and energy between ``f_low`` and ``f_high`` Hz: a sum of
    sinusoids at random frequencies and phases (differentiable, so the physics stays exact).
    """
    freqs = rng.uniform(f_low, f_high, n_components)
    phases = rng.uniform(0, 2 * np.pi, n_components)
    omega = 2 * np.pi * freqs
    steps = np.diff(t)
    # np.allclose(steps, steps[0]) without its temporaries (the same test: atol 1e-8, rtol 1e-5)
    if len(t) < 64 or np.max(np.abs(steps - steps[0])) > 1e-8 + 1e-5 * abs(steps[0]):
        signal = np.sin(omega * t[:, None] + phases).sum(axis=1)
    else:
        # uniform grid t0 + (q B + r) dt: sin(a + b) = sin a cos b + cos a sin b turns the sum over
        # components into two small matrix products (sin/cos on ~2 sqrt(n) points, not n)
        block = int(np.sqrt(len(t))) + 1
        coarse = t[0] + np.arange(-(-len(t) // block))[:, None] * block * steps[0]
        fine = np.arange(block)[:, None] * steps[0]
        a, b = omega * coarse + phases, omega * fine
        signal = (np.sin(a) @ np.cos(b).T + np.cos(a) @ np.sin(b).T).ravel()[: len(t)]
    return signal * np.sqrt(2.0 / n_components)


def euler_pitch_roll_yaw(pitch, roll=0.0, yaw=0.0) -> np.ndarray:
    """Segment -> world rotation matrices from angles (rad): yaw about z, then roll about x, then
    pitch about y (intrinsic Z-X-Y: ``R = Rz(yaw) Rx(roll) Ry(pitch)``). Positive pitch tilts the
    segment's +x up and its +z forward. Written out (SciPy's ``from_euler('ZXY')`` gives the same
    matrices to 1e-15, ten times slower on long arrays; tests/test_simulate.py compares them).
    """
    pitch = np.atleast_1d(np.asarray(pitch, dtype=float))
    shape = pitch.shape
    roll = np.broadcast_to(np.asarray(roll, dtype=float), shape)
    yaw = np.broadcast_to(np.asarray(yaw, dtype=float), shape)
    cz, sz, cx, sx = np.cos(yaw), np.sin(yaw), np.cos(roll), np.sin(roll)
    cy, sy = np.cos(pitch), np.sin(pitch)
    R = np.empty(shape + (3, 3))
    R[..., 0, 0] = cz * cy - sz * sx * sy
    R[..., 0, 1] = -sz * cx
    R[..., 0, 2] = cz * sy + sz * sx * cy
    R[..., 1, 0] = sz * cy + cz * sx * sy
    R[..., 1, 1] = cz * cx
    R[..., 1, 2] = sz * sy - cz * sx * cy
    R[..., 2, 0] = -cx * sy
    R[..., 2, 1] = sx
    R[..., 2, 2] = cx * cy
    return R


def small_rotations(rotvecs: np.ndarray) -> np.ndarray:
    """Rotation matrices of rotation vectors (rad), shape (M, 3) -> (M, 3, 3)."""
    return Rotation.from_rotvec(rotvecs).as_matrix()
