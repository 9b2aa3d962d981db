"""Movement trimming (Kong et al. 2016, Section 2.4.1 and Fig. 5).

Two indicators are computed from the angular velocity ``gyr`` (rad/s, shape (N, 3)):

* the squared modulus ``|w|^2`` normalised by its maximum over the recording;
* the moving standard deviation of ``|w|`` over a centred window, normalised by its maximum.

A sample is *movement* when either indicator exceeds ``threshold`` (0.1 in the paper). The binary
mask is then closed morphologically (:func:`close_gaps`, as ``scipy.ndimage.binary_closing``)
with a structuring element of ``closing_s`` seconds (1 s in the paper), which fills short pauses
inside a movement (e.g. the turning point of a bow). The paper does not give the moving-SD
window; ``window_s`` defaults to 0.5 s, about half a movement cycle of the slowest tests.

Because both indicators are normalised to their own maximum, a recording without movement would
still produce a "movement" made of noise. ``min_peak_rad_s`` guards against that: when the peak
angular velocity modulus is below it (default 0.35 rad/s = 20 deg/s, well above gyroscope noise and
postural sway, well below any of Kong's or Ricci's movements), NoMovementError is raised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from aceval.data.errors import NoMovementError, check_samples


@dataclass(frozen=True)
class TrimParams:
    """Parameters of the movement trimmer; the defaults are the paper's (Fig. 5)."""

    threshold: float = 0.1
    closing_s: float = 1.0
    window_s: float = 0.5
    min_peak_rad_s: float = 0.35


def _moving_std(signal: np.ndarray, window: int) -> np.ndarray:
    """Centred moving standard deviation (window in samples, edges use the nearest value)."""
    mean = ndimage.uniform_filter1d(signal, window, mode="nearest")
    mean_sq = ndimage.uniform_filter1d(signal**2, window, mode="nearest")
    return np.sqrt(np.clip(mean_sq - mean**2, 0.0, None))


def movement_mask(gyr, fs_hz: float, params: TrimParams = TrimParams()) -> np.ndarray:
    """Boolean (N,) mask of the samples kept as movement (Kong Fig. 5)."""
    gyr = check_samples(gyr, name="angular velocity", min_samples=2)
    speed = np.linalg.norm(gyr, axis=1)
    peak = float(speed.max())
    if peak < params.min_peak_rad_s:
        raise NoMovementError(
            f"no movement: peak angular velocity {peak:.3f} rad/s is below "
            f"min_peak_rad_s={params.min_peak_rad_s} rad/s"
        )
    window = max(1, int(round(params.window_s * fs_hz)))
    moving_sd = _moving_std(speed, window)
    squared = speed**2 / peak**2
    sd_norm = moving_sd / moving_sd.max() if moving_sd.max() > 0 else moving_sd
    mask = (squared > params.threshold) | (sd_norm > params.threshold)
    length = max(1, int(round(params.closing_s * fs_hz)))
    return close_gaps(mask, length)


def close_gaps(mask: np.ndarray, length: int) -> np.ndarray:
    """The morphological closing of a 1-D mask by ``length`` samples, the mask padded with rest
    first (so that movement touching either end is not eroded): every run of False shorter than
    ``length`` between two True runs becomes True. The same mask as
    ``scipy.ndimage.binary_closing`` of the padded mask with ``np.ones(length)`` (tested), found
    from the runs instead of two passes of the structuring element.
    """
    mask = np.asarray(mask, dtype=bool)
    edges = np.diff(np.concatenate([[0], (~mask).astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    fill = (starts > 0) & (stops < len(mask)) & (stops - starts < length)
    marks = np.zeros(len(mask) + 1, dtype=np.int64)
    marks[starts[fill]] += 1
    marks[stops[fill]] -= 1
    return mask | (np.cumsum(marks[:-1]) > 0)


def mask_to_ranges(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open sample ranges ``[(start, stop), ...]`` of the True runs of a boolean mask."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops)]


def movement_ranges(gyr, fs_hz: float, params: TrimParams = TrimParams()) -> list[tuple[int, int]]:
    """Kept sample ranges (half-open) of a repetition: the movement windows of Kong Fig. 5."""
    return mask_to_ranges(movement_mask(gyr, fs_hz, params))
