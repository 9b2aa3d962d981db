"""Exports of two vendors that are not Xsens, written from signals (SI) for `aceval import table`:

* ``vendor_txt``: one tab-separated text file per sensor and trial (``<trial>_<sensor>.txt``):
  a few header lines, one of them "Acquisition frequency: 100 Hz", then ``PacketCounter
  Acc_X..Z Gyr_X..Z Mag_X..Z`` in m/s^2 and rad/s; beside each trial a JSON of its phases
  (``<trial>.json``: standing, walk, turn boundaries in seconds), as a lab keeps them;
* ``apdm_csv``: one comma-separated file per trial with every sensor in it (APDM's CSV export
  as OpenSim's APDMDataReader reads it): "Test Name:", "Sample Rate:, 100.0, Hz", then
  ``Time, <sensor>/Acceleration/X ... <sensor>/Angular Velocity/Z ...`` and a line of units.
"""

import json
from pathlib import Path

import numpy as np

#: the mapping a lab writes for each layout (docs/your_data.md holds the first)
MAPPINGS = {
    "vendor_txt": (
        "sensor_from: file_name          # one file per sensor: its ID ends the file name\n"
        "rate_line: 'Acquisition frequency: ([0-9.]+) ?Hz'\n"
        "counter: PacketCounter\n"
        "counter_wrap: 65536\n"
        "acc: {columns: [Acc_X, Acc_Y, Acc_Z], unit: m/s^2}\n"
        "gyr: {columns: [Gyr_X, Gyr_Y, Gyr_Z], unit: rad/s}\n"
    ),
    "apdm_csv": (
        "sensor_from: columns\n"
        "rate_line: 'Sample Rate:,\\s*([0-9.]+)'\n"
        "time: {column: Time, unit: s}\n"
        "units_line: true\n"
        "acc: {columns: ['{sensor}/Acceleration/X', '{sensor}/Acceleration/Y',\n"
        "                '{sensor}/Acceleration/Z'], unit: m/s^2}\n"
        "gyr: {columns: ['{sensor}/Angular Velocity/X', '{sensor}/Angular Velocity/Y',\n"
        "                '{sensor}/Angular Velocity/Z'], unit: rad/s}\n"
    ),
}


def vendor_txt(folder: Path, trial: str, sensors: dict, phases: dict, fs=100.0, counter=0,
               lose=None) -> None:  # fmt: skip
    """One trial: ``sensors`` {ID: (acc, gyr)}, ``phases`` {name: [start, end] or [[..], ..]}
    written as ``<trial>.json``; ``lose``: (ID, sample, count) packets left out of one file."""
    folder.mkdir(parents=True, exist_ok=True)
    for sensor, (acc, gyr) in sensors.items():
        n = len(acc)
        packets = (counter + np.arange(n)) % 65536
        mag = np.tile([0.2, 0.0, 0.4], (n, 1))
        table = np.column_stack([packets, acc, gyr, mag])
        if lose and lose[0] == sensor:
            table = np.delete(table, range(lose[1], lose[1] + lose[2]), axis=0)
        lines = [f"Device: VN-{sensor}", f"Acquisition frequency: {fs:g} Hz", "Sensor fusion: off",
                 "PacketCounter\tAcc_X\tAcc_Y\tAcc_Z\tGyr_X\tGyr_Y\tGyr_Z\tMag_X\tMag_Y\tMag_Z"]  # fmt: skip
        lines += ["\t".join([str(int(r[0]))] + [f"{v:.6f}" for v in r[1:]]) for r in table]
        (folder / f"{trial}_{sensor}.txt").write_text("\n".join(lines) + "\n")
    (folder / f"{trial}.json").write_text(json.dumps(phases))


def apdm_csv(folder: Path, trial: str, sensors: dict, fs=100.0) -> None:
    """One trial with every sensor in one CSV (module docstring)."""
    folder.mkdir(parents=True, exist_ok=True)
    n = min(len(acc) for acc, _ in sensors.values())
    labels, units, columns = ["Time"], ["s"], [np.arange(n) / fs]
    for sensor, (acc, gyr) in sensors.items():
        labels += [f"{sensor}/Acceleration/{a}" for a in "XYZ"]
        labels += [f"{sensor}/Angular Velocity/{a}" for a in "XYZ"]
        units += ["m/s^2"] * 3 + ["rad/s"] * 3
        columns += [*acc[:n].T, *gyr[:n].T]
    values = np.column_stack(columns)
    lines = [f"Test Name:,{trial}" + "," * (len(labels) - 2), f"Sample Rate:,{fs:g},Hz",
             ",".join(labels), ",".join(units)]  # fmt: skip
    lines += [",".join(f"{v:.6f}" for v in row) for row in values]
    (folder / f"{trial}.csv").write_text("\n".join(lines) + "\n")


#: the other lab's sensors: its own IDs for the simulated frontal set's lower back, shanks, feet
OTHER_SENSORS = {"LB01": "IMU3", "SR02": "IMU5", "FR03": "IMU6", "SL04": "IMU8", "FL05": "IMU9"}
#: each trial: 5 s standing, a walk, a 2 s turn on the spot, a walk (s)
STANDING_S, WALK_S, TURN_S = 5.0, 6.0, 2.0


def write_other_lab(exports: Path, simulated: Path) -> None:
    """The other lab's folder (docs/your_data.md, second walk-through): per subject two trials,
    each its standing, two straight walks of the simulated T6 repetitions and a turn between
    them (the standing's specific force, the body turning 180 deg about the vertical), one
    ``vendor_txt`` file per sensor and the trial's phases in ``<trial>.json``."""
    from aceval.data.dataset import load_dataset

    from .labexports import SUBJECTS

    dataset = load_dataset(simulated)
    rec = dataset.recordings[dataset.recordings["sensor_set"] == "frontal"]
    fs = dataset.fs_hz

    def read(subject, test, rep, imu):
        path = rec.query("subject == @subject and test == @test and rep == @rep and imu == @imu")
        data = dataset.read_recording(path["path"].item())
        return data.acc, data.gyr

    for k, (lab, sim) in enumerate(SUBJECTS.items()):
        for trial in (1, 2):
            sensors = {}
            for sensor, imu in OTHER_SENSORS.items():
                stand_acc, stand_gyr = read(sim, "T0", 1, imu)
                up = stand_acc.mean(axis=0) / np.linalg.norm(stand_acc.mean(axis=0))
                n_turn = int(TURN_S * fs)
                turn_gyr = np.outer(np.full(n_turn, np.pi / TURN_S), up)  # 180 deg about up
                parts = [(stand_acc[: int(STANDING_S * fs)], stand_gyr[: int(STANDING_S * fs)])]
                for walk in (2 * trial - 1, 2 * trial):
                    acc, gyr = read(sim, "T6", walk, imu)
                    parts.append((acc[: int(WALK_S * fs)], gyr[: int(WALK_S * fs)]))
                    if walk == 2 * trial - 1:
                        parts.append((stand_acc[:n_turn], turn_gyr + stand_gyr[:n_turn]))
                sensors[sensor] = (
                    np.vstack([a for a, _ in parts]),
                    np.vstack([g for _, g in parts]),
                )
            first_walk = STANDING_S + WALK_S
            phases = {
                "standing": [0.0, STANDING_S],
                "walk": [
                    [STANDING_S, first_walk],
                    [first_walk + TURN_S, first_walk + TURN_S + WALK_S],
                ],
                "turn": [[first_walk, first_walk + TURN_S]],
            }
            vendor_txt(exports / lab, f"trial_{trial:02d}", sensors, phases, fs, 1000 * (k + 1))


def other_truth(simulated: Path):
    """The simulation's true sensor-to-body rotations under the other lab's subjects and IMU names
    (the sensors.tsv of docs/your_data.md's second walk-through names them by place)."""
    import pandas as pd

    from .labexports import SUBJECTS

    names = {"IMU3": "lower_back", "IMU5": "shank_r", "IMU6": "foot_r", "IMU8": "shank_l",
             "IMU9": "foot_l"}  # fmt: skip
    table = pd.read_csv(simulated / "ground_truth.tsv", sep="\t", dtype={"subject": str})
    table = table[(table["sensor_set"] == "frontal") & table["imu"].isin(names)]
    subjects = {sim: lab for lab, sim in SUBJECTS.items()}
    return table.assign(imu=table["imu"].map(names), subject=table["subject"].map(subjects)).drop(
        columns="sensor_set"
    )
