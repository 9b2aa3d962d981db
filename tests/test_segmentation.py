import numpy as np
import pytest

from aceval.data.errors import NoMovementError, NonFiniteError
from aceval.signals.segmentation import TrimParams, movement_mask, movement_ranges

FS = 100.0


def rest_move_signal(rng, periods):
    """Gyroscope (N, 3) rad/s from (kind, seconds) periods; movement = 1 Hz oscillation."""
    parts, truth, start = [], [], 0
    for kind, seconds in periods:
        n = int(seconds * FS)
        t = np.arange(n) / FS
        if kind == "move":
            speed = 2.0 * np.sin(2 * np.pi * 1.0 * t)
            parts.append(np.column_stack([0.1 * speed, speed, 0.05 * speed]))
            truth.append((start, start + n))
        else:
            parts.append(np.zeros((n, 3)))
        start += n
    gyr = np.concatenate(parts) + rng.normal(0, 0.01, (start, 3))  # ~0.6 deg/s noise
    return gyr, truth


def test_trimming_finds_known_movement_windows(rng):
    gyr, truth = rest_move_signal(
        rng, [("rest", 2), ("move", 3), ("rest", 2), ("move", 3), ("rest", 2)]
    )
    ranges = movement_ranges(gyr, FS)
    assert len(ranges) == len(truth)
    tolerance = int(0.3 * FS)  # half the moving-SD window plus the onset of the sine
    for (start, stop), (true_start, true_stop) in zip(ranges, truth):
        assert abs(start - true_start) <= tolerance
        assert abs(stop - true_stop) <= tolerance


def test_closing_fills_short_pause_but_not_long_rest(rng):
    gyr, _ = rest_move_signal(
        rng, [("rest", 1), ("move", 2), ("rest", 0.5), ("move", 2), ("rest", 1)]
    )
    assert len(movement_ranges(gyr, FS)) == 1  # a 0.5 s pause is closed by the 1 s element
    gyr, _ = rest_move_signal(
        rng, [("rest", 1), ("move", 2), ("rest", 2.5), ("move", 2), ("rest", 1)]
    )
    assert len(movement_ranges(gyr, FS)) == 2
    # with a longer closing element the 2.5 s rest is filled too: the parameter is honoured
    assert len(movement_ranges(gyr, FS, TrimParams(closing_s=4.0))) == 1


def test_movement_touching_the_ends_is_kept(rng):
    gyr, _ = rest_move_signal(rng, [("move", 2), ("rest", 2), ("move", 2)])
    mask = movement_mask(gyr, FS)
    assert mask[0] and mask[-1]


def test_static_recording_raises(rng):
    gyr = rng.normal(0, 0.01, (1000, 3))
    with pytest.raises(NoMovementError, match="peak angular velocity"):
        movement_ranges(gyr, FS)


def test_nan_raises(rng):
    gyr, _ = rest_move_signal(rng, [("rest", 1), ("move", 2)])
    gyr[50, 1] = np.nan
    with pytest.raises(NonFiniteError, match="sample 50"):
        movement_ranges(gyr, FS)


def test_closing_the_gaps_equals_scipys_binary_closing_of_the_padded_mask():
    """close_gaps (from the runs) is the closing Kong Fig. 5 names, as scipy.ndimage computes it:
    random masks of random run lengths, odd and even structuring elements."""
    from scipy import ndimage

    from aceval.signals.segmentation import close_gaps

    rng = np.random.default_rng(0)
    for _ in range(2000):
        n, length = int(rng.integers(1, 400)), int(rng.integers(1, 120))
        runs = rng.random(n // 5 + 1) < rng.uniform(0.05, 0.95)
        mask = np.repeat(runs, rng.integers(1, 30, len(runs)))[:n]
        padded = np.pad(mask, length, constant_values=False)
        expected = ndimage.binary_closing(padded, structure=np.ones(length, bool))[length:-length]
        np.testing.assert_array_equal(close_gaps(mask, length), expected)
