"""From a dataset to calibrations: recordings -> trimmed per-repetition summaries -> rotations.

Data flow one way (DESIGN.md section 2): each recording is read once and reduced to a summary
(static: the median specific force; motion: the scatter matrix ``sum a a^T`` and count of its
trimmed samples); every subset of repetitions is then calibrated from the summaries alone.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from .calibration.kong import KongLimits, kong_from_scatters, scatter, vertical_axis
from .dataset import Dataset, R_COLUMNS
from .errors import CalibrationError
from .rotations import axis_vector, error_angle_deg
from .segmentation import TrimParams, mask_to_ranges, movement_mask

SCATTER_COLUMNS = [f"s{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
KEY = ["subject", "sensor_set", "imu"]


def summarise_recordings(dataset: Dataset, subject: str | None = None,
                         trim: TrimParams = TrimParams()) -> pd.DataFrame:
    """One row per recording of ``subject`` (all subjects if None) that some analysis needs.

    Static tests: ``z0_x, z0_y, z0_z`` (Kong Eq. 2). Motion tests that may calibrate the IMU
    (calibrates.tsv): ``n_samples`` kept by the trimmer and the scatter ``s11..s33`` (m^2/s^4).
    A recording that cannot be used gets ``flag`` (the error code) and ``message`` naming the file.
    """
    recordings = dataset.recordings
    if subject is not None:
        recordings = recordings[recordings["subject"] == subject]
    static = set(dataset.static_tests())
    allowed = set(map(tuple, dataset.calibrates[["test", "imu"]].to_numpy()))
    rows = []
    for _, rec in recordings.iterrows():
        is_static = rec["test"] in static
        if not is_static and (rec["test"], rec["imu"]) not in allowed:
            continue
        row = {k: rec[k] for k in ["subject", "sensor_set", "test", "rep", "imu"]}
        row.update(kind="static" if is_static else "motion", flag="", message="")
        try:
            data = dataset.read_recording(rec["path"])
            if is_static:
                row.update(zip(["z0_x", "z0_y", "z0_z"], vertical_axis(data.acc)))
                row["n_samples"] = len(data.acc)
            else:
                mask = movement_mask(data.gyr, dataset.fs_hz, trim)
                kept = data.acc[mask]
                row["n_samples"] = int(mask.sum())
                row["n_segments"] = len(mask_to_ranges(mask))
                row.update(zip(SCATTER_COLUMNS, scatter(kept).ravel()))
        except CalibrationError as exc:
            row.update(flag=exc.code, message=f"{rec['path']}: {exc}")
        rows.append(row)
    return pd.DataFrame(rows)


def all_subsets(repetitions: list[int]) -> list[tuple[int, ...]]:
    """Every non-empty subset of the repetitions, by size then lexicographically (31 for 5)."""
    return [c for k in range(1, len(repetitions) + 1) for c in itertools.combinations(repetitions, k)]


def subset_label(subset) -> str:
    return "+".join(f"R{r}" for r in subset)


def calibrate(dataset: Dataset, summaries: pd.DataFrame, subsets: str = "all",
              limits: KongLimits = KongLimits()) -> pd.DataFrame:
    """Kong calibrations for every (subject, set, IMU, test) in ``summaries`` and every subset of
    its usable repetitions (``subsets='all'``) or all of them together (``'full'``).

    z0 comes from the IMU's static recording(s) (Kong Eq. 2; several are averaged). One row per
    calibration: key columns, ``repetitions`` ('R1+R3+R4'), ``n_reps``, r11..r33,
    diagnostics, ``flag`` ('' when valid) and, with ground truth, ``error_deg``.
    """
    static = summaries[(summaries["kind"] == "static") & (summaries["flag"] == "")]
    # several static recordings of one IMU (e.g. Ricci's 3 trials): their z0 averaged, renormalised
    z0 = static.groupby(KEY)[["z0_x", "z0_y", "z0_z"]].mean()
    z0 = z0.div(np.linalg.norm(z0.to_numpy(), axis=1), axis=0)
    motion = summaries[(summaries["kind"] == "motion") & (summaries["flag"] == "")]
    out = []
    for (subject, sensor_set, imu, test), group in motion.groupby(KEY + ["test"], sort=True):
        group = group.sort_values("rep")
        reps = [int(r) for r in group["rep"]]
        if (subject, sensor_set, imu) not in z0.index:
            continue  # no static test: validation reports it; nothing to calibrate from
        chosen = all_subsets(reps) if subsets == "all" else [tuple(reps)]
        index = {rep: k for k, rep in enumerate(reps)}
        result = kong_from_scatters(
            group[SCATTER_COLUMNS].to_numpy(float).reshape(-1, 3, 3),
            group["n_samples"].to_numpy(float),
            z0.loc[(subject, sensor_set, imu)].to_numpy(float),
            axis_vector(dataset.right_axis(sensor_set, imu)),
            [[index[r] for r in subset] for subset in chosen],
            limits=limits, strict=False,
        )
        truth = dataset.ground_truth_matrix(subject, sensor_set, imu)
        errors = error_angle_deg(result.R, truth) if truth is not None else np.full(len(chosen), np.nan)
        for k, subset in enumerate(chosen):
            out.append({
                "subject": subject, "sensor_set": sensor_set, "imu": imu, "test": test,
                "repetitions": subset_label(subset), "n_reps": len(subset), "method": "kong",
                **dict(zip(R_COLUMNS, result.R[k].ravel())),
                "n_samples": int(result.n_samples[k]),
                "eig1": result.eigenvalues[k, 0], "eig2": result.eigenvalues[k, 1], "eig3": result.eigenvalues[k, 2],
                "planarity": result.planarity[k], "normal_ratio": result.normal_ratio[k],
                "normal_vertical_angle_deg": result.normal_vertical_angle_deg[k],
                "flag": result.flag[k], "error_deg": errors[k],
            })
    return pd.DataFrame(out)
