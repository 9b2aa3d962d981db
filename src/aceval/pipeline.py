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
from .objectives import correlation_3d, frontal_lateral_plan, full_sets, segment_pair_plan
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
    for rec in recordings.to_dict("records"):
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
        segment, side = dataset.imus.loc[(sensor_set, imu), ["segment", "side"]]
        for k, subset in enumerate(chosen):
            out.append({
                "subject": subject, "sensor_set": sensor_set, "imu": imu, "segment": segment, "side": side,
                "test": test,
                "repetitions": subset_label(subset), "n_reps": len(subset), "method": "kong",
                **dict(zip(R_COLUMNS, result.R[k].ravel())),
                "n_samples": int(result.n_samples[k]),
                "eig1": result.eigenvalues[k, 0], "eig2": result.eigenvalues[k, 1], "eig3": result.eigenvalues[k, 2],
                "planarity": result.planarity[k], "normal_ratio": result.normal_ratio[k],
                "normal_vertical_angle_deg": result.normal_vertical_angle_deg[k],
                "flag": result.flag[k], "error_deg": errors[k],
            })
    return pd.DataFrame(out)


CORRELATION_COLUMNS = ["objective", "subject", "sensor_set", "imu", "imu_b", "segment", "pair", "side",
                       "t_ex", "t_ap", "rep", "signal", "correlation", "flag"]


def correlations(dataset: Dataset, calibrations: pd.DataFrame, mode: str = "concatenated",
                 segment_pairs: dict | None = None) -> pd.DataFrame:
    """Kong Obj 1 and 2 (Eq. 7-10) for the subjects in ``calibrations``: full-set calibrations
    applied to every repetition of every motion test (T_ap), correlation per recording.

    Obj 1 (``objective='frontal_lateral'``, needs two sensor sets): the same IMU in both sets,
    ``sensor_set`` = 'set_a|set_b'; acceleration and angular velocity (``signal``). Obj 2
    (``'segment_pair'``): two segments of one set calibrated from the same T_ex, on the tests that
    ``segment_pairs`` names; acceleration. Recordings of different length are not correlated (they
    cannot be aligned sample by sample): such rows get ``flag='lengths_differ'``.
    """
    if calibrations.empty:
        return pd.DataFrame(columns=CORRELATION_COLUMNS)
    full = full_sets(calibrations)
    motion = [t for t in dataset.tests.index if dataset.tests.loc[t, "kind"] == "motion"]
    paths = dataset.recordings.set_index(["subject", "sensor_set", "test", "rep", "imu"])["path"].to_dict()
    reps: dict = {}
    for subject, sensor_set, test, rep, imu in paths:
        reps.setdefault((subject, sensor_set, test, imu), []).append(rep)
    cache: dict = {}

    def signals(key):
        if key not in cache:
            cache[key] = dataset.read_recording(paths[key]) if key in paths else None
        return cache[key]

    def correlate(base: dict, key_a, key_b, R_a, R_b, which):
        a, b = signals(key_a), signals(key_b)
        if a is None or b is None:
            return
        for signal in which:
            row = {**base, "rep": key_a[3], "signal": signal, "flag": ""}
            if len(a.t) != len(b.t):
                row.update(correlation=np.nan, flag="lengths_differ")
            else:
                row["correlation"] = correlation_3d(getattr(a, signal) @ R_a.T, getattr(b, signal) @ R_b.T, mode)
            rows.append(row)

    rows: list[dict] = []
    sensor_sets = list(dataset.meta["sensor_sets"])
    if len(sensor_sets) == 2 and len(full):
        for plan in frontal_lateral_plan(full, sensor_sets).to_dict("records"):
            base = {"objective": "frontal_lateral", "subject": plan["subject"], "sensor_set": "|".join(sensor_sets),
                    "imu": plan["imu"], "segment": plan["segment"], "side": plan["side"], "t_ex": plan["t_ex"]}
            for t_ap in motion:
                for rep in sorted(reps.get((plan["subject"], sensor_sets[0], t_ap, plan["imu"]), [])):
                    correlate({**base, "t_ap": t_ap},
                              (plan["subject"], sensor_sets[0], t_ap, rep, plan["imu"]),
                              (plan["subject"], sensor_sets[1], t_ap, rep, plan["imu"]),
                              plan["R_a"], plan["R_b"], ("acc", "gyr"))
    if segment_pairs and len(full):
        for plan in segment_pair_plan(full, segment_pairs).to_dict("records"):
            base = {"objective": "segment_pair", "subject": plan["subject"], "sensor_set": plan["sensor_set"],
                    "imu": plan["imu_a"], "imu_b": plan["imu_b"], "pair": plan["pair"], "side": plan["side"],
                    "t_ex": plan["t_ex"]}
            for t_ap in [t for t in plan["t_ap"] if t in motion]:
                for rep in sorted(reps.get((plan["subject"], plan["sensor_set"], t_ap, plan["imu_a"]), [])):
                    correlate({**base, "t_ap": t_ap},
                              (plan["subject"], plan["sensor_set"], t_ap, rep, plan["imu_a"]),
                              (plan["subject"], plan["sensor_set"], t_ap, rep, plan["imu_b"]),
                              plan["R_a"], plan["R_b"], ("acc",))
    return pd.DataFrame(rows, columns=CORRELATION_COLUMNS)
