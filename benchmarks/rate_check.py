"""How often the check of a rate given by hand (aceval.signals.rate_check) fires on recordings read
at their right rate, and how often it catches a wrong one (not a speed benchmark: config/README.md
quotes its numbers).

    python benchmarks/rate_check.py [SIMULATED_DATASET ...]

The real recordings are read whole, as a lab's import reads a trial, from ../shared/data: the
NeuRA walk and its static trial (MT Manager exports, 100 Hz), qmt's full-body recording (100 Hz),
gaitmap's feet (204.8 Hz) and HuGaDB's 19 files (58 Hz, the dataset's totals give 56-60 Hz: its
own rate is uncertain by a few per cent; gyroscopes the importer leaves out as corrupted are left
out here too). Each SIMULATED_DATASET (e.g. one written by ``aceval simulate kong``) adds one
trial per subject, test and repetition (its frontal set), and per subject one trial of its
standing, walking repetitions 1 and 2 and a 2 s turn on the spot between them, as a lab records
(tests/tableexports.py's layout). Each trial is then read at its rate (a flag is a false alarm)
and at 0.5, 2, 0.6 and 1/0.6 times it (50 Hz for 100, 200 for 100, 60 for 100, 100 for 60: a
flag is a catch); a trial whose sensors give no evidence (no periodic movement) is counted as
not judged.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.importers.lab_trials import RATE_MISMATCH
from aceval.signals.rate_check import implied_rate

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
FACTORS = {"right": 1.0, "x0.5": 0.5, "x2": 2.0, "x0.6": 0.6, "x1/0.6": 1 / 0.6}


def real_trials():
    """(dataset, trial, fs, [(acc, gyr)]) of the real recordings, read whole."""
    from aceval.importers import gaitmap, hugadb, qmt
    from aceval.importers.xsens import read_mt_export

    for folder in ("rawimu", "static_S01"):
        signals = {}
        for path in sorted((DATA / "neura_gaittoolbox" / folder).glob("*.txt")):
            _, values = read_mt_export(path)
            acc = values[["Acc_X", "Acc_Y", "Acc_Z"]].to_numpy(float)
            signals[acc.tobytes()] = (acc, values[["Gyr_X", "Gyr_Y", "Gyr_Z"]].to_numpy(float))
        yield "neura", folder, 100.0, list(signals.values())  # duplicates once
    _, structs = qmt.read_qmt(DATA / "qmt_fullbody" / "full_body_example_data.mat")
    yield "qmt", "full body", 100.0, list(structs.values())
    table = gaitmap.read_two_header_csv(DATA / "gaitmap_feet" / "imu_sample_not_rotated.csv")
    feet = [
        (table[s][["acc_x", "acc_y", "acc_z"]].to_numpy(float),
         np.radians(table[s][["gyr_x", "gyr_y", "gyr_z"]].to_numpy(float)))
        for s in ("left_sensor", "right_sensor")
    ]  # fmt: skip
    yield "gaitmap", "feet", 204.8, feet
    for path in sorted((DATA / "hugadb").glob("*.txt")):
        data = hugadb.read_hugadb(path)
        kept = [
            (data.acc(s), data.gyr(s))
            for s in data.counts
            if not hugadb.gyro_fault(data.counts[s][1])
        ]
        if kept:
            yield "hugadb", path.stem, hugadb.SAMPLING_RATE_HZ, kept


def simulated_trials(root: Path):
    """(dataset, trial, fs, [(acc, gyr)]) of a simulated dataset (module docstring)."""
    from aceval.data.dataset import load_dataset

    dataset = load_dataset(root)
    frontal = dataset.recordings[dataset.recordings["sensor_set"] == dataset.meta["sensor_sets"][0]]
    fs = dataset.fs_hz

    def read(rows):
        return [
            (lambda r: (r.acc, r.gyr))(dataset.read_recording(p))
            for p in rows.sort_values("imu")["path"]
        ]

    for (subject, test, rep), rows in frontal.groupby(["subject", "test", "rep"]):
        yield root.name, f"{subject} {test} R{rep}", fs, read(rows)
    for subject, rows in frontal.groupby("subject"):
        standing = read(rows[rows["test"] == "T0"].query("rep == 1"))
        walks = [read(rows[(rows["test"] == "T6") & (rows["rep"] == r)]) for r in (1, 2)]
        if not all(walks):
            continue
        turn = int(2 * fs)
        trial = []
        for (s_acc, s_gyr), (a1, g1), (a2, g2) in zip(standing, *walks):
            up = s_acc.mean(axis=0) / np.linalg.norm(s_acc.mean(axis=0))
            turning = np.outer(np.full(turn, np.pi / 2), up) + s_gyr[:turn]
            trial.append(
                (np.vstack([s_acc[: 5 * int(fs)], a1, s_acc[:turn], a2]),
                 np.vstack([s_gyr[: 5 * int(fs)], g1, turning, g2]))
            )  # fmt: skip
        yield root.name, f"{subject} lab trial", fs, trial


def main(simulated: list[str]) -> None:
    rows = []
    trials = [*real_trials()] + [t for root in simulated for t in simulated_trials(Path(root))]
    for dataset, trial, fs, signals in trials:
        for name, factor in FACTORS.items():
            evidence = implied_rate(signals, fs * factor)
            ratio = evidence.implied_hz / (fs * factor)
            judged = np.isfinite(ratio)
            flagged = judged and max(ratio, 1 / ratio) > RATE_MISMATCH
            rows.append({"dataset": dataset, "trial": trial, "declared": name, "judged": judged,
                         "flagged": flagged, "implied_over_true": evidence.implied_hz / fs,
                         "sensors": evidence.n_sensors})  # fmt: skip
    table = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    counts = table.groupby(["dataset", "declared"]).agg(
        trials=("trial", "size"), judged=("judged", "sum"), flagged=("flagged", "sum")
    )
    print(counts.unstack("declared").to_string())
    right = table[(table["declared"] == "right") & table["judged"]]
    print("\nimplied / true rate at the right rate, per dataset (judged trials):")
    print(right.groupby("dataset")["implied_over_true"].describe()[["count", "min", "50%", "max"]])
    wrong = table[(table["declared"] != "right") & table["judged"]]
    print(f"\nall: false alarms {int(right['flagged'].sum())} of {len(right)} judged trials; "
          f"catches {int(wrong['flagged'].sum())} of {len(wrong)} judged wrong-rate trials; "
          f"not judged {int((~table['judged']).sum())} of {len(table)}")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
