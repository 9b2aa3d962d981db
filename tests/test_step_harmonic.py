"""The step-harmonic heading: a known mounting comes back from a synthetic walking trunk."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.methods.step_harmonic import (
    MAX_STEP_RATIO,
    harmonic,
    pooled_steps,
    step_frequency,
    step_harmonic_rotation,
    step_scatter,
)

FS = 100.0
STEP_HZ = 1.8
R_TRUE = Rotation.from_euler("zyx", [-60, 15, 100], degrees=True).as_matrix()  # sensor -> body


def walking_trunk(ap=2.0, ml=0.8, seconds=12.0, seed=0, step_hz=STEP_HZ):
    """Specific force (body frame, m/s^2) of a trunk walking at STEP_HZ: fore-aft at the step
    frequency, sideways at the stride frequency (half of it), vertical at the step frequency,
    plus noise; standing still for 2 s at each end."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, seconds, 1 / FS)
    walking = (t > 2) & (t < seconds - 2)
    w = 2 * np.pi * step_hz
    body = np.zeros((len(t), 3))
    body[:, 0] = ap * np.sin(w * t)
    body[:, 1] = ml * np.sin(0.5 * w * t + 0.3)
    body[:, 2] = 2.5 * np.cos(w * t)
    body *= walking[:, None]
    body[:, 2] -= 9.81  # at rest the specific force points up (z down)
    return body + 0.1 * rng.standard_normal(body.shape), walking


def calibrate(body, mask, R_mount, segment="waist"):
    acc = body @ R_mount  # d_sensor = R^T d_body, row-wise
    z0 = R_mount.T @ np.array([0.0, 0.0, 1.0])
    right = R_mount.T @ np.array([0.0, 1.0, 0.0])
    step_hz = pooled_steps([(acc, mask, segment, 1)], FS)[1]
    H = step_scatter(acc, FS, mask, harmonic(segment) * step_hz)
    R, ratio = step_harmonic_rotation(H, z0, right)
    return R, ratio, step_hz


def test_a_known_mounting_comes_back_and_the_step_frequency_is_found():
    body, walking = walking_trunk()
    R, ratio, step_hz = calibrate(body, walking, R_TRUE)
    assert step_hz == pytest.approx(STEP_HZ, abs=0.05)
    assert error_angle_deg(R, R_TRUE) < 1.0
    assert ratio < 0.1 <= MAX_STEP_RATIO
    assert np.allclose(R @ R.T, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)


def test_a_rotated_sensor_gives_the_correspondingly_rotated_calibration():
    body, walking = walking_trunk(seed=2)
    R, _, _ = calibrate(body, walking, R_TRUE)
    Q = Rotation.from_euler("xyz", [30, -70, 5], degrees=True).as_matrix()
    remounted, _, _ = calibrate(body, walking, R_TRUE @ Q.T)  # the sensor turned by Q
    assert np.allclose(remounted, R @ Q.T, atol=1e-6)


def test_the_sideways_sway_at_the_stride_frequency_does_not_turn_the_heading():
    # a sway larger than the fore-aft swing, but at half the step frequency: filtered out
    body, walking = walking_trunk(ap=1.0, ml=3.0, seed=3)
    R, ratio, _ = calibrate(body, walking, R_TRUE)
    assert error_angle_deg(R, R_TRUE) < 2.0 and ratio < MAX_STEP_RATIO


def test_no_preferred_horizontal_direction_is_flagged_by_its_ratio():
    body, walking = walking_trunk(ap=1.5, ml=0.0, seed=4)
    w = 2 * np.pi * STEP_HZ
    t = np.arange(len(body)) / FS
    body[:, 1] += 1.5 * np.cos(w * t) * walking  # as much sideways power at the step frequency
    _, ratio, _ = calibrate(body, walking, R_TRUE)
    assert ratio > MAX_STEP_RATIO


def test_too_short_or_unfinite_input_gives_nan_not_a_number():
    body, walking = walking_trunk(seconds=4.5)
    assert np.isnan(step_frequency(body[:50], FS))
    R, ratio = step_harmonic_rotation(np.full((3, 3), np.nan), np.array([0, 0, 1.0]), [0, 1, 0])
    assert np.isnan(R).all() and np.isnan(ratio)
    assert np.isnan(step_scatter(body, FS, np.zeros(len(body), dtype=bool), STEP_HZ)).all()
    assert np.isnan(pooled_steps([(body[:150], np.ones(150, dtype=bool), "waist", 1)], FS)[1])


def test_repetitions_too_short_on_their_own_are_pooled():
    """Issue 28: four 2.5 s repetitions, each shorter than two cycles of the slowest step (3.3 s),
    find the step frequency together, and their summed scatters give the mounting."""
    body, _ = walking_trunk(seconds=14.0, seed=5)
    acc = body @ R_TRUE
    parts = [acc[i : i + 250] for i in range(250, 1250, 250)]
    masks = [np.ones(len(p), dtype=bool) for p in parts]
    recordings = [(p, m, "waist", rep) for rep, (p, m) in enumerate(zip(parts, masks), start=1)]
    by_rep, step_hz, own, disagree = pooled_steps(recordings, FS)
    assert step_hz == pytest.approx(STEP_HZ, abs=0.05) and np.isnan(own).all() and not disagree
    assert by_rep == dict.fromkeys(range(1, 5), step_hz)  # each too short: the pooled one
    H = sum(step_scatter(p, FS, m, step_hz) for p, m in zip(parts, masks))
    z0, right = R_TRUE.T @ [0, 0, 1.0], R_TRUE.T @ [0, 1.0, 0]
    assert error_angle_deg(step_harmonic_rotation(H, z0, right)[0], R_TRUE) < 2.0


def test_a_leg_is_read_at_the_stride_and_the_trunk_sets_the_step():
    """A foot swings fore-aft once per stride (half the step frequency) while its magnitude is
    strongest at the step: its heading comes back at the stride harmonic; the trunk recording of
    the same test sets the step frequency."""
    t = np.arange(0, 14, 1 / FS)
    walking = (t > 2) & (t < 12)
    w = 2 * np.pi * STEP_HZ
    foot = np.zeros((len(t), 3))
    foot[:, 0] = 4.0 * np.sin(0.5 * w * t)  # the swing, once per stride
    foot[:, 1] = 3.0 * np.sin(w * t + 0.4)  # sideways at the step: the wrong axis at the step
    foot[:, 2] = 8.0 * np.cos(w * t)
    foot = foot * walking[:, None] + [0, 0, -9.81]
    trunk, _ = walking_trunk(seconds=14.0, seed=6)
    recordings = [(trunk @ R_TRUE, walking, "waist", 1), (foot @ R_TRUE, walking, "foot", 1)]
    _, step_hz, _, disagree = pooled_steps(recordings, FS)
    assert step_hz == pytest.approx(STEP_HZ, abs=0.05) and not disagree
    assert harmonic("foot") == 0.5 and harmonic("pelvis") == harmonic("thigh") == 1.0
    H = step_scatter(foot @ R_TRUE, FS, walking, harmonic("foot") * step_hz)
    z0, right = R_TRUE.T @ [0, 0, 1.0], R_TRUE.T @ [0, 1.0, 0]
    assert error_angle_deg(step_harmonic_rotation(H, z0, right)[0], R_TRUE) < 2.0


def test_recordings_that_disagree_on_the_step_frequency_say_so():
    first, walking = walking_trunk(seed=7)
    second, _ = walking_trunk(seed=8, step_hz=2.7)  # walking at another frequency
    same = pooled_steps([(first, walking, "waist", 1), (first, walking, "chest", 2)], FS)
    assert not same[3] and same[0] == {1: same[1], 2: same[1]}
    other = pooled_steps([(first, walking, "waist", 1), (second, walking, "waist", 2)], FS)
    assert other[3]  # the second repetition's peak is 1.5 times the test's
