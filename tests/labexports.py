"""A lab's folder of Xsens MT Manager exports, written from a SIMULATED Kong dataset: three
subjects walking (T6 repetitions as trials), five sensors each (lower back, shanks, feet), in the
variants labs send (docs/your_data.md imports exactly this folder):

* P01: a separate standing trial; tab-separated MT Manager 2019 exports (header blocks with the
  DeviceId, no '// Update Rate' line, SampleTimeFine filled: the rate is derived from it);
* P02: 5 s of quiet standing at the start of each walking trial; comma-separated exports with the
  '// Update Rate' line and an empty SampleTimeFine (older MT Manager);
* P03: no quiet standing at all; tab-separated, no rate line, empty SampleTimeFine (the rate
  must be given: --rate); in its second trial one sensor has a sample fewer than the others.

``write_lab`` returns where the simulation's truth is, to compare the calibrations with.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.dataset import load_dataset

from .runner import aceval

#: the lab's sensors: (sensor ID, the lab's name, Kong segment, side, simulated IMU of the frontal
#: set); the lumbar sensor keeps the lab's name, mapped to Kong's segment 'waist'
SENSORS = [
    ("00B4A101", "lower_back", "waist", "center", "IMU3"),
    ("00B4A102", "shank_r", "shank", "right", "IMU5"),
    ("00B4A103", "foot_r", "foot", "right", "IMU6"),
    ("00B4A104", "shank_l", "shank", "left", "IMU8"),
    ("00B4A105", "foot_l", "foot", "left", "IMU9"),
]
SUBJECTS = {"P01": "S1", "P02": "S2", "P03": "S3"}
REPETITIONS = 3
STANDING_S = 5.0
COLUMNS = ["PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z"]


def simulate(root: Path, repetitions: int = REPETITIONS) -> Path:
    """The simulated Kong dataset the exports are cut from (3 subjects, 3 repetitions)."""
    out = root / "simulated"
    options = ["--seed", 7, "--subjects", 3, "--repetitions", repetitions]
    simulated = aceval("simulate", "kong", "--out", out, *options)
    assert simulated.code == 0, simulated.err[-3000:]
    return out


def write_lab(exports: Path, simulated: Path) -> None:
    """The lab's export folder at ``exports`` (one subfolder per subject)."""
    dataset = load_dataset(simulated)
    rec = dataset.recordings[dataset.recordings["sensor_set"] == "frontal"]

    def signals(subject, test, rep):
        rows = rec[(rec["subject"] == subject) & (rec["test"] == test) & (rec["rep"] == rep)]
        out = {}
        for sensor_id, _, _, _, imu in SENSORS:
            data = dataset.read_recording(rows.loc[rows["imu"] == imu, "path"].item())
            out[sensor_id] = (data.acc, data.gyr)
        return out

    counter = 1000
    for lab, sim in SUBJECTS.items():
        folder = exports / lab
        folder.mkdir(parents=True)
        standing = signals(sim, "T0", 1)
        trials = []
        if lab == "P01":
            trials.append(("stand", standing))
        for rep in range(1, REPETITIONS + 1):
            walk = signals(sim, "T6", rep)
            if lab == "P02":  # the first 5 s of the quiet standing, then the walk
                n = int(STANDING_S * dataset.fs_hz)
                walk = {
                    s: (np.vstack([standing[s][0][:n], a]), np.vstack([standing[s][1][:n], g]))
                    for s, (a, g) in walk.items()
                }
            trials.append((f"walk_{rep:02d}", walk))
        for name, sensors in trials:
            for k, (sensor_id, (acc, gyr)) in enumerate(sensors.items()):
                short = lab == "P03" and name == "walk_02" and k == 2  # a sample fewer
                if short:
                    acc, gyr = acc[:-1], gyr[:-1]
                path = folder / f"{name}-000_{sensor_id}.txt"
                export(path, sensor_id, counter, acc, gyr, STYLES[lab])
            counter += 5000


#: each subject's export style (MT Manager versions in use)
STYLES = {"P01": "2019", "P02": "comma", "P03": "bare"}


def export(path: Path, sensor_id: str, counter: int, acc, gyr, style: str) -> None:
    """One MT Manager text export (SI): ``2019`` (tab-separated, header blocks with the DeviceId,
    SampleTimeFine ticks that wrap at 2^32, no rate line), ``comma`` (the '// Update Rate' line,
    empty SampleTimeFine) or ``bare`` (tab-separated, no rate anywhere)."""
    n = len(acc)
    table = pd.DataFrame(np.column_stack([acc, gyr]), columns=COLUMNS[2:]).map(lambda v: f"{v:.6f}")
    table.insert(0, "SampleTimeFine", [str(4_294_960_000 + 100 * i) if style == "2019" else ""
                                       for i in range(n)])  # fmt: skip
    table.insert(0, "PacketCounter", [str((counter + i) % 65536) for i in range(n)])
    if style == "comma":
        header = ["// Start Time: Unknown", "// Update Rate: 100.0Hz",
                  "// Filter Profile: human (46.1)", "// Firmware Version: 4.3.4"]  # fmt: skip
        body = table.to_csv(index=False, lineterminator="\n")
    else:
        header = ["// General information:", "//  MT Manager version: 2019.2.0",
                  "// Device information:", f"//  DeviceId: {sensor_id}",
                  "//  ProductCode: MTW2-3A7G6", "// Device settings:",
                  "//  Filter Profile: human (46.1)"]  # fmt: skip
        body = table.to_csv(sep="\t", index=False, lineterminator="\t\n")
    path.write_text("\n".join(header) + "\n" + body)


def truth(simulated: Path) -> pd.DataFrame:
    """The simulation's true sensor-to-body rotations under the lab's names (subject, imu)."""
    table = pd.read_csv(simulated / "ground_truth.tsv", sep="\t", dtype={"subject": str})
    table = table[table["sensor_set"] == "frontal"]
    names = {imu: name for _, name, _, _, imu in SENSORS}
    subjects = {sim: lab for lab, sim in SUBJECTS.items()}
    table = table[table["imu"].isin(names)].assign(
        imu=lambda t: t["imu"].map(names), subject=lambda t: t["subject"].map(subjects)
    )
    return table.drop(columns="sensor_set")
