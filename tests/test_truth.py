"""The ground truth from optical markers on a simulated trial whose marker frame twists about the
shank's long axis while walking (as the NeuRA shank markers do): the point-acceleration method
stays on the known mounting, the marker-frame method inherits the twist."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.data.truth import (
    acceleration_truth,
    long_axis_heading_deg,
    pair_consistency_deg,
    twist_about_axis,
)
from aceval.importers.vicon import ground_truth
from aceval.simulate.engine import OVERSAMPLE, PAD, measure

FS = 100.0
#: z up (Vicon) -> z down (the simulator's physics): a half turn about x
UP_TO_DOWN = np.diag([1.0, -1.0, -1.0])
#: Kong's body frame in the z-up world, walking along +x: x forward, y right (-y world), z down
BODY = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])


def shank_trial(twist_deg: float, seed: int = 0):
    """3 s standing, then 7 s of walking along x: a shank hanging from a moving knee, pitching 30
    deg at the stride frequency; a sensor 25 cm down the shank with a random mounting; markers at
    the knee and ankle (joint centres on the long axis) and on a lateral wand that twists about
    the long axis by ``twist_deg`` on average (with a 0.5 swing) while walking."""
    rng = np.random.default_rng(seed)
    n_out = int(10 * FS)
    dt = 1.0 / (FS * OVERSAMPLE)
    t = (np.arange(n_out * OVERSAMPLE + 2 * PAD) - PAD) * dt
    walking = np.clip((t - 3.0) / 1.0, 0.0, 1.0) ** 2 * (3 - 2 * np.clip((t - 3.0) / 1.0, 0.0, 1.0))
    phase = 2 * np.pi * 0.9 * np.maximum(t - 3.0, 0.0)
    pitch = walking * np.radians(30.0) * np.sin(phase)
    roll = walking * np.radians(4.0) * np.sin(phase + 0.7)
    # segment frame (columns e1 along the shank, downwards; e2 forward; e3 = e1 x e2), world z up
    standing = np.column_stack([[0, 0, -1.0], [1.0, 0, 0], np.cross([0, 0, -1.0], [1.0, 0, 0])])
    R_seg = Rotation.from_euler("yx", np.column_stack([pitch, roll])).as_matrix() @ standing
    speed = 1.2 * walking
    knee = np.column_stack([np.cumsum(speed) * dt, 0.02 * walking * np.sin(phase / 2),
                            0.5 + 0.02 * walking * np.cos(2 * phase)])  # fmt: skip
    mount = Rotation.random(random_state=seed).as_matrix()  # sensor -> segment
    lever = np.array([0.25, 0.05, 0.04])  # segment frame, from the knee
    sensor_pos = knee + R_seg @ lever
    R_ws = R_seg @ mount
    gyr, acc = measure(UP_TO_DOWN @ R_ws, sensor_pos @ UP_TO_DOWN.T, FS)
    gyr += rng.normal(0, 0.005, gyr.shape)
    acc += rng.normal(0, 0.02, acc.shape)
    index = np.arange(PAD, len(t) - PAD, OVERSAMPLE)
    twist = np.radians(twist_deg) * walking[index] * (1 + 0.5 * np.sin(phase[index]))
    wand_seg = np.column_stack(
        [np.full(len(index), 0.15), -0.08 * np.sin(twist), 0.08 * np.cos(twist)]
    )
    markers = {
        "KNEE": knee[index],
        "ANKLE": knee[index] + R_seg[index] @ np.array([0.4, 0, 0]),
        "WAND": knee[index] + np.einsum("nij,nj->ni", R_seg[index], wand_seg),
    }
    truth = BODY @ R_ws[index[int(2.9 * FS)]]
    return gyr, acc, markers, truth, R_seg[index], lever


@pytest.mark.parametrize("twist", [0.0, 15.0])
def test_point_acceleration_truth_ignores_a_twisting_marker_frame(twist):
    gyr, acc, markers, truth, _, lever = shank_trial(twist)
    standing, walk, bout = (
        (0, int(3 * FS)),
        (int(4 * FS), int(10 * FS) - 5),
        (int(3 * FS), int(7 * FS)),
    )
    new = acceleration_truth(acc, gyr, markers["ANKLE"], standing, bout, FS)
    old = ground_truth(markers, ("KNEE", "ANKLE", "WAND"), gyr, acc, standing, walk, FS)
    error_new = error_angle_deg(BODY @ new["R_ws0"].as_matrix(), truth)
    error_old = error_angle_deg(BODY @ old["R_ws0"].as_matrix(), truth)
    assert error_new < 1.0
    if twist:
        assert error_old > 5.0  # the marker frame's twist biases its truth
        # the twist check sees it: marker frame vs sensor, about the long axis, during the walk
        seen = twist_about_axis(
            old["frames"][new["start"] : bout[1]], new["orientation"], [1, 0, 0], 0
        )
        assert abs(np.mean(seen[-200:])) == pytest.approx(twist, abs=2.0)
    else:
        assert error_old < 1.0
    # per stride (0.9 Hz: 1.1 s each) the heading agrees with the whole bout's
    strides = [(int((4 + 1.1 * k) * FS), int((5.1 + 1.1 * k) * FS)) for k in range(2)]
    per_stride = acceleration_truth(acc, gyr, markers["ANKLE"], standing, bout, FS, 0, strides)
    assert per_stride["stride_sd_deg"] < 1.0 and per_stride["stride_se_deg"] < 1.0
    # the long axis (knee to ankle), seen by the markers, asks no correction of the right truth
    # (whatever the wand does) and the marker frame's twist of the wrong one
    a, b = bout
    orientation = new["orientation"][a - new["start"] : b - new["start"]]
    gyr_walk = gyr[a:b] - gyr[: standing[1]].mean(axis=0)
    correction = long_axis_heading_deg(orientation, gyr_walk, markers["KNEE"][a:b],
                                       markers["ANKLE"][a:b], FS)  # fmt: skip
    assert abs(correction) < 2.0
    turned = Rotation.from_euler("z", 10, degrees=True) * orientation
    assert long_axis_heading_deg(turned, gyr_walk, markers["KNEE"][a:b], markers["ANKLE"][a:b],
                                 FS) == pytest.approx(-10.0, abs=2.0)  # fmt: skip
    # the fitted lever arm is where the sensor sits: 16 cm from the ankle point
    ankle_to_sensor = lever - np.array([0.4, 0.0, 0.0])
    assert np.linalg.norm(new["lever_arm_m"]) == pytest.approx(
        np.linalg.norm(ankle_to_sensor), abs=0.02
    )


def test_pair_consistency_of_two_sensors_on_one_segment():
    """Two sensors on one rigid segment: their gyroscopes' relative rotation equals the one their
    true mountings imply; a truth turned by 5 deg shows as 5 deg."""
    rng = np.random.default_rng(1)
    omega_segment = rng.normal(size=(500, 3)) * [0.3, 2.0, 0.5]
    mount_a, mount_b = Rotation.random(2, random_state=3).as_matrix()  # sensor -> segment
    gyr_a, gyr_b = omega_segment @ mount_a, omega_segment @ mount_b  # segment -> sensor frames
    R_a, R_b = BODY @ mount_a, BODY @ mount_b
    assert max(pair_consistency_deg(gyr_a, gyr_b, R_a, R_b)) < 1e-6
    # a truth turned by 5 deg about the body vertical is a heading inconsistency, not a tilt
    turned = Rotation.from_euler("z", 5, degrees=True).as_matrix() @ R_b
    heading, tilt = pair_consistency_deg(gyr_a, gyr_b, R_a, turned)
    assert heading == pytest.approx(5.0, abs=1e-6) and tilt < 1e-6
    tilted = Rotation.from_euler("x", 3, degrees=True).as_matrix() @ R_b
    heading, tilt = pair_consistency_deg(gyr_a, gyr_b, R_a, tilted)
    assert tilt == pytest.approx(3.0, abs=1e-6) and heading < 1e-6
