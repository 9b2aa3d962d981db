"""The step-harmonic heading of a trunk or pelvis sensor in walking (beyond the papers).

While walking, the trunk's forward speed rises and falls once per step (the inverted pendulum:
fastest in double support, slowest at midstance), so its anterior-posterior acceleration is
strongest at the step frequency; its medial-lateral sway repeats once per stride, at half of it
(Zijlstra & Hof 2003, Gait Posture 18:1-10). The anterior-posterior axis is then the horizontal
direction (orthogonal to z0 from quiet standing) of largest acceleration power in a band around
the step frequency, found as the dominant frequency of the acceleration magnitude.

Per recording, :func:`step_scatter` reduces the trimmed samples to the 3x3 scatter of the
band-passed acceleration (so subsets of repetitions add, as Kong's scatters do);
:func:`step_harmonic_rotation` turns a summed scatter and z0 into R. Conditioning: the ratio of
the two horizontal eigenvalues (middle / largest); near 1 no horizontal direction dominates and
the heading is undetermined (flag ``no_step_heading`` above :data:`MAX_STEP_RATIO`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from aceval.methods.interface import Fit, Method
from aceval.methods.statistics import Pooled

#: walking step frequencies searched (Hz): 36-210 steps/min, beyond slow and fast walking
STEP_BAND_HZ = (0.6, 3.5)
#: the band-pass around the step frequency f: [0.75 f, 1.25 f] keeps the stride frequency (f/2)
#: and the second harmonic (2 f) out
PASS_BAND = (0.75, 1.25)
#: above this middle/largest horizontal eigenvalue ratio the heading is undetermined (the same
#: 0.5 as Kong's smallest/middle eigenvalue ratio)
MAX_STEP_RATIO = 0.5
SCATTER_COLUMNS = [f"h{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]


def step_frequency(acc: np.ndarray, fs_hz: float) -> float:
    """Dominant frequency (Hz) of the acceleration magnitude within :data:`STEP_BAND_HZ` (Hann
    window, zero-padded to at least 8x the samples for a fine grid); NaN when too short.
    """
    magnitude = np.linalg.norm(acc, axis=1)
    if len(magnitude) < 2 * fs_hz / STEP_BAND_HZ[0]:  # fewer than two cycles of the slowest step
        return float("nan")
    magnitude = (magnitude - magnitude.mean()) * np.hanning(len(magnitude))
    n_fft = 1 << int(np.ceil(np.log2(8 * len(magnitude))))
    power = np.abs(np.fft.rfft(magnitude, n_fft)) ** 2
    frequency = np.fft.rfftfreq(n_fft, 1.0 / fs_hz)
    band = (frequency >= STEP_BAND_HZ[0]) & (frequency <= STEP_BAND_HZ[1])
    return float(frequency[band][np.argmax(power[band])])


def step_scatter(acc: np.ndarray, fs_hz: float, mask: np.ndarray) -> tuple[np.ndarray, float]:
    """``(H, step_hz)``: the scatter ``sum b b^T`` (3x3, m^2/s^4) of the acceleration band-passed
    around the step frequency (2nd-order Butterworth, zero phase), over the samples of ``mask``
    (the trimmer's moving samples); the frequency from the moving span only. NaN when no step
    frequency is found or the band reaches the Nyquist frequency.
    """
    nan = (np.full((3, 3), np.nan), float("nan"))
    moving = np.flatnonzero(mask)
    if len(moving) == 0:
        return nan
    span = acc[moving[0] : moving[-1] + 1]
    step_hz = step_frequency(span, fs_hz)
    low, high = PASS_BAND[0] * step_hz, PASS_BAND[1] * step_hz
    if not np.isfinite(step_hz) or high >= 0.5 * fs_hz:
        return nan
    from scipy import signal  # here, not above: its import costs every job about 1 s (SciPy 1.17)

    sos = signal.butter(2, [low, high], btype="bandpass", fs=fs_hz, output="sos")
    if len(acc) <= 3 * 2 * len(sos):  # sosfiltfilt's padding needs a few samples
        return nan
    band = signal.sosfiltfilt(sos, acc, axis=0)[mask]
    return band.T @ band, step_hz


def step_harmonic_rotation(H, z0, right) -> tuple[np.ndarray, np.ndarray]:
    """``(R, ratio)`` of each scatter in ``H`` (..., 3, 3) and z0 (3,) or (..., 3): R (..., 3, 3,
    sensor -> body) with z = z0 exactly, x the horizontal principal axis of the band-passed
    scatter (the anterior-posterior direction), its sign chosen so that y = z x x points along
    ``right``; ``ratio`` = middle / largest eigenvalue of the scatter projected on the horizontal
    plane (0: one direction, 1: none). NaN where a scatter is not finite or has no horizontal
    power.
    """
    H, z0 = np.asarray(H, float), np.asarray(z0, float)
    P = np.eye(3) - z0[..., :, None] * z0[..., None, :]
    finite = np.isfinite(H).all(axis=(-2, -1))
    projected = P @ np.where(finite[..., None, None], H, 0.0) @ P
    eigenvalues, vectors = np.linalg.eigh(projected)  # ascending; the smallest is along z0
    x = vectors[..., :, 2]
    x = x - np.sum(x * z0, axis=-1, keepdims=True) * z0
    with np.errstate(invalid="ignore", divide="ignore"):
        x = x / np.linalg.norm(x, axis=-1, keepdims=True)
        ratio = eigenvalues[..., 1] / eigenvalues[..., 2]
    y = np.cross(z0, x)
    sign = np.where(np.sum(y * np.asarray(right, float), axis=-1, keepdims=True) < 0, -1.0, 1.0)
    R = np.stack([x * sign, y * sign, np.broadcast_to(z0, x.shape)], axis=-2)
    valid = finite & (eigenvalues[..., 2] > 0)
    return np.where(valid[..., None, None], R, np.nan), np.where(valid, ratio, np.nan)


# --- the method's interface in Kong's protocol (aceval.methods.interface) -----------------------

#: why a walking test has no step-harmonic calibration
TOO_SHORT = (
    "needs walking recordings of at least two cycles of the slowest step (3.3 s) to find the "
    "step frequency; this dataset's repetitions are shorter"
)


def applies(pooled: Pooled) -> np.ndarray:
    """Walking rows: those with a step-band scatter, and (flagged ``not_applicable``) the
    calibration from all repetitions of a walking test whose repetitions are too short.
    """
    return pooled.walking | ((pooled.first_phase == "gait") & pooled.all_repetitions)


def fit(pooled: Pooled, fitted: Mapping[str, Fit] | None = None) -> Fit:
    """The step-harmonic calibration of each row from its summed step-band scatter, flagged
    ``no_step_heading`` when no horizontal direction dominates (:data:`MAX_STEP_RATIO`) and
    ``not_applicable`` (with a ``note``) when the unit's repetitions are too short.
    """
    R, ratio = step_harmonic_rotation(pooled.steps, pooled.z0, pooled.right)
    flag = np.where(ratio <= MAX_STEP_RATIO, "", "no_step_heading").astype(object)
    flag[~pooled.walking] = "not_applicable"
    note = np.where(pooled.walking, None, TOO_SHORT).astype(object)
    step_hz = np.where(pooled.walking, pooled.step_hz, np.nan)
    return Fit(R, flag, {"step_ratio": ratio, "step_hz": step_hz, "note": note})


def resample(pooled: Pooled, fitted: Mapping[str, Fit] | None = None) -> Fit:
    """The step-harmonic calibration of bootstrap resamples, NaN where flagged."""
    R, ratio = step_harmonic_rotation(pooled.steps, pooled.z0, pooled.right)
    ok = ratio <= MAX_STEP_RATIO
    return Fit(np.where(ok[:, None, None], R, np.nan), np.where(ok, "", "no_step_heading"))


METHOD = Method(
    name="step_harmonic",
    fit=fit,
    resample=resample,
    applies=applies,
    summary="walking: body x from the horizontal acceleration at the step frequency (beyond the "
    "papers)",
)
