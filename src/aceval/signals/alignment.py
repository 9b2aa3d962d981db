"""Kong Sec. 2.3: two recordings aligned in time by the cross-correlation of their acceleration
magnitudes (which need no calibration).
"""

from __future__ import annotations

import numpy as np


def best_lag(a: np.ndarray, b: np.ndarray, max_lag: int) -> int:
    """Kong Sec. 2.3: "the data from the two sets were aligned by removing the offset estimated
    from the cross correlation of the acceleration". The lag L (samples, |L| <= ``max_lag``) that
    maximises the cross-correlation ``sum_t x[t + L] y[t]`` of the two recordings' acceleration
    magnitudes (demeaned; the magnitude needs no calibration), such that ``a[t + L]`` matches
    ``b[t]``. Only the lags in the window are computed; the first of equal maxima wins.
    """
    x = np.linalg.norm(np.asarray(a, float), axis=1)
    y = np.linalg.norm(np.asarray(b, float), axis=1)
    x, y = x - x.mean(), y - y.mean()
    lags = np.arange(max(-max_lag, 1 - len(y)), min(max_lag, len(x) - 1) + 1)
    if not len(lags):
        return 0
    cross = [
        float(np.dot(x[max(0, lag) : len(y) + lag], y[max(0, -lag) : len(x) - lag])) for lag in lags
    ]
    return int(lags[int(np.argmax(cross))])


def aligned(n_a: int, n_b: int, lag: int) -> tuple[slice, slice]:
    """The overlapping samples of two recordings when ``a[t + lag]`` matches ``b[t]``."""
    start_b = max(0, -lag)
    stop_b = min(n_b, n_a - lag)
    return slice(start_b + lag, stop_b + lag), slice(start_b, max(start_b, stop_b))
