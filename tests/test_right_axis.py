"""The right axis proposed from the recordings (aceval.signals.right_axis) on analytic swings of
known mountings: the axis, its sign from each cue, and no sign where there is no cue."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.signals.gait_sign import foot_pitch_votes, pendulum_right
from aceval.signals.right_axis import propose, recording_evidence

from . import walking

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
    assert found["F"]["sign_from"] == "shank of its side"  # a swing has no foot flat to vote
    # a trunk sensor that only sways: no pendulum, and its plane is no sagittal plane in walking
    assert found["W"]["proposed"] == "" and found["W"]["verdict"] == "undetermined"
    assert "the data cannot tell" in found["W"]["evidence"]
    assert "inverted pendulum" in found["W"]["evidence"]
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


# --- the foot's pitch and the trunk's pendulum in walking (aceval.signals.gait_sign)


@pytest.mark.parametrize("axis", ["+x", "-y", "+z"])
def test_a_foot_alone_in_walking_takes_its_sign_from_its_pitch(axis, rng):
    """No shank: toe-down first and farther after each foot flat gives the sign; the same strides
    played backwards (walking backwards: the order reversed, the sizes not) abstain."""
    mount = mounted(axis, 10.0, rng)
    acc, gyr = walking.foot_walk(mount)
    stats = recording_evidence({"F": (acc, gyr, "foot", "right")}, "gait", FS)
    (found,) = propose([unit("F", "foot", "walk", "gait", [stats["F"]])])
    assert (found["proposed"], found["verdict"], found["sign_from"]) == (axis, "sure", "foot pitch")
    assert "in 8 of 8 strides" in found["evidence"]
    axis_votes, n_for, n_against = foot_pitch_votes(gyr, FS)
    assert (n_for + n_against, min(n_for, n_against)) == (8, 0)
    back = walking.foot_walk(mount, reverse=True)
    assert foot_pitch_votes(back[1], FS)[1:] == (0, 0)
    stats = recording_evidence({"F": (*back, "foot", "right")}, "gait", FS)
    (backwards,) = propose([unit("F", "foot", "walk", "gait", [stats["F"]])])
    assert backwards["proposed"] == f"+-{axis[1]}" and backwards["verdict"] == "undetermined"
    assert "the data cannot tell the sign" in backwards["evidence"]


def test_a_foot_stride_votes_by_its_larger_and_first_excursion_only_when_both_agree():
    """The two cues of a stride, set apart: toe-up first but toe-down farther, or neither
    strongly, abstain; a stride that turns less than 20 deg does not vote."""
    pitch = walking.foot_pitch

    def rate(angle):
        return np.column_stack([0 * angle, np.gradient(np.radians(angle)) * FS, 0 * angle])

    assert foot_pitch_votes(rate(pitch()), FS)[1:] == (8, 0)
    assert foot_pitch_votes(rate(pitch(down_deg=15, up_deg=40)), FS)[1:] == (0, 0)  # disagree
    assert foot_pitch_votes(rate(pitch(down_deg=8, up_deg=6)), FS)[1:] == (0, 0)  # too small
    assert foot_pitch_votes(rate(pitch(reverse=True)), FS)[1:] == (0, 0)


@pytest.mark.parametrize("axis", ["+y", "-z", "+x"])
def test_a_trunk_in_walking_takes_its_right_direction_from_the_pendulum(axis, rng):
    mount = mounted(axis, 15.0, rng)
    acc, gyr = walking.trunk_walk(mount)
    right, correlation = pendulum_right(acc, FS)
    assert correlation > 0.9 and np.degrees(np.arccos(right @ mount[1])) < 5
    reps = [walking.trunk_walk(mount, seed=k) for k in range(2)]
    stats = [recording_evidence({"W": (a, g, "waist", "center")}, "gait", FS)["W"] for a, g in reps]
    (found,) = propose([unit("W", "waist", "walk", "gait", stats)])
    said = (found["proposed"], found["verdict"], found["sign_from"])
    assert said == (axis, "sure", "trunk pendulum")
    # running trades speed and height the other way: the cue, read in walking only, reverses
    assert pendulum_right(walking.trunk_walk(mount, running=True)[0], FS)[0] @ mount[1] < -0.9


def test_subjects_who_disagree_are_named_not_averaged(rng):
    """Two subjects' feet mounted the opposite ways under one IMU name: no proposal, each subject's
    answer in the evidence (they wore different sensors, or wore them differently)."""
    units = []
    for subject, axis in (("S1", "+y"), ("S2", "-y"), ("S3", "+y")):
        acc, gyr = walking.foot_walk(mounted(axis, 5.0, rng), seed=len(units))
        stats = recording_evidence({"F": (acc, gyr, "foot", "right")}, "gait", FS)
        units.append(unit("F", "foot", "walk", "gait", [stats["F"]], subject=subject))
    (found,) = propose(units)
    assert found["proposed"] == "" and found["verdict"] == "undetermined"
    assert "S1: +y (sure); S2: -y (sure); S3: +y (sure)" in found["evidence"]
    by_line = {p["key"]: p["proposed"] for p in propose(units, key=lambda u: u["subject"])}
    assert by_line == {"S1": "+y", "S2": "-y", "S3": "+y"}
    (agreeing,) = propose([units[0], units[2]])
    assert agreeing["proposed"] == "+y" and "2 subjects, each alike" in agreeing["evidence"]


def test_the_xsens_import_proposes_for_every_empty_sheet_line_from_its_own_sensor(
    tmp_path, rng, capsys
):
    """Two subjects who wore different sensors (one sensors.tsv line each), mounted differently,
    right_axis left empty: each line is refused with its own sensor's proposal, not the first
    subject's for both and not their average."""
    from aceval.cli import main

    from .labexports import export

    lines = ["sensor_id\tsegment\tside\timu\tsubject\tright_axis"]
    for k, (subject, axis) in enumerate((("P1", "+y"), ("P2", "-z"))):
        mount = mounted(axis, 5.0, rng)
        acc, gyr = walking.foot_walk(mount, seed=k)
        standing = np.tile(walking.GRAVITY_UP @ mount, (200, 1)) + rng.normal(0, 0.05, (200, 3))
        acc = np.vstack([standing, acc])
        gyr = np.vstack([rng.normal(0, 0.01, (200, 3)), gyr])
        sensor = f"00B4A30{k + 1}"
        path = tmp_path / "exports" / subject / f"walk_1-000_{sensor}.txt"
        path.parent.mkdir(parents=True)
        export(path, sensor, 100, acc, gyr, "2019")
        lines.append(f"{sensor}\tfoot\tright\tfoot_r\t{subject}\t")
    (tmp_path / "sensors.tsv").write_text("\n".join(lines) + "\n")
    (tmp_path / "trials.tsv").write_text(
        "subject\ttrial\ttest\tstatic\tfirst_phase\n"
        "P1\tP1/walk_1\twalk\t2\tgait\nP2\tP2/walk_1\twalk\t2\tgait\n"
    )
    args = ["import", "xsens", tmp_path / "exports", "--trials", tmp_path / "trials.tsv"]
    args += ["--sensors", tmp_path / "sensors.tsv", "--out", tmp_path / "out"]
    assert main([str(a) for a in args]) == 1
    said = capsys.readouterr().err
    assert "Traceback" not in said and not (tmp_path / "out").exists()
    assert (
        "sensors.tsv line 2 (foot_r, foot right, subject P1): the recordings propose +y (sure"
        in said
    )
    assert (
        "sensors.tsv line 3 (foot_r, foot right, subject P2): the recordings propose -z (sure"
        in said
    )
    assert said.count("toe-down first and farther") == 2
