"""Small functions of the signal checks, the pair alignment and the step-harmonic heading on
cases worked by hand, each a survivor of the mutation benchmark before (issue 44)."""

import numpy as np
import pytest

from aceval.data.errors import TooFewAxesError
from aceval.methods import step_harmonic
from aceval.methods.sufficient import Pooled
from aceval.methods.triad import triad
from aceval.signals import checks
from aceval.signals.alignment import aligned


@pytest.mark.parametrize(
    "n_a, n_b, lag, part_a, part_b",
    [
        (10, 8, 0, (0, 8), (0, 8)),
        (10, 8, 2, (2, 10), (0, 8)),  # a[t + 2] matches b[t]
        (10, 8, -3, (0, 5), (3, 8)),
        (5, 5, 7, (7, 5), (0, 0)),  # no overlap: both empty
    ],
)
def test_aligned_overlap_of_two_recordings(n_a, n_b, lag, part_a, part_b):
    a_slice, b_slice = aligned(n_a, n_b, lag)
    assert (a_slice.start, a_slice.stop) == part_a and (b_slice.start, b_slice.stop) == part_b
    a = np.arange(n_a) - lag  # a[t + lag] == b[t]
    b = np.arange(n_b)
    np.testing.assert_array_equal(a[a_slice], b[b_slice])


def _agreement(trace: float, ww: float, rr: float, evidence: float) -> np.ndarray:
    summed = np.zeros(len(checks.AGREEMENT_COLUMNS))
    summed[[0, 4, 8]] = trace / 3
    summed[9:12] = ww, rr, evidence
    return summed


def test_gyro_acc_agreement_and_its_verdicts():
    kappa, evidence = checks.gyro_acc_agreement(_agreement(0.3, 0.25, 4.0, 500.0))
    assert kappa == pytest.approx(0.3) and evidence == 500.0  # 0.3 / sqrt(0.25 x 4)
    assert np.isnan(checks.gyro_acc_agreement(_agreement(0.3, 0.0, 4.0, 500.0))[0])
    assert checks.agreement_problem(0.05, 500.0).startswith("the accelerometer's turns")
    assert checks.agreement_problem(0.05, 100.0) == ""  # too little slow motion to tell
    assert checks.agreement_problem(float("nan"), 500.0) == ""
    assert checks.agreement_problem(0.5, 500.0) == ""
    empty = checks.best_test_agreement(np.zeros((0, len(checks.AGREEMENT_COLUMNS))))
    assert empty.shape == (len(checks.AGREEMENT_COLUMNS),) and not empty.any()
    assert checks.sensor_problem(_agreement(0.3, 0.25, 4.0, 500.0), 1500.0, "deg/s")["flag"] == (
        "gyro_implausible"
    )
    inconsistent = checks.sensor_problem(_agreement(0.02, 0.25, 4.0, 500.0), 200.0, "deg/s")
    assert inconsistent["flag"] == "gyro_acc_inconsistent"


def test_static_posture_is_the_smallest_median_angle_to_z0():
    tilt = np.radians(12.0)
    still = {
        "T1": [[0.0, np.sin(tilt), np.cos(tilt)]] * 3,  # 12 deg from z0
        "T3": [[0.0, 0.0, 1.0], [np.nan] * 3, [0.0, np.sin(2 * tilt), np.cos(2 * tilt)]],
    }
    found = checks.static_posture(np.array([0.0, 0.0, 1.0]), still)
    assert found["static_vertical_angle_deg"] == pytest.approx(12.0)  # T3's median is 12 too
    assert found["static_check_tests"] == 2 and found["flag"] == "static_not_standing"
    one = checks.static_posture(np.array([0.0, 0.0, 1.0]), {"T1": still["T1"]})
    assert one["flag"] == "" and one["static_vertical_angle_deg"] == pytest.approx(12.0)


# --- the step-harmonic heading ------------------------------------------------------------------

FS = 100.0


def test_the_magnitude_spectrum_is_a_power():
    """Twice the amplitude, four times the power at the step frequency."""
    t = np.arange(800) / FS
    step = np.sin(2 * np.pi * 1.8 * t)
    single, double = (
        step_harmonic.magnitude_spectrum(np.outer(9.81 + amplitude * step, [0, 0, 1]), FS)
        for amplitude in (1.0, 2.0)
    )
    assert double.max() == pytest.approx(4 * single.max(), rel=1e-9)
    assert step_harmonic.peak_frequency(single, FS) == pytest.approx(1.8, abs=0.01)


def test_step_scatter_is_nan_where_no_band_can_be_filtered():
    rng = np.random.default_rng(0)
    acc, mask = rng.normal(size=(400, 3)), np.ones(400, bool)
    assert np.isfinite(step_harmonic.step_scatter(acc, FS, mask, 1.8)).all()
    for frequency, samples in ((float("nan"), acc), (45.0, acc), (1.8, acc[:5])):
        found = step_harmonic.step_scatter(samples, FS, mask[: len(samples)], frequency)
        assert found.shape == (3, 3) and np.isnan(found).all()
    assert np.isnan(step_harmonic.step_scatter(acc, FS, np.zeros(400, bool), 1.8)).all()


def test_a_recording_without_movement_has_no_step_frequency_of_its_own():
    t = np.arange(600) / FS
    walk = np.column_stack([np.zeros_like(t), np.zeros_like(t), 9.81 + np.sin(2 * np.pi * 1.8 * t)])
    recordings = [(walk, np.ones(600, bool), "chest", 1), (walk, np.zeros(600, bool), "chest", 2)]
    step_hz, test_hz, own, _ = step_harmonic.pooled_steps(recordings, FS)
    assert test_hz == pytest.approx(1.8, abs=0.01) and own[0] == pytest.approx(1.8, abs=0.01)
    assert np.isnan(own[1]) and step_hz[2] == test_hz


def test_step_harmonic_applies_to_walking_and_to_a_too_short_walking_test():
    pooled = Pooled.of_axes([0, 0, 1.0], 0.9, [0, 1.0, 0], 0.8)
    gait = Pooled(**{**pooled.__dict__, "first_phase": np.array(["gait"], dtype=object)})
    method = step_harmonic.StepHarmonic()
    assert method.applies(gait).tolist() == [True]  # flagged not_applicable, with a note
    assert method.applies(pooled).tolist() == [False]
    fit = method.fit(gait, {})
    assert fit.flag_.tolist() == ["not_applicable"] and fit.diagnostics_["note"][0]


def test_triad_needs_two_axes_on_each_side():
    for v_ref, v_est in ((np.eye(3)[:1], np.eye(3)[:2]), (np.eye(3)[:2], np.eye(3)[:1])):
        with pytest.raises(TooFewAxesError, match="primary and a secondary"):
            triad(v_ref, v_est)


def test_a_pair_without_overlap_has_one_flagged_row_per_signal():
    from types import SimpleNamespace

    from aceval.signals.reduction import pair_moments

    recording = SimpleNamespace(t=np.arange(50) / FS, acc_norm=np.ones(50))
    moving = np.ones(50, bool)
    rows = pair_moments((recording, moving), (recording, moving), {"pair": "p"}, ("acc_norm",), 49)
    assert rows == [
        {
            "pair": "p",
            "lag_samples": 49,
            "n_overlap": 1,
            "flag": "no_overlap",
            "signal": "acc_norm",
            "window": "all",
            "n": 0,
        }
    ]
    flagged = pair_moments((recording, moving), (recording, moving), {}, ("acc_norm",), 0, "x")
    assert [(r["window"], r["flag"], r["n"]) for r in flagged] == [("all", "x", 0)]


def test_the_spread_of_the_repetitions_axes_ignores_their_sign():
    from aceval.methods.sufficient import axis_spread_deg

    tilt = np.radians(10.0)
    phases = np.array([[[0.0, 1.0, 0.0], [0.0, -np.cos(tilt), np.sin(tilt)], [np.nan] * 3]])
    spread = axis_spread_deg(phases, np.array([[0.0, 1.0, 0.0]]), np.array([[True, True, True]]))
    assert spread[0] == pytest.approx(5.0)  # the median of 0 and 10 deg, the flipped axis 10
