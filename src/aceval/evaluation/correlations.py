"""Kong Objectives 1 and 2 (Eq. 7-10): the correlation of two time-aligned recordings after their
calibrations, from the pair moments of the one pass (nothing reads the samples again).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.calibrate.table import full_sets
from aceval.data.dataset import Dataset
from aceval.evaluation.objectives import (
    CORRELATION_MODES,
    correlation_from_moments,
    frontal_lateral_plan,
    segment_pair_plan,
)

CORRELATION_COLUMNS = [
    "objective",
    "subject",
    "sensor_set",
    "imu",
    "imu_b",
    "segment",
    "pair",
    "side",
    "t_ex",
    "t_ap",
    "rep",
    "signal",
    "mode",
    "heading_error_deg",
    "lag_samples",
    "n_samples",
    "correlation",
    "flag",
]
#: heading errors (deg, about body z, imposed on the second set's calibration) at which the Obj 1
#: correlation is also computed, for every mode: how large an error the correlation can detect
SENSITIVITY_HEADINGS_DEG = (0.0, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0)


def correlations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    pairs: pd.DataFrame,
    mode: str = "concatenated",
    segment_pairs: dict | None = None,
    headings_deg: tuple = SENSITIVITY_HEADINGS_DEG,
) -> pd.DataFrame:
    """Kong Obj 1 and 2 (Eq. 7-10): full-set calibrations applied to every repetition of every
    motion test (T_ap), one correlation per recording pair, from the pair moments of the one pass
    (``pairs``, :func:`aceval.signals.reduction.reduce_recordings`; already aligned in time, Kong Sec. 2.3).

    Obj 1 (``objective='frontal_lateral'``, needs two sensor sets): the same IMU in both sets,
    ``sensor_set`` = 'set_a|set_b'; acceleration and angular velocity (``signal``). Obj 2
    (``'segment_pair'``): two segments of one set calibrated from the same T_ex, on the tests that
    ``segment_pairs`` names; acceleration. ``mode`` as in :func:`aceval.evaluation.objectives.correlation_3d`
    (``per_axis_moving``: over the samples either sensor's trimmer keeps as movement). A pair
    overlapping too little is flagged ``no_overlap`` with no correlation.

    Also, for Obj 1's acceleration (``objective='frontal_lateral_sensitivity'``): the correlation in
    every mode with the second set's calibration turned by each heading error in ``headings_deg``
    about body z, to measure what size of calibration error the correlation can detect; one row
    per unit, mode and heading (the mean over the repetitions).
    """
    if calibrations.empty or pairs.empty:
        return pd.DataFrame(columns=CORRELATION_COLUMNS)
    full = full_sets(calibrations)
    motion = [t for t in dataset.tests.index if dataset.tests.loc[t, "kind"] == "motion"]
    # the pair moments by (objective, subject, set, IMU, IMU b, test, rep, signal, window)
    keys = ["objective", "subject", "sensor_set", "imu", "imu_b", "test", "rep", "signal", "window"]
    lookup = pairs[keys].assign(imu_b=pairs["imu_b"].fillna(""), rep=pairs["rep"].astype(int))
    index = {key: k for k, key in enumerate(lookup.itertuples(index=False, name=None))}
    reps = lookup.groupby(keys[:4] + ["test"])["rep"].unique().to_dict()
    # each pair's alignment as arrays, read by position (not a pandas row per pair)
    lags, n_overlaps = pairs["lag_samples"].to_numpy(), pairs["n_overlap"].to_numpy()
    pair_flags = pairs["flag"].to_numpy(dtype=object)
    turns = {h: Rotation.from_euler("z", h, degrees=True).as_matrix() for h in headings_deg}
    rows: list[dict] = []
    wanted: list[tuple] = []  # (row, pair row, R_a, R_b, mode)

    def window(m: str) -> str:
        return "moving" if m == "per_axis_moving" else "all"

    def correlate(base, objective, sensor_set, imu, imu_b, t_ap, R_a, R_b, signals, sensitivity):
        unit = (objective, base["subject"], sensor_set, imu)
        for rep in sorted(int(r) for r in reps.get((*unit, t_ap), [])):
            for signal in signals:
                key = (*unit, imu_b, t_ap, rep, signal)
                k = index[(*key, window(mode))]
                row = {**base, "t_ap": t_ap, "rep": rep, "signal": signal, "mode": mode,
                       "heading_error_deg": 0.0, "lag_samples": int(lags[k]),
                       "n_samples": int(n_overlaps[k]), "correlation": np.nan,
                       "flag": pair_flags[k] if isinstance(pair_flags[k], str) else ""}  # fmt: skip
                rows.append(row)
                if row["flag"]:
                    continue
                wanted.append((len(rows) - 1, k, R_a, R_b, mode))
                if sensitivity and signal == "acc":
                    for heading, turn in turns.items():
                        for m in CORRELATION_MODES:
                            rows.append({**row, "objective": "frontal_lateral_sensitivity",
                                         "mode": m, "heading_error_deg": heading})  # fmt: skip
                            wanted.append(
                                (len(rows) - 1, index[(*key, window(m))], R_a, turn @ R_b, m)
                            )

    sensor_sets = list(dataset.meta["sensor_sets"])
    if len(sensor_sets) == 2 and len(full):
        for plan in frontal_lateral_plan(full, sensor_sets).to_dict("records"):
            base = {"objective": "frontal_lateral", "subject": plan["subject"],
                    "sensor_set": "|".join(sensor_sets), "imu": plan["imu"],
                    "segment": plan["segment"], "side": plan["side"], "t_ex": plan["t_ex"]}  # fmt: skip
            for t_ap in motion:
                correlate(base, "frontal_lateral", base["sensor_set"], plan["imu"], "", t_ap,
                          plan["R_a"], plan["R_b"], ("acc", "gyr"), bool(headings_deg))  # fmt: skip
    if segment_pairs and len(full):
        for plan in segment_pair_plan(full, segment_pairs).to_dict("records"):
            base = {"objective": "segment_pair", "subject": plan["subject"],
                    "sensor_set": plan["sensor_set"], "imu": plan["imu_a"], "imu_b": plan["imu_b"],
                    "pair": plan["pair"], "side": plan["side"], "t_ex": plan["t_ex"]}  # fmt: skip
            for t_ap in [t for t in plan["t_ap"] if t in motion]:
                correlate(base, "segment_pair", plan["sensor_set"], plan["imu_a"], plan["imu_b"],
                          t_ap, plan["R_a"], plan["R_b"], ("acc",), False)  # fmt: skip
    table = pd.DataFrame(rows, columns=CORRELATION_COLUMNS)
    for m in {w[4] for w in wanted}:
        chosen = [w for w in wanted if w[4] == m]
        values = correlation_from_moments(
            pairs.iloc[[w[1] for w in chosen]],
            np.array([w[2] for w in chosen]),
            np.array([w[3] for w in chosen]),
            m,
        )
        table.loc[[w[0] for w in chosen], "correlation"] = values
    return _sensitivity_unit_means(table)


def _sensitivity_unit_means(table: pd.DataFrame) -> pd.DataFrame:
    """The sensitivity rows as what :func:`aceval.report.kong2016.correlation_sensitivity` reads: one per
    unit (subject x IMU x T_ex x T_ap), mode and heading error, the mean over the repetitions
    (``rep``, lag and sample count left empty): five times fewer rows, the same numbers.
    """
    sensitivity = (table["objective"] == "frontal_lateral_sensitivity").to_numpy()
    if not sensitivity.any():
        return table
    per_rep = ["rep", "lag_samples", "n_samples", "correlation", "flag"]
    keys = [c for c in CORRELATION_COLUMNS if c not in per_rep]
    means = (
        table[sensitivity]
        .groupby(keys, sort=False, dropna=False)["correlation"]
        .mean()
        .reset_index()
        .assign(flag="")
    )
    return pd.concat([table[~sensitivity], means], ignore_index=True)[CORRELATION_COLUMNS]
