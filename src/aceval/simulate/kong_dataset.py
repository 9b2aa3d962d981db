"""Simulated Kong et al. 2016 dataset: 5 subjects (Kong Table 1), frontal/back and lateral sets of
9 IMUs, T0 once and T1-T6 x 5 repetitions, written in the dataset contract with ground truth.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np

from aceval.data.units import SIMULATED_SUBJECTS
from aceval.data.writer import DatasetWriter, simulated_meta, write_sheet
from aceval.simulate.body import Anthropometry, kong_placements, random_mount
from aceval.simulate.engine import euler_pitch_roll_yaw
from aceval.simulate.kong_protocol import PROTOCOL, t6_walk
from aceval.simulate.motion import segment_poses
from aceval.simulate.options import (
    SHAKING_PEAK_G,
    SimOptions,
    heel_strike_shaking,
    sensor_signals,
)
from aceval.simulate.simulation import Simulation, written

IMUS = [  # Kong Sec. 2.3 and Fig. 4
    ("IMU1", "head", "center", "upper_body"),
    ("IMU2", "chest", "center", "upper_body"),
    ("IMU3", "waist", "center", "upper_body"),
    ("IMU4", "thigh_r", "right", "lower_body"),
    ("IMU5", "shank_r", "right", "lower_body"),
    ("IMU6", "foot_r", "right", "lower_body"),
    ("IMU7", "thigh_l", "left", "lower_body"),
    ("IMU8", "shank_l", "left", "lower_body"),
    ("IMU9", "foot_l", "left", "lower_body"),
]
CALIBRATES = {  # Kong Table 2
    "T1": ["IMU1", "IMU2", "IMU3"],
    "T2": ["IMU1", "IMU2", "IMU3"],
    "T3": ["IMU1", "IMU2", "IMU3", "IMU4", "IMU7"],
    "T4": ["IMU5", "IMU6", "IMU8", "IMU9"],
    "T5": ["IMU4", "IMU5", "IMU6", "IMU7", "IMU8", "IMU9"],
    "T6": ["IMU4", "IMU5", "IMU6", "IMU7", "IMU8", "IMU9"],
}
SUBJECTS = [  # Kong Table 1
    ("S1", 27, 174, 90),
    ("S2", 23, 173, 80),
    ("S3", 23, 166, 68),
    ("S4", 22, 169, 56),
    ("S5", 26, 187, 84),
]
ACC_RANGE_G = {"upper_body": 4.0, "lower_body": 8.0}  # Kong Sec. 2.3
GYR_RANGE_DPS = 400.0  # Kong Sec. 2.3
UNITS = {"acc": "g", "gyr": "deg/s"}
SENSOR_SETS = ["frontal", "lateral"]
#: dataset.yaml's facts of Kong's sensors (the rigid box's too)
SENSOR_META = dict(
    units=UNITS, sensor_sets=SENSOR_SETS, acc_range_g=ACC_RANGE_G, gyr_range_dps=GYR_RANGE_DPS
)
#: soft-tissue wobble RMS (deg) by segment and set: stiffer over bone (head, shank front, foot
#: dorsum), larger over fat and muscle (lateral waist, thighs); see docs/simulation.md
WOBBLE_DEG = {
    "head": (0.3, 0.3),
    "chest": (1.0, 1.0),
    "waist": (1.0, 2.0),
    "thigh": (1.5, 1.5),
    "shank": (0.7, 1.0),
    "foot": (1.0, 1.0),
}
FOOT_PROGRESSION_DEG = (7.0, 3.0)  # toe-out mean, SD (Perry & Burnfield 2010)
LEG_ROTATION_SD_DEG = 3.0  # resting external/internal rotation of the leg


def _subjects(n: int, rng) -> list[tuple]:
    subjects = list(SUBJECTS[:n])
    for k in range(len(subjects), n):  # beyond Kong's five: heights from Table 1's mean and SD
        height = rng.normal(173.8, 8.0)
        subjects.append(
            (f"S{k + 1}", int(rng.integers(20, 30)), round(height), round(rng.normal(75.6, 13.6)))
        )
    return subjects


def _stance_offsets(rng, offplane: float) -> dict[str, np.ndarray]:
    """Each segment's yaw (rad) in quiet stance relative to the whole-body frame {0}: feet toe out
    and legs rotate a little; trunk segments are aligned. Scaled by ``offplane`` (0: none), since
    they turn the legs' planes of motion away from the body's sagittal plane.
    """
    offsets = {}
    for s, sign in (("r", 1.0), ("l", -1.0)):
        leg = np.radians(rng.normal(0, LEG_ROTATION_SD_DEG))
        foot = np.radians(rng.normal(*FOOT_PROGRESSION_DEG))
        offsets[f"thigh_{s}"] = offsets[f"shank_{s}"] = offplane * sign * leg
        offsets[f"foot_{s}"] = offplane * sign * foot
    return offsets


def kong_simulation(
    seed: int,
    n_subjects: int = SIMULATED_SUBJECTS["kong"],
    options: SimOptions = SimOptions(),
    name: str = "kong_sim",
) -> Simulation:
    """The SIMULATED Kong protocol dataset named ``name``, before it is written."""
    meta = simulated_meta(name, "Kong et al. 2016", "kong", seed, options.fs_hz, **SENSOR_META)
    subjects = _subjects(n_subjects, np.random.default_rng([seed, 0]))
    repetitions = {test: 1 if test == "T0" else options.repetitions for test in PROTOCOL}

    def sheets(writer: DatasetWriter) -> None:
        columns = ["subject", "age", "height_cm", "weight_kg"]
        write_sheet(writer.root / "subjects.tsv", columns, subjects)
        writer.protocol_sheets(
            {test: (kind, text) for test, (_, kind, text) in PROTOCOL.items()},
            repetitions,
            CALIBRATES,
        )
        _imus_sheet(writer.root, meta)

    runs = [(test, rep) for test in PROTOCOL for rep in range(1, repetitions[test] + 1)]
    write_subject = partial(_write_subject, seed, subjects, runs, meta, options)
    return Simulation(meta, [s[0] for s in subjects], sheets, write_subject, "kong_sim")


def _imus_sheet(out: Path, meta: dict) -> None:
    """imus.tsv: each IMU of each sensor set, its segment, side, region and declared right axis
    (from the placements of a 1.75 m body: the right axis does not depend on the size).
    """
    probe = kong_placements(Anthropometry(1.75))
    write_sheet(
        out / "imus.tsv",
        ["imu", "sensor_set", "segment", "side", "region", "right_axis"],
        [
            [
                imu,
                sensor_set,
                segment.split("_")[0],
                side,
                region,
                probe[sensor_set][segment].right_axis(),
            ]
            for sensor_set in meta["sensor_sets"]
            for imu, segment, side, region in IMUS
        ],
    )


def _write_subject(seed, subjects, runs, meta, options, k: int, writer: DatasetWriter) -> None:
    """Subject ``k``: its mountings (ground truth) and every recording of every run (test,
    repetition), each drawn from the subject's and the run's own random streams.
    """
    subject, _, height_cm, _ = subjects[k]
    rng = np.random.default_rng([seed, 1, k])
    body = Anthropometry(height_cm / 100.0)
    placements = kong_placements(body)
    offsets = _stance_offsets(rng, options.offplane)
    mounts = {}
    for sensor_set in meta["sensor_sets"]:
        for imu, segment, _, _ in IMUS:
            mount = random_mount(rng, placements[sensor_set][segment], options.misalignment_sd_deg)
            mounts[sensor_set, imu] = mount
            stance = euler_pitch_roll_yaw(0.0, 0.0, offsets.get(segment, 0.0))[0]
            writer.ground_truth(subject, sensor_set, imu, stance @ mount)
    for j, (test, rep) in enumerate(runs):
        run_rng = np.random.default_rng([seed, 2, k, j])
        build = PROTOCOL[test][0]
        extra = {"measured": options.variability == "measured"} if build is t6_walk else {}
        posture, fixed_ankle = build(run_rng, body, options.fs_hz, options.offplane, **extra)
        for segment, yaw in offsets.items():
            posture.add(segment, yaw=yaw)
        R_seg, origin = segment_poses(posture, body, fixed_ankle)
        shake_rng = np.random.default_rng([seed, 3, k, j])  # its own: the other draws unchanged
        for sensor_set in meta["sensor_sets"]:
            for imu, segment, _, region in IMUS:
                wobble = WOBBLE_DEG[segment.split("_")[0]][sensor_set == "lateral"]
                shaking = _shaking(shake_rng, posture, segment, options.impacts)
                gyr, acc = sensor_signals(
                    run_rng,
                    R_seg[segment],
                    origin[segment],
                    mounts[sensor_set, imu],
                    placements[sensor_set][segment].position,
                    posture.envelope,
                    wobble,
                    options,
                    ACC_RANGE_G[region],
                    shaking=shaking,
                )
                writer.recording(subject, sensor_set, test, rep, imu, gyr, acc)


def _shaking(rng, posture, segment: str, scale: float):
    """The heel strike's shaking of a sensor on ``segment`` ('shank_r', ...) in a walk (None
    where there is none: ``scale`` 0, not a leg segment, no heel strike).
    """
    kind, _, side = segment.partition("_")
    strikes = posture.strikes.get(side)
    if scale <= 0 or kind not in SHAKING_PEAK_G or strikes is None or not len(strikes):
        return None
    return heel_strike_shaking(rng, posture.t, strikes, scale * SHAKING_PEAK_G[kind])


#: writes :func:`kong_simulation` into a folder: ``simulate_kong(out, seed, n_subjects, options, name)``
simulate_kong = written(kong_simulation)
