"""What a peer tool calibrates: the file interface of workflow/peers/peer_io.py (the peers' plan;
the plan of aceval's own methods is :mod:`aceval.calibrate.plan`).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import pandas as pd

from aceval.calibrate.table import (
    KEY,
    imu_identity,
)
from aceval.data.dataset import Dataset
from aceval.data.rotations import axis_vector


def calibration_plan(
    dataset: Dataset, summaries: pd.DataFrame, retest_k: int | None = 3, root=None
) -> dict:
    """What a peer tool calibrates, in the file interface of workflow/peers/peer_io.py: per (subject,
    set, IMU, motion test) that Kong's method calibrates, the static and motion recording files
    this pass found usable, the sample ranges of each motion file that aceval's methods read
    (``kept``: the trimmer's movement windows, clipped samples left out), the declared right axis
    as a vector, and the subsets of repetitions (all of them, then every subset of ``retest_k``);
    and (``static``) every IMU's quiet-standing files. Ricci's functional design has no
    calibration here (the peers calibrate from a vertical and one movement axis). ``root``: the
    dataset's folder as the peers find it (default: where it is read; a job writing the
    dataset reads it from its staging folder).
    """
    plan = {
        "dataset": str(Path(root or dataset.root).resolve()),
        "fs_hz": dataset.fs_hz,
        "acc_scale": dataset.acc_scale,
        "gyr_scale": dataset.gyr_scale,
        "calibrations": [],
        "static": [],
    }
    if dataset.functional_axes is not None or summaries.empty:
        return plan
    usable = summaries[summaries["flag"] == ""]
    paths = dataset.recordings.set_index(["subject", "sensor_set", "test", "rep", "imu"])["path"]
    static = usable[usable["kind"] == "static"]
    static_paths = {
        key: [paths[(*key[:2], t, r, key[2])] for t, r in zip(g["test"], g["rep"])]
        for key, g in static.groupby(KEY)
    }
    static_tests = {key: "+".join(sorted(set(g["test"]))) for key, g in static.groupby(KEY)}
    plan["static"] = [  # every IMU's quiet standing, whether a motion test calibrates it or not
        {
            **imu_identity(dataset, *key),
            "test": static_tests[key],
            "right_axis": axis_vector(dataset.right_axis(*key[1:])).tolist(),
            "paths": files,
        }
        for key, files in sorted(static_paths.items())
    ]
    motion = usable[usable["kind"] == "motion"]
    for (subject, sensor_set, imu, test), group in motion.groupby(KEY + ["test"], sort=True):
        if (subject, sensor_set, imu) not in static_paths:
            continue
        reps = sorted(int(r) for r in group["rep"])
        chosen = [reps]
        if retest_k and len(reps) > retest_k:
            chosen += [list(c) for c in itertools.combinations(reps, retest_k)]
        plan["calibrations"].append(
            {
                **imu_identity(dataset, subject, sensor_set, imu),
                "test": test,
                "right_axis": axis_vector(dataset.right_axis(sensor_set, imu)).tolist(),
                "static": static_paths[(subject, sensor_set, imu)],
                "reps": {str(r): paths[(subject, sensor_set, test, r, imu)] for r in reps},
                "kept": {str(r): _ranges(k) for r, k in zip(group["rep"], group["kept"])},
                "subsets": chosen,
            }
        )
    return plan


def _ranges(text) -> list[list[int]]:
    """'a:b;c:d' -> [[a, b], [c, d]] (half-open sample ranges)."""
    if not isinstance(text, str) or not text:
        return []
    return [[int(v) for v in part.split(":")] for part in text.split(";")]
