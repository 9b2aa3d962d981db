"""Simulated rigid-box control (Kong Sec. 3, Fig. 7, Tables 4-5): both sets of 9 IMUs on two faces
of an aluminium box; rotation about one edge and random hand-held rotation, 5 repetitions each.
"""

from __future__ import annotations

import numpy as np

from aceval.data.units import SIMULATED_SUBJECTS
from aceval.data.writer import DatasetWriter, simulated_meta, write_sheet
from aceval.simulate.body import Placement, random_mount
from aceval.simulate.engine import (
    band_noise,
    each_times,
    euler_pitch_roll_yaw,
    fine_time,
    small_rotations,
)
from aceval.simulate.kong_dataset import ACC_RANGE_G, IMUS, SENSOR_META
from aceval.simulate.motion import bell
from aceval.simulate.options import SimOptions, sensor_signals
from aceval.simulate.simulation import Simulation, written

#: box size (m): Kong does not give it; a hand-held aluminium box of this size is assumed
BOX = np.array([0.30, 0.20, 0.15])
MISALIGNMENT_SD_DEG = 2.0  # sensors stuck on a machined flat face


def _placements() -> dict[str, dict[str, Placement]]:
    """3 x 3 grids of IMU1-9 on the front face (frontal set) and the right face (lateral set);
    box frame origin at the box centre, x forward, y right, z down.
    """
    lx, ly, lz = BOX / 2
    grid = [(a, b) for b in (-0.6, 0.0, 0.6) for a in (-0.6, 0.0, 0.6)]
    frontal, lateral = {}, {}
    for (imu, *_), (a, b) in zip(IMUS, grid):
        frontal[imu] = Placement("box", (lx, a * ly, b * lz), (1, 0, 0), (0, 0, -1))
        lateral[imu] = Placement("box", (a * lx, ly, b * lz), (0, 1, 0), (0, 0, -1))
    return {"frontal": frontal, "lateral": lateral}


def _edge_rotation(rng, fs):
    """Tilt about the bottom-back edge (parallel to y): front lifted ~60 deg and lowered."""
    rest, duration = rng.uniform(0.8, 1.2), rng.uniform(2.5, 3.5)
    t = fine_time(2 * rest + duration, fs)
    pitch = np.radians(rng.normal(60, 6)) * bell(t, rest, duration)
    R = euler_pitch_roll_yaw(pitch)
    edge = np.array([-BOX[0] / 2, 0.0, BOX[2] / 2])  # the hinge, in the box frame
    origin = -each_times(R, edge) + edge  # the edge stays where it is
    return t, R, origin, bell(t, rest, duration)


def _random_rotation(rng, fs):
    """Hand-held random rotation: +-30 deg RMS about each axis and +-5 cm translation, 0.2-0.8 Hz
    (voluntary hand rotation rarely exceeds 1 Hz).
    """
    rest, duration = 1.0, rng.uniform(6, 8)
    t = fine_time(2 * rest + duration, fs)
    envelope = np.clip((t - rest) / 0.5, 0, 1) * np.clip((rest + duration - t) / 0.5, 0, 1)
    envelope = envelope**2 * (3 - 2 * envelope)  # smooth on and off
    rotvec = (
        np.radians(30)
        * envelope[:, None]
        * np.column_stack([band_noise(rng, t, 0.2, 0.8) for _ in range(3)])
    )
    origin = (
        0.05 * envelope[:, None] * np.column_stack([band_noise(rng, t, 0.2, 0.8) for _ in range(3)])
    )
    return t, small_rotations(rotvec), origin, envelope


def _static(rng, fs):
    t = fine_time(10.0, fs)
    return t, euler_pitch_roll_yaw(np.zeros_like(t)), np.zeros((len(t), 3)), np.zeros_like(t)


TESTS = {
    "T0": (_static, "static", "box at rest on the table, 10 s"),
    "EDGE": (_edge_rotation, "motion", "rotation about one edge"),
    "RANDOM": (_random_rotation, "motion", "random hand-held rotation"),
}


def box_simulation(
    seed: int,
    n_subjects: int = SIMULATED_SUBJECTS["box"],
    options: SimOptions = SimOptions(),
    name: str = "box_sim",
) -> Simulation:
    """The SIMULATED rigid-box dataset (Kong Sec. 3) named ``name``, before it is written."""
    description = "the rigid aluminium box of Kong et al. 2016 Sec. 3"
    meta = simulated_meta(name, description, "box", seed, options.fs_hz, **SENSOR_META)
    placements = _placements()
    subjects = [f"BOX{k + 1}" for k in range(n_subjects)]
    repetitions = {test: 1 if test == "T0" else options.repetitions for test in TESTS}

    def sheets(writer: DatasetWriter) -> None:
        write_sheet(
            writer.root / "subjects.tsv",
            ["subject", "description"],
            [[s, "rigid aluminium box"] for s in subjects],
        )
        writer.protocol_sheets(
            {test: (kind, text) for test, (_, kind, text) in TESTS.items()},
            repetitions,
            {"EDGE": [imu for imu, *_ in IMUS]},
        )
        write_sheet(
            writer.root / "imus.tsv",
            ["imu", "sensor_set", "segment", "side", "region", "right_axis"],
            [
                [imu, sensor_set, "box", "center", region, placements[sensor_set][imu].right_axis()]
                for sensor_set in meta["sensor_sets"]
                for imu, _, _, region in IMUS
            ],
        )

    runs = [(test, rep) for test in TESTS for rep in range(1, repetitions[test] + 1)]

    def write_subject(k: int, writer: DatasetWriter) -> None:
        subject = subjects[k]
        rng = np.random.default_rng([seed, 1, k])
        mounts = {}
        for sensor_set in meta["sensor_sets"]:
            for imu, *_ in IMUS:
                mounts[sensor_set, imu] = random_mount(
                    rng, placements[sensor_set][imu], MISALIGNMENT_SD_DEG
                )
                writer.ground_truth(subject, sensor_set, imu, mounts[sensor_set, imu])
        for j, (test, rep) in enumerate(runs):
            run_rng = np.random.default_rng([seed, 2, k, j])
            _, R, origin, envelope = TESTS[test][0](run_rng, options.fs_hz)
            for sensor_set in meta["sensor_sets"]:
                for imu, _, _, region in IMUS:
                    gyr, acc = sensor_signals(
                        run_rng,
                        R,
                        origin,
                        mounts[sensor_set, imu],
                        placements[sensor_set][imu].position,
                        envelope,
                        0.0,
                        options,
                        ACC_RANGE_G[region],
                    )
                    writer.recording(subject, sensor_set, test, rep, imu, gyr, acc)

    return Simulation(meta, subjects, sheets, write_subject, "box_sim")


#: writes :func:`box_simulation` into a folder: ``simulate_box(out, seed, n_subjects, options, name)``
simulate_box = written(box_simulation)
