"""The checks of a sensor's own signals (issue 41) on analytic cases: a stuck channel, a spike,
the gyroscope's offset, static trials that disagree, the accelerometer's sign."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.contract import R_COLUMNS
from aceval.data.errors import StuckChannelError
from aceval.data.recording_checks import acc_spikes, plateau_limit, stuck_channel
from aceval.evaluation.methods_comparison import with_truth
from aceval.evaluation.truth_warnings import truth_warning
from aceval.signals.checks import (
    GYRO_BIAS_LIMIT_DEG_S,
    acc_sign_agreement,
    agreement_moments,
    recording_signals,
    signal_verdict,
)
from aceval.signals.reduction import C_AA, C_AB, C_BB, MEAN_A, MEAN_B, moments

G = 9.81
NAMES = ["acc_x", "acc_y", "acc_z"]


def swing(n: int = 2000, fs: float = 100.0, seed: int = 0):
    """A noisy sensor swinging about its y axis: (acc m/s^2, gyr rad/s), (n, 3) each."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    angle = 0.6 * np.sin(2 * np.pi * 0.5 * t)
    rate = np.column_stack([0.05 * np.sin(t), 0.6 * np.pi * np.cos(np.pi * t), 0.05 * np.cos(t)])
    acc = Rotation.from_rotvec(angle[:, None] * [0.0, 1.0, 0.0]).inv().apply([0.0, 0.0, G])
    return acc + rng.normal(0, 0.02, acc.shape), rate + rng.normal(0, 0.002, rate.shape)


def test_a_stuck_channel_is_found_and_a_noise_free_one_is_not():
    acc, gyr = swing()
    assert stuck_channel(acc, NAMES) is None
    for value in (0.0, 0.0731 * G):
        stuck = acc.copy()
        stuck[:, 1] = value
        name, share, held = stuck_channel(stuck, NAMES)
        assert (name, share, held) == ("acc_y", 1.0, value)
    planar = swing()[0] * [1.0, 0.0, 1.0]  # acc_y exactly 0, acc_x and acc_z noisy: a dead axis
    assert stuck_channel(planar, NAMES)[0] == "acc_y"
    ideal = Rotation.from_rotvec(np.linspace(0, 1, 500)[:, None] * [0, 1, 0]).inv().apply([0, 0, G])
    assert stuck_channel(ideal, NAMES) is None  # noise-free: y may hold 0 rightly
    with pytest.raises(StuckChannelError, match="gyr_y holds one value"):
        recording_signals(acc, gyr * [1.0, 0.0, 1.0], np.zeros(len(acc), bool))


def test_a_spike_is_found_where_the_rotation_runs_smoothly_and_not_at_an_impact():
    acc, gyr = swing()
    assert not acc_spikes(acc, gyr).any()
    spiked = acc.copy()
    spiked[700, 0] = 16 * G
    assert np.flatnonzero(acc_spikes(spiked, gyr)).tolist() == [700]
    jolted = gyr.copy()
    jolted[700] += np.radians([0.0, 60.0, 0.0])  # an impact turns the segment too
    assert not acc_spikes(spiked, jolted).any()


def test_plateau_limit_finds_the_rail_axis_by_axis():
    acc, _ = swing()
    assert plateau_limit(acc) is None
    clipped = np.clip(acc, -0.8 * G, 0.8 * G)
    assert plateau_limit(clipped) == pytest.approx(0.8 * G)


def test_agreement_moments_summed_in_chunks_equal_one_pass(monkeypatch):
    acc, gyr = swing(6000)
    whole = agreement_moments(acc, gyr, 100.0)
    monkeypatch.setattr("aceval.signals.checks.CHUNK_SAMPLES", 777)
    chunked = agreement_moments(acc, gyr, 100.0)
    assert whole["ga_turn_deg"] > 0
    assert all(np.isclose(whole[k], chunked[k], rtol=1e-12, atol=1e-12) for k in whole)


def _rows(offset_deg_s: np.ndarray, z0: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An IMU's rest offsets (its static, then four motion recordings), static verticals and
    vendor angles (none), as :func:`signal_verdict` takes them."""
    offsets = np.tile(np.radians(offset_deg_s), (len(z0) + 4, 1))
    return offsets, np.array(z0, dtype=float), np.full(len(z0), np.nan)


def test_the_gyroscope_offset_and_static_trials_that_disagree_are_flagged():
    down = [0.0, 0.0, 1.0]
    leaning = Rotation.from_rotvec(np.radians(18) * np.array([0, 1, 0])).apply(down)
    verdict = signal_verdict(*_rows(np.array([1.0, 0.5, 0.0]), [down, down]))
    assert verdict["flag"] == "" and verdict["static_spread_deg"] == pytest.approx(0.0)
    verdict = signal_verdict(*_rows(np.array([5.0, 0.0, 5.0]), [down, leaning]))
    assert verdict["flag"] == "gyro_bias;static_disagree"
    assert verdict["gyro_bias_deg_s"] == pytest.approx(np.hypot(5, 5))
    assert np.hypot(5, 5) > GYRO_BIAS_LIMIT_DEG_S
    assert verdict["static_spread_deg"] == pytest.approx(18.0)


def _pair(acc_a, gyr_a, acc_b, gyr_b) -> pd.DataFrame:
    base = {"objective": "frontal_lateral", "subject": "S1", "sensor_set": "frontal|lateral",
            "imu": "IMU4", "window": "all", "flag": ""}  # fmt: skip
    rows = [base | {"signal": s} | moments(a, b) for s, a, b in
            (("acc", acc_a, acc_b), ("gyr", gyr_a, gyr_b))]  # fmt: skip
    return pd.DataFrame(rows)


def test_two_sensors_of_a_segment_agree_on_the_accelerometer_sign_unless_one_is_negated():
    """A rigid mount (b = M a) with motion out of the plane: agreement > 0 as read, exactly its
    negative with one accelerometer negated."""
    rng = np.random.default_rng(3)
    acc, gyr = swing()
    gyr = gyr + np.column_stack([0.4 * np.sin(np.arange(len(gyr)) / 37.0), np.zeros(len(gyr)),
                                 0.3 * np.cos(np.arange(len(gyr)) / 23.0)])  # fmt: skip
    mount = Rotation.from_euler("xyz", [20, -70, 35], degrees=True)
    acc_b = mount.apply(acc) + rng.normal(0, 0.05, acc.shape)
    pairs = _pair(acc, gyr, acc_b, mount.apply(gyr))
    agreement = acc_sign_agreement(pairs)
    assert set(agreement) == {("S1", "frontal", "IMU4"), ("S1", "lateral", "IMU4")}
    value = agreement[("S1", "frontal", "IMU4")]
    assert value > 0.1
    negated = acc_sign_agreement(_pair(acc, gyr, -acc_b, mount.apply(gyr)))
    assert negated[("S1", "frontal", "IMU4")] == pytest.approx(-value)
    assert MEAN_A[0] in pairs and C_AA[0] in pairs and C_BB[0] in pairs and C_AB[0] in pairs
    assert MEAN_B[0] in pairs


def test_the_truth_warning_names_a_reversed_accelerometer_however_few():
    """One IMU's calibrations are its truth turned 180 deg about the body's right axis (what an
    accelerometer read with the other sign gives): named, and a transposed truth not blamed; a
    transposed truth is still told as such."""
    axes = np.array([[0.6, 0.0, 0.8], [0.0, 0.6, -0.8], [0.8, -0.6, 0.0]])
    mounts = Rotation.from_rotvec(np.radians([[60.0], [70.0], [80.0]]) * axes).as_matrix()
    truths = dict(zip(["IMU2", "IMU4", "IMU5"], mounts))  # transposed: 120-160 deg off
    truth = pd.DataFrame(
        [{"subject": "S1", "sensor_set": "frontal", "imu": imu, **dict(zip(R_COLUMNS, R.ravel()))}
         for imu, R in truths.items()]
    ).set_index(["subject", "sensor_set", "imu"])  # fmt: skip

    def table(estimate) -> pd.DataFrame:
        rows = [
            {"subject": "S1", "sensor_set": "frontal", "imu": imu, "test": "T3", "method": m,
             "n_reps": 3, "repetitions": "R1+R2+R3", "flag": "",
             **dict(zip(R_COLUMNS, estimate(imu, R).ravel()))}
            for imu, R in truths.items() for m in ("kong", "triad")
        ]  # fmt: skip
        return with_truth(pd.DataFrame(rows), truth)

    one = table(lambda imu, R: np.diag([-1.0, 1.0, -1.0]) @ R if imu == "IMU4" else R)
    warning = truth_warning(one, truth)
    assert "S1 frontal IMU4" in warning and "acc_at_rest" in warning
    assert "IMU2" not in warning and "transposed" not in warning
    assert truth_warning(table(lambda imu, R: R), truth) == ""
    assert "transposed" in truth_warning(table(lambda imu, R: R.T), truth)
