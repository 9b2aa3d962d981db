"""Is a declared sampling rate the recording's? The gyroscope against the accelerometer.

A sampling rate given by hand (``--rate`` for exports without a rate line) is otherwise never
checked, and a wrong one moves calibrations silently (the trimmer's windows and every
integrated angle scale with it). The data can tell: the gyroscope reports angular velocity in
rad/s, a physical unit, while the angle it integrates to depends on the time step ``1 / rate``.

The check: over whole strides of walking (or any whole cycles of a periodic movement) the body
returns to its speed, so the mean of the specific force in a world frame is gravity alone. For
a trial time step ``s / rate``, each sensor's specific force is turned into the frame of the
window's first sample by its gyroscope integrated with that step (the gyroscope's offset at rest
removed), and averaged over the window; the magnitude of that mean equals the sensor's own
magnitude at rest only at the right step. Too small a step leaves the segment's swing in the
mean (the centripetal and impact accelerations add up in the sensor's frame), too large a step
smears gravity: the magnitude falls with ``s``, and its root is the rate the data imply
(``rate / s``). Windows are four periods of the movement long (the period from the
autocorrelation of the angular velocities, in samples, so the windows hold whole strides whatever
rate is declared); a sensor whose magnitude hardly changes with the step (a trunk sensor in
walking, quiet standing) gives no evidence, nor does a trial without a periodic movement.

Measured on recordings whose rate is known and on wrong declared rates: config/README.md, the
table of checks (``benchmarks/rate_check.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aceval.data.contract import GRAVITY

#: periods per window: the window starts and ends at one phase of the gait, at one speed (an even
#: number: where the period found is a step, the window still holds whole strides)
PERIODS_PER_WINDOW = 4
#: steps tried: from a 64th to 64 times the declared one (a gyroscope in deg/s read as rad/s is
#: a factor 57), by factors of 2, then halved around the root
COARSE_STEPS = 2.0 ** np.arange(-6, 7)
BISECTIONS = 7
#: a window whose mean angular speed is lower than this (rad/s) holds no movement to judge by
MIN_WINDOW_SPEED = 0.5
#: a sensor gives evidence where its window mean falls by at least this much (m/s^2) per
#: e-fold of the step at the root (a trunk sensor in walking: far less; a shank: about 1)
MIN_SLOPE = 0.3
#: the period search: the autocorrelation's peaks at lags from this (samples) ...
MIN_PERIOD_SAMPLES = 8
#: ... that correlates at least this much
MIN_PERIODICITY = 0.3


@dataclass(frozen=True)
class RateEvidence:
    """What one trial's sensors say about its rate: ``implied_hz`` the rate at which the
    gyroscope and the accelerometer agree (NaN: no sensor gives evidence), ``n_sensors`` how many
    sensors gave evidence, ``stride_hz`` the frequency of the movement's period (a stride, or a
    step) at the declared rate (NaN without a periodic movement) and ``weight`` the evidence's
    weight (the slopes' sum).
    """

    implied_hz: float
    n_sensors: int
    stride_hz: float
    weight: float


def stride_period(gyrs: list[np.ndarray]) -> int | None:
    """The stride period in samples: the autocorrelation of the sensors' angular velocities
    (every axis, each less its mean: a leg's oscillates once per stride, and quiet phases add
    nothing), at its peaks beyond its main lobe (its first fall below zero) and within a third of
    the trial, the first at least 80 % as high as the highest (not a multiple of the period);
    None when none reaches :data:`MIN_PERIODICITY` (no periodic movement).
    """
    signal = np.hstack([g - g.mean(axis=0) for g in gyrs])
    n = len(signal)
    if n < 3 * MIN_PERIOD_SAMPLES:
        return None
    spectrum = np.fft.rfft(signal, 2 * n, axis=0)
    auto = np.fft.irfft(np.abs(spectrum) ** 2, axis=0)[:n].sum(axis=1)
    auto = auto / (auto[0] or 1.0) * n / (n - np.arange(n))  # unbiased
    below = np.flatnonzero(auto[: n // 3] < 0)
    if len(below) == 0:
        return None
    lags = np.arange(max(below[0], MIN_PERIOD_SAMPLES), n // 3)
    if len(lags) < 3:
        return None
    inner = auto[lags[1:-1]]
    peaks = lags[1:-1][(inner > auto[lags[:-2]]) & (inner >= auto[lags[2:]])]
    if len(peaks) == 0 or auto[peaks].max() < MIN_PERIODICITY:
        return None
    return int(peaks[np.flatnonzero(auto[peaks] >= 0.8 * auto[peaks].max())[0]])


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton products of quaternions (..., 4), scalar first."""
    w1, x1, y1, z1 = np.moveaxis(p, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def _turned_means(acc: np.ndarray, gyr: np.ndarray, step: float) -> np.ndarray:
    """(W,) the magnitude of each window's mean specific force turned into the frame of its
    first sample, the rotation integrated with time step ``step`` (s); ``acc``, ``gyr``: (W, L, 3).
    """
    angle = gyr * step
    norm = np.linalg.norm(angle, axis=-1, keepdims=True)
    half = np.sin(norm / 2) / np.where(norm > 0, norm, 1.0)
    q = np.concatenate([np.cos(norm / 2), angle * np.where(norm > 0, half, 0.5)], axis=-1)
    shift = 1
    while shift < q.shape[1]:  # prefix products: q[t] = q0 q1 ... qt (body-frame increments)
        q[:, shift:] = _qmul(q[:, :-shift], q[:, shift:])
        shift *= 2
    w, u = q[..., :1], q[..., 1:]
    t = 2 * np.cross(u, acc)
    turned = acc + w * t + np.cross(u, t)
    return np.linalg.norm(turned.mean(axis=1), axis=-1)


def _windows(acc, gyr, period: int):
    """(acc, gyr) as (W, L, 3) windows of :data:`PERIODS_PER_WINDOW` periods that move."""
    length = PERIODS_PER_WINDOW * period
    count = len(acc) // length
    acc_w = acc[: count * length].reshape(count, length, 3)
    gyr_w = gyr[: count * length].reshape(count, length, 3)
    moving = np.linalg.norm(gyr_w, axis=-1).mean(axis=1) > MIN_WINDOW_SPEED
    return acc_w[moving], gyr_w[moving]


def _at_rest(acc: np.ndarray, gyr: np.ndarray, fs_hz: float) -> tuple[np.ndarray, float]:
    """The gyroscope's offset (rad/s) and the specific force's magnitude (m/s^2) at rest: medians
    over the samples whose angular speed stays below 0.1 rad/s for half a second (zero and
    :data:`GRAVITY` without such samples).
    """
    from scipy.ndimage import minimum_filter1d

    slow = np.linalg.norm(gyr, axis=1) < 0.1
    still = minimum_filter1d(slow.astype(np.int8), max(1, int(fs_hz / 2))) > 0
    if still.sum() < fs_hz:
        return np.zeros(3), GRAVITY
    return np.median(gyr[still], axis=0), float(np.median(np.linalg.norm(acc[still], axis=1)))


def sensor_step(acc, gyr, fs_hz: float, period: int) -> tuple[float, float]:
    """``(s, slope)`` of one sensor: the factor ``s`` of the declared time step at which its
    windows' turned mean equals its magnitude at rest (median over windows; NaN where no root or
    the slope at it is below :data:`MIN_SLOPE`) and that slope (m/s^2 per e-fold of ``s``).
    """
    offset, rest = _at_rest(acc, gyr, fs_hz)
    acc_w, gyr_w = _windows(acc, gyr - offset, period)
    if len(acc_w) == 0:
        return np.nan, 0.0

    def excess(s: float) -> float:
        return float(np.median(_turned_means(acc_w, gyr_w, s / fs_hz))) - rest

    values = np.array([excess(s) for s in COARSE_STEPS])
    falls = np.flatnonzero((values[:-1] > 0) & (values[1:] <= 0))
    if len(falls) == 0:
        return np.nan, 0.0
    k = falls[np.argmax(values[falls] - values[falls + 1])]
    low, high, v_low, v_high = COARSE_STEPS[k], COARSE_STEPS[k + 1], values[k], values[k + 1]
    for _ in range(BISECTIONS):
        middle = np.sqrt(low * high)
        v = excess(middle)
        low, high, v_low, v_high = (middle, high, v, v_high) if v > 0 else (low, middle, v_low, v)
    slope = (v_low - v_high) / np.log(high / low)
    root = np.exp(np.log(low) + v_low / (v_low - v_high) * np.log(high / low))
    return (float(root), float(slope)) if slope >= MIN_SLOPE else (np.nan, float(slope))


def implied_rate(signals: list[tuple[np.ndarray, np.ndarray]], fs_hz: float) -> RateEvidence:
    """The rate one trial's sensors imply (module docstring): ``signals`` their ``(acc, gyr)``
    (SI, (N, 3), one synchronised recording) read at the declared ``fs_hz``; the weighted median
    of the sensors' steps, each weighted by its slope.
    """
    moving = moving_span([gyr for _, gyr in signals])
    signals = [(acc[moving], gyr[moving]) for acc, gyr in signals]
    if moving.stop - moving.start < 3 * MIN_PERIOD_SAMPLES:
        return RateEvidence(np.nan, 0, np.nan, 0.0)
    period = stride_period([gyr for _, gyr in signals])
    if period is None:
        return RateEvidence(np.nan, 0, np.nan, 0.0)
    found = [sensor_step(acc, gyr, fs_hz, period) for acc, gyr in signals]
    found = [(s, w) for s, w in found if np.isfinite(s)]
    stride_hz = fs_hz / period
    if not found:
        return RateEvidence(np.nan, 0, stride_hz, 0.0)
    steps, weights = np.array(found).T
    return RateEvidence(
        float(fs_hz / weighted_median(steps, weights)), len(found), stride_hz, float(weights.sum())
    )


def moving_span(gyrs: list[np.ndarray]) -> slice:
    """From the first to the last sample at which some sensor turns faster than
    :data:`MIN_WINDOW_SPEED` (the trial's quiet standing before and after left out).
    """
    fast = np.flatnonzero(np.any([np.linalg.norm(g, axis=1) > MIN_WINDOW_SPEED for g in gyrs], 0))
    return slice(int(fast[0]), int(fast[-1]) + 1) if len(fast) else slice(0, 0)


def weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    """The weighted median (geometric: of the logarithms) of positive ``values``."""
    order = np.argsort(values)
    cumulative = np.cumsum(np.asarray(weights, float)[order])
    return float(np.asarray(values)[order][np.searchsorted(cumulative, cumulative[-1] / 2)])


def combined_rate(evidence: list[RateEvidence]) -> float:
    """The rate several trials imply together: the weighted median over the trials with
    evidence (NaN without any).
    """
    found = [e for e in evidence if np.isfinite(e.implied_hz)]
    if not found:
        return np.nan
    return weighted_median(
        np.array([e.implied_hz for e in found]), np.array([e.weight for e in found])
    )
