"""``aceval apply``: body-frame copies of a dataset's recordings (d_body = R d_sensor).

The copies go into a new folder laid out like the dataset (same sheets, same relative paths,
same units), with ``applied_calibrations.tsv`` naming the calibration used for each IMU. The
input is only read.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from .dataset import R_COLUMNS, RECORDING_COLUMNS, Dataset
from .objectives import unflagged
from .safety import contained
from .writer import write_sheet

KEY = ["subject", "sensor_set", "imu"]


def chosen_calibrations(
    dataset: Dataset, calibrations: pd.DataFrame, method: str = "kong", test: str | None = None
) -> pd.DataFrame:
    """One valid calibration per (subject, set, IMU): ``method``, all repetitions (the largest
    ``n_reps``), from ``test`` or else the first test of calibrates.tsv that has one.
    """
    valid = calibrations[(calibrations["method"] == method) & unflagged(calibrations)]
    if test is not None:
        valid = valid[valid["test"] == test]
    order = {t: k for k, t in enumerate(dict.fromkeys(dataset.calibrates["test"]))}
    valid = valid.assign(_order=valid["test"].map(order).fillna(len(order)))
    valid = valid.sort_values(["_order", "n_reps"], ascending=[True, False])
    return valid.drop_duplicates(KEY).drop(columns="_order").reset_index(drop=True)


def apply_calibrations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    out: Path,
    method: str = "kong",
    test: str | None = None,
    progress=None,
) -> str:
    """Write the body-frame copies into the empty folder ``out``; returns a one-line summary."""
    chosen = chosen_calibrations(dataset, calibrations, method, test)
    rotations = {
        tuple(row[KEY]): row[R_COLUMNS].to_numpy(float).reshape(3, 3)
        for _, row in chosen.iterrows()
    }
    recordings = dataset.recordings
    keep = recordings[[key in rotations for key in zip(*(recordings[k] for k in KEY))]]
    for sheet in ("dataset.yaml", "tests.tsv", "calibrates.tsv", "subjects.tsv"):
        shutil.copy(dataset.root / sheet, out / sheet)
    imus = pd.read_csv(dataset.root / "imus.tsv", sep="\t", dtype=str)
    imus.assign(right_axis="+y").to_csv(
        out / "imus.tsv", sep="\t", index=False
    )  # body y points right
    keep.to_csv(out / "recordings.tsv", sep="\t", index=False)
    for done, row in enumerate(keep.to_dict("records"), start=1):
        R = rotations[(row["subject"], row["sensor_set"], row["imu"])]
        data = dataset.read_recording(row["path"])
        table = np.column_stack(
            [data.t, data.acc @ R.T / dataset.acc_scale, data.gyr @ R.T / dataset.gyr_scale]
        )
        target = contained(
            out, row["path"]
        )  # never outside the output folder, whatever the sheet says
        target.parent.mkdir(parents=True, exist_ok=True)
        pd.DataFrame(table, columns=RECORDING_COLUMNS).to_csv(
            target, index=False, float_format="%.6g"
        )
        if progress:
            progress(done, len(keep), "recordings written")
    columns = KEY + ["test", "repetitions", "method", *R_COLUMNS]
    write_sheet(out / "applied_calibrations.tsv", columns, chosen[columns].to_numpy().tolist())
    missing = recordings[KEY].drop_duplicates().shape[0] - len(rotations)
    return (
        f"aceval apply: {len(keep)} recordings of {len(rotations)} IMUs in the body frame ({method}); "
        f"{missing} IMU(s) without a valid {method} calibration left out"
    )
