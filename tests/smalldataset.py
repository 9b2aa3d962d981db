"""A small simulated dataset to break in tests: one subject, three repetitions, the frontal chest,
right thigh and right shank IMUs (Kong protocol; every test that calibrates them)."""

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from .runner import aceval

IMUS = ("IMU2", "IMU4", "IMU5")
SENSOR_SET = "frontal"


def simulate_small(
    root: Path, imus=IMUS, every_recording: bool = False, repetitions: int = 3
) -> Path:
    """The small dataset at ``root``: ``imus`` of the frontal set; only the recordings of the tests
    that calibrate each IMU, or (``every_recording``) every IMU in every test, as a lab records.
    """
    full = root.parent / f"{root.name}_full"
    # a lab's export (CSV): the bad-input tests edit its text
    options = ["--subjects", 1, "--repetitions", repetitions, "--seed", 3, "--format", "csv"]
    simulated = aceval("simulate", "kong", "--out", full, *options)
    assert simulated.code == 0, simulated.err[-3000:]
    root.mkdir(parents=True)
    for name in ("tests.tsv", "subjects.tsv"):
        shutil.copy(full / name, root / name)
    meta = yaml.safe_load((full / "dataset.yaml").read_text())
    (root / "dataset.yaml").write_text(
        yaml.safe_dump({**meta, "sensor_sets": [SENSOR_SET]}, sort_keys=False)
    )

    def sheet(name, keep):
        table = pd.read_csv(full / name, sep="\t", dtype=str)
        table = table[keep(table)]
        table.to_csv(root / name, sep="\t", index=False)
        return table

    ours = lambda t: t["imu"].isin(imus) & (t.get("sensor_set", SENSOR_SET) == SENSOR_SET)  # noqa: E731
    sheet("imus.tsv", ours)
    sheet("ground_truth.tsv", ours)
    calibrates = sheet("calibrates.tsv", lambda t: t["imu"].isin(imus))
    allowed = set(map(tuple, calibrates[["test", "imu"]].to_numpy()))
    recordings = sheet(
        "recordings.tsv",
        lambda t: (
            ours(t)
            & np.array(
                [
                    every_recording or test == "T0" or (test, imu) in allowed
                    for test, imu in zip(t["test"], t["imu"])
                ]
            )
        ),
    )
    for path in recordings["path"]:
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(full / path, root / path)
    shutil.rmtree(full)
    return root
