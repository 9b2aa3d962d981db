"""The place checks (aceval.signals.signatures) on signals whose answer is known."""

import numpy as np
import pandas as pd

from aceval.signals.signatures import (
    MIN_TIMING_R,
    motion_signatures,
    sagittal_rate,
    signature_verdicts,
    speed_envelope,
)

FS = 100.0
T = np.arange(0, 10, 1 / FS)
RIGHT = np.array([0.0, 1.0, 0.0])


def about_y(rate: np.ndarray) -> np.ndarray:
    return np.column_stack([0.02 * np.sin(7 * T), rate, 0.01 * np.cos(5 * T)])


def test_timing_tells_a_sensor_moving_with_the_others_from_one_that_does_not():
    bell = np.exp(-(((T - 5) / 0.8) ** 2))  # one movement, all sensors together
    rng = np.random.default_rng(0)
    gyr = {"A": about_y(2 * bell), "B": about_y(-1.5 * bell), "C": rng.normal(0, 1, (len(T), 3))}
    envelopes = {imu: speed_envelope(T, g, FS) for imu, g in gyr.items()}
    places = {"A": ("chest", "center"), "B": ("thigh", "right"), "C": ("shank", "right")}
    found = motion_signatures(envelopes, places)
    assert found["A"]["timing_r"] > 0.9 and found["B"]["timing_r"] > 0.9
    assert found["C"]["timing_r"] < MIN_TIMING_R


def test_side_votes_follow_the_leg_that_swings_together():
    stride = 2 * np.pi * T / 1.1
    swing = {"right": np.sin(stride), "left": np.sin(stride + np.pi)}  # half a stride apart
    gyr = {
        "thigh_r": about_y(swing["right"]),
        "shank_r": about_y(1.3 * np.sin(stride - 0.4)),
        "thigh_l": about_y(swing["left"]),
        "shank_l": about_y(1.3 * np.sin(stride - 0.4 + np.pi)),
    }
    places = {k: (k.split("_")[0], "right" if k.endswith("_r") else "left") for k in gyr}
    envelopes = {imu: speed_envelope(T, g, FS) for imu, g in gyr.items()}
    rates = {imu: sagittal_rate(T, g, FS, RIGHT) for imu, g in gyr.items()}
    found = motion_signatures(envelopes, places, rates)
    assert all(found[imu]["side_votes"] == 1 for imu in gyr)
    places_exchanged = places | {"thigh_r": ("thigh", "left"), "thigh_l": ("thigh", "right")}
    found = motion_signatures(envelopes, places_exchanged, rates)
    assert found["thigh_r"]["side_votes"] == -1 and found["thigh_l"]["side_votes"] == -1
    assert np.isnan(found["thigh_r"]["timing_r"])  # not judged in walking


def test_a_sign_from_an_axis_far_from_the_right_axis_is_not_given():
    assert sagittal_rate(T, about_y(np.sin(T)), FS, np.array([1.0, 0.0, 0.0])) is None


def test_verdicts_flag_a_sensor_moving_in_a_test_that_does_not_calibrate_it():
    rows = []
    for imu, speeds in {"A": (100, 5), "B": (90, 80), "C": (110, 4)}.items():
        for test, speed in zip(("T1", "T4"), speeds):
            rows.append(
                {"subject": "S1", "sensor_set": "s", "imu": imu, "test": test, "rep": 1,
                 "calibrates": imu != "B", "gyro_p90_deg_s": speed, "timing_r": 0.9,
                 "side_votes": np.nan, "side_evidence": np.nan}
            )  # fmt: skip
    verdicts = signature_verdicts(pd.DataFrame(rows))
    # B is calibrated by neither test but moves in both (in T4 the calibrated sensors are still)
    assert verdicts[("S1", "s", "B")]["flag"] == "unexpected_motion_pattern"
    assert verdicts[("S1", "s", "A")]["flag"] == "" and verdicts[("S1", "s", "C")]["flag"] == ""


def test_flags_are_combined_never_overwritten():
    from aceval.calibrate.table import combine_flags, has_flag

    assert combine_flags("", "backward", "backward;right_axis_mismatch", None) == (
        "backward;right_axis_mismatch"
    )
    assert combine_flags("", "") == ""
    flags = pd.Series(["backward;low_rho", "low_rho", "", np.nan])
    assert has_flag(flags, "backward").tolist() == [True, False, False, False]


def test_direction_checks_give_both_flags_when_both_hold():
    """A calibration that is backward and whose declared right axis is 90 deg off carries both."""
    from aceval.signals.checks import direction_checks

    found = direction_checks(
        np.array(["-y"]), np.array(["chest"]), np.array([[[0.0, 1.0, 0.0]]]), None,
        np.ones((1, 1)), np.eye(3)[None], np.array([[1.0, 0.0, 0.0]]),
    )  # fmt: skip
    assert found["flag"][0] == "backward;right_axis_mismatch"


def test_an_undetermined_y_axis_leaves_the_right_axis_unchecked_not_mislabelled():
    """The declared right axis 90 deg from y0: a mislabel where y0 is determined, 'unchecked'
    where Kong's plane normal is undetermined (y0 then says nothing about the declaration)."""
    from aceval.signals.checks import direction_checks

    args = (
        np.array(["", ""]), np.array(["waist", "waist"]), np.full((2, 1, 3), np.nan), None,
        np.ones((2, 1)), np.stack([np.eye(3)] * 2), np.array([[1.0, 0.0, 0.0]] * 2),
    )  # fmt: skip
    found = direction_checks(*args, undetermined=np.array([False, True]))
    assert found["flag"].tolist() == ["right_axis_mismatch", "right_axis_unchecked"]
    assert found["mismatch"].tolist() == [True, False]
    assert direction_checks(*args)["flag"].tolist() == ["right_axis_mismatch"] * 2
