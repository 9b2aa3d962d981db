"""A tiny valid dataset (1 subject, 1 set, 1 IMU, T0 + T1 x 2) written by hand, to break in tests."""

from pathlib import Path

import numpy as np
import yaml

from .synthetic import G, pitch_motion

HEADER = "t,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"


def write_csv(path: Path, acc_g: np.ndarray, gyr_dps: np.ndarray, fs: float = 100.0) -> None:
    t = np.arange(len(acc_g)) / fs
    np.savetxt(
        path,
        np.column_stack([t, acc_g, gyr_dps]),
        fmt="%.6g",
        delimiter=",",
        header=HEADER,
        comments="",
    )


def make_dataset(root: Path) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    meta = {
        "name": "mini",
        "sampling_rate_hz": 100,
        "units": {"acc": "g", "gyr": "deg/s"},
        "sensor_sets": ["frontal"],
        "acc_range_g": {"lower_body": 8},
    }
    (root / "dataset.yaml").write_text(yaml.safe_dump(meta))
    (root / "imus.tsv").write_text(
        "imu\tsegment\tside\tregion\tright_axis\nIMU4\tthigh\tright\tlower_body\t+y\n"
    )
    (root / "tests.tsv").write_text(
        "test\tkind\trepetitions\tdescription\nT0\tstatic\t1\tstand\nT1\tmotion\t2\tbow\n"
    )
    (root / "calibrates.tsv").write_text("test\timu\nT1\tIMU4\n")
    (root / "subjects.tsv").write_text("subject\theight_cm\nS1\t175\n")
    rows = ["subject\tsensor_set\ttest\trep\timu\tpath"]
    static = np.tile([0.0, 0.0, -1.0], (300, 1))
    write_csv(root / "s1_t0.csv", static, np.zeros((300, 3)))
    rows.append("S1\tfrontal\tT0\t1\tIMU4\ts1_t0.csv")
    for rep in (1, 2):
        acc = pitch_motion(n=400, seed=rep) / G
        # a real accelerometer's noise on its third axis too (2 mg, as the simulator's): a
        # channel that holds exactly 0 beside two noisy ones is a dead axis (a stuck channel)
        acc[:, 1] += np.random.default_rng(10 + rep).normal(0.0, 0.002, len(acc))
        gyr = np.column_stack(
            [np.zeros(400), 40 * np.sin(np.linspace(0, 4 * np.pi, 400)), np.zeros(400)]
        )
        write_csv(root / f"s1_t1_r{rep}.csv", acc, gyr)
        rows.append(f"S1\tfrontal\tT1\t{rep}\tIMU4\ts1_t1_r{rep}.csv")
    (root / "recordings.tsv").write_text("\n".join(rows) + "\n")
    return root
