"""The right axis proposed from the recordings (aceval.signals.right_axis) on analytic swings of
known mountings: the axis, its sign from each cue, and no sign where there is no cue."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.signals.right_axis import propose, recording_evidence

FS = 100.0
GRAVITY_UP = np.array([0.0, 0.0, -9.81])  # specific force at rest, body frame (z down)


def swing(mount: np.ndarray, seconds=8.0, phase=0.0, gain=1.0, skewed=True, seed=0):
    """A segment swinging about body y (a shank in walking: forward fast, back slowly when
    ``skewed``), seen by a sensor mounted with ``mount`` (sensor -> body): (acc, gyr)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    pulse = np.clip(np.sin(2 * np.pi * t + phase), 0, None) ** 3
    rate = gain * (3.0 * (pulse - pulse.mean()) if skewed else 2.0 * np.sin(2 * np.pi * t + phase))
    pitch = np.cumsum(rate) / FS
    body = Rotation.from_rotvec(np.outer(pitch, [0.0, 1.0, 0.0]))  # segment -> body's stance
    gyr_body = np.column_stack([np.zeros_like(rate), rate, np.zeros_like(rate)])
    acc_body = body.inv().apply(GRAVITY_UP) + rng.normal(0, 0.05, (len(t), 3))
    to_sensor = mount.T
    return acc_body @ to_sensor.T, gyr_body @ to_sensor.T + rng.normal(0, 0.01, (len(t), 3))


def mounted(axis: str, tilt_deg: float, rng) -> np.ndarray:
    """A sensor -> body rotation whose sensor axis ``axis`` points to the body's right, tilted by
    up to ``tilt_deg`` about a random axis."""
    target = {"+x": [0, 0, 90], "-x": [0, 0, -90], "+y": [0, 0, 0], "-y": [0, 0, 180],
              "+z": [-90, 0, 0], "-z": [90, 0, 0]}[axis]  # fmt: skip
    base = Rotation.from_euler("xyz", target, degrees=True)
    wobble = Rotation.from_rotvec(rng.normal(size=3) / np.sqrt(3) * np.radians(tilt_deg))
    R = (wobble * base).as_matrix()
    k = int(np.argmax(np.abs(R[1])))  # body y in the sensor frame: along the signed axis
    assert "xyz"[k] == axis[1] and np.sign(R[1, k]) == (1 if axis[0] == "+" else -1)
    return R


def unit(imu, segment, test, phase, stats, subject="S1"):
    return {"subject": subject, "sensor_set": "main", "imu": imu, "segment": segment,
            "test": test, "first_phase": phase, "stats": stats}  # fmt: skip


@pytest.mark.parametrize("axis", ["+x", "-x", "+y", "-y", "+z", "-z"])
def test_a_shank_in_walking_proposes_its_mounting_with_certainty(axis, rng):
    mount = mounted(axis, 15.0, rng)
    acc, gyr = swing(mount)
    stats = recording_evidence({"S": (acc, gyr, "shank", "right")}, "gait", FS)
    (found,) = propose([unit("S", "shank", "walk", "gait", [stats["S"]])])
    assert (found["proposed"], found["verdict"]) == (axis, "sure")
    assert np.degrees(np.arccos(found["direction"] @ mount[1])) < 5  # the true right direction


def test_a_foot_takes_its_sign_from_the_shank_of_its_side_and_a_trunk_sensor_none(rng):
    shank_mount, foot_mount, waist_mount = (mounted(a, 10.0, rng) for a in ("+z", "-y", "+x"))
    shank = swing(shank_mount, seed=1)
    foot = swing(foot_mount, phase=0.3, gain=1.2, seed=2)
    waist = swing(waist_mount, gain=0.3, skewed=False, seed=3)
    group = {"S": (*shank, "shank", "left"), "F": (*foot, "foot", "left")}
    group["W"] = (*waist, "waist", "center")
    stats = recording_evidence(group, "gait", FS)
    found = {p["imu"]: p for p in propose([unit(i, s[2], "walk", "gait", [stats[i]])
                                           for i, s in group.items()])}  # fmt: skip
    assert (found["F"]["proposed"], found["F"]["verdict"]) == ("-y", "sure")
    assert found["W"]["proposed"] == "+-x" and found["W"]["verdict"] == "undetermined"
    assert "trunk" in found["W"]["evidence"]
    # the foot alone: the axis, no sign
    alone = recording_evidence({"F": (*foot, "foot", "left")}, "gait", FS)
    (only,) = propose([unit("F", "foot", "walk", "gait", [alone["F"]])])
    assert only["proposed"] == "+-y" and only["verdict"] == "undetermined"


def test_a_first_phase_gives_the_sign_and_an_undetermined_plane_no_axis(rng):
    mount = mounted("-z", 10.0, rng)
    # a leg swing whose first phase is forward (+y): the swing starts with a positive rotation
    reps = [swing(mount, seconds=2.0, skewed=False, seed=k) for k in range(3)]
    stats = [recording_evidence({"T": (a, g, "thigh", "right")}, "+y", FS)["T"] for a, g in reps]
    (found,) = propose([unit("T", "thigh", "T5", "+y", stats)])
    assert (found["proposed"], found["verdict"]) == ("-z", "sure")
    # the same recordings declared as a -y test (bowing) give the opposite sign
    flipped = [dict(s) for s in stats]
    (opposite,) = propose([unit("T", "thigh", "T1", "-y", flipped)])
    assert opposite["proposed"] == "+z"
    # no rotation axis and no plane: random tumbling gives nothing
    tumble_gyr = rng.normal(0, 1.0, (800, 3))
    tumble_acc = rng.normal(0, 5.0, (800, 3))
    tumbling = recording_evidence({"T": (tumble_acc, tumble_gyr, "thigh", "right")}, "+y", FS)
    (none,) = propose([unit("T", "thigh", "T5", "+y", [tumbling["T"]])])
    assert none["proposed"] == "" and none["verdict"] == "undetermined"
