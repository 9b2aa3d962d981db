"""How accurate is the walking-based vertical (the fallback z0 of recordings without quiet
standing: ``static=walking`` of `aceval import xsens --trials`, HuGaDB's T0w)? Not a speed
benchmark: docs/your_data.md quotes its numbers.

    python benchmarks/walking_vertical.py resources/kong_sim resources/neura resources/gaitmap_feet

Each argument is a dataset folder with quiet standing (static test T0) and walking (motion test
T6, first phase ``gait``). A copy is written whose T0 recordings are replaced by the walking
vertical of each T6 repetition (the repetition low-passed at 0.5 Hz,
:func:`aceval.importers.shared.mean_posture`); both are calibrated from all repetitions of T6
(`aceval calibrate --subsets full --tests T6`). Per segment it prints: the angle between the two
verticals (deg; median and largest over the IMUs) and, where the dataset has a ground truth, each
method's median error with the standing vertical and with the walking one.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.dataset import load_dataset
from aceval.data.writer import DatasetWriter
from aceval.importers.shared import mean_posture


def walking_copy(source: Path, target: Path) -> None:
    """``source`` with its T0 recordings replaced by the mean posture of each T6 repetition."""
    dataset = load_dataset(source)
    writer = DatasetWriter(target, {**dataset.meta, "units": {"acc": "m/s^2", "gyr": "rad/s"}})
    recordings = dataset.recordings
    walking = recordings[recordings["test"] == "T6"]
    for row in walking.itertuples():
        data = dataset.read_recording(row.path)
        for test, acc, gyr in (
            ("T0", mean_posture(data.acc, dataset.fs_hz), mean_posture(data.gyr, dataset.fs_hz)),
            ("T6", data.acc, data.gyr),
        ):
            writer.recording(row.subject, row.sensor_set, test, row.rep, row.imu, gyr, acc)
    writer.close()
    for sheet in ("imus.tsv", "calibrates.tsv", "subjects.tsv", "ground_truth.tsv"):
        if (source / sheet).exists():
            shutil.copy(source / sheet, target / sheet)
    tests = dataset.tests.reset_index()
    tests = tests[tests["test"].isin(["T0", "T6"])].copy()
    tests.loc[tests["test"] == "T0", "repetitions"] = tests.loc[
        tests["test"] == "T6", "repetitions"
    ].item()
    tests.to_csv(target / "tests.tsv", sep="\t", index=False)
    calibrates = pd.read_csv(target / "calibrates.tsv", sep="\t", dtype=str)
    calibrates[calibrates["test"] == "T6"].to_csv(target / "calibrates.tsv", sep="\t", index=False)


def calibrations(dataset: Path, out: Path) -> pd.DataFrame:
    subprocess.run(
        [sys.executable, "-m", "aceval", "calibrate", str(dataset), "--out", str(out),
         "--subsets", "full", "--tests", "T6", "--retest-k", "0"],
        check=True, capture_output=True,
    )  # fmt: skip
    table = pd.read_csv(out, dtype={"subject": str})
    return table


def compare(source: Path, scratch: Path) -> pd.DataFrame:
    walking = scratch / f"{source.name}_walking"
    walking_copy(source, walking)
    standing = calibrations(source, scratch / f"{source.name}_standing.csv")
    fallback = calibrations(walking, scratch / f"{source.name}_walking.csv")
    key = ["subject", "sensor_set", "imu", "segment", "method"]
    both = standing.merge(fallback, on=key, suffixes=("_standing", "_walking"))
    z_s = both[["r31_standing", "r32_standing", "r33_standing"]].to_numpy(float)
    z_w = both[["r31_walking", "r32_walking", "r33_walking"]].to_numpy(float)
    both["vertical_angle_deg"] = np.degrees(np.arccos(np.clip(np.sum(z_s * z_w, axis=1), -1, 1)))
    both["dataset"] = source.name
    return both


def main(folders: list[str]) -> None:
    pd.set_option("display.width", 200)
    with tempfile.TemporaryDirectory() as scratch:
        rows = pd.concat([compare(Path(f), Path(scratch)) for f in folders], ignore_index=True)
    kong = rows[rows["method"] == "kong"]
    print("Angle between the standing and the walking vertical (deg), per IMU:")
    print(
        kong.groupby(["dataset", "segment"])["vertical_angle_deg"]
        .agg(imus="size", median="median", largest="max")
        .round(1)
        .to_string()
    )
    if rows["error_deg_standing"].notna().any():
        print("\nMedian error against the truth (deg), standing vs walking vertical:")
        errors = rows.groupby(["dataset", "segment", "method"])[
            ["error_deg_standing", "error_deg_walking"]
        ].median()
        print(errors.dropna().round(1).unstack("method").to_string())


if __name__ == "__main__":
    main(sys.argv[1:])
