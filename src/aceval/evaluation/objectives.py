"""Kong et al. 2016 Objectives 1-5 (Section 2.4.2) as pure functions on tidy tables.

Input is the calibration table of :func:`aceval.calibrate.pipeline.calibrate` (one row per subject, sensor
set, IMU, test and subset of repetitions, with r11..r33 and ``flag``). Flagged calibrations are
left out (Obj 3-4 keep those flagged only ``unstable``: the spread they measure); the tables
count what is left (``n``).

* Obj 1 / Obj 2: correlation of calibrated 3-axis signals (Eq. 7-10), :func:`correlation_3d`;
  which calibrations are compared is planned here, the signals are read in :mod:`aceval.calibrate.pipeline`.
* Obj 3: "incremental" (Eq. 11-12) and "to last" (Eq. 13, for every subset size, not only 1).
* Obj 4: test-retest between distinct subsets of ``k`` repetitions (Eq. 15, k = 3).
* Obj 5: cross-test, full sets of two tests that both calibrate the IMU (Eq. 16).

Every comparison of two calibrations is the angle of ``R_a R_b^T`` in axis-angle form (Eq. 14),
:func:`aceval.data.rotations.error_angle_deg`, with the share of that rotation about the body vertical.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from aceval.calibrate.table import CALIBRATION_KEY, full_sets, matrices, parse_subset, spread_usable
from aceval.data.contract import R_COLUMNS
from aceval.data.rotations import error_angle_deg, vertical_share

CORRELATION_MODES = ("concatenated", "per_axis", "per_axis_moving")
#: Kong's segments from head to foot: the order of every table's rows
SEGMENT_ORDER = ["head", "chest", "waist", "thigh", "shank", "foot"]
#: columns of every angle row
ANGLE_COLUMNS = [
    "comparison",
    "subject",
    "sensor_set",
    "imu",
    "segment",
    "side",
    "test",
    "k",
    "calibration_a",
    "calibration_b",
    "error_angle_deg",
    "vertical_share",
]


def correlation_3d(
    a: np.ndarray, b: np.ndarray, mode: str = "concatenated", moving: np.ndarray | None = None
) -> float:
    """Pearson correlation of two 3-axis signals of shape (N, 3) (Kong Eq. 8 and 10).

    ``concatenated``: r of the 3N values (x_1..x_N, y_1..y_N, z_1..z_N) of each signal, so the
    different mean levels of the axes (gravity) count as shared variation. ``per_axis``: the mean
    of the x, y and z correlations; an axis that is constant in either signal has no correlation
    and is left out (NaN if all are). ``per_axis_moving``: ``per_axis`` over the moving samples
    only (``moving``, a boolean (N,) mask, e.g. the trimmer's): rest periods are left out and each
    axis's mean, the gravity it carries, is removed by the correlation itself, so what remains is
    the motion (the most sensitive to a heading error: docs/objectives.md).
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(
            f"expected two (N, 3) signals of the same shape, got {a.shape} and {b.shape}"
        )
    if mode == "concatenated":
        x, y = a.T.ravel(), b.T.ravel()
        if np.std(x) == 0 or np.std(y) == 0:
            return float("nan")
        return float(np.corrcoef(x, y)[0, 1])
    if mode == "per_axis_moving":
        if moving is None:
            raise ValueError("correlation mode per_axis_moving needs the moving samples (moving=)")
        a, b = a[moving], b[moving]
        mode = "per_axis"
    if mode == "per_axis":
        values = [
            np.corrcoef(a[:, k], b[:, k])[0, 1]
            for k in range(3)
            if len(a) > 1 and np.std(a[:, k]) > 0 and np.std(b[:, k]) > 0
        ]
        return float(np.mean(values)) if values else float("nan")
    raise ValueError(f"correlation mode {mode!r} is not one of {', '.join(CORRELATION_MODES)}")


def correlation_from_moments(
    pairs: pd.DataFrame, R_a: np.ndarray, R_b: np.ndarray, mode: str = "concatenated"
) -> np.ndarray:
    """:func:`correlation_3d` of ``R_a a`` and ``R_b b`` from the moments of each recording pair
    (rows of :data:`aceval.signals.reduction.PAIR_COLUMNS`: ``n``, means ``ma_*``, ``mb_*``, centred
    scatters ``caa*``, ``cbb*`` and cross-moment ``cab*``), for (K, 3, 3) stacks of calibrations:
    sum(x y) = trace(R_a C_ab R_b^T) + n M_a . M_b with M = R m, so any calibration costs O(1).

    ``concatenated``: r of the 3n values of each signal (spread of the axes' means included);
    ``per_axis`` (and ``per_axis_moving``, whose rows hold the moving samples' moments): the mean
    of the axes' correlations, an axis constant in either signal left out (NaN if all are).
    """
    from aceval.signals.reduction import C_AA, C_AB, C_BB, MEAN_A, MEAN_B

    n = pairs["n"].to_numpy(float)
    C_aa = pairs[C_AA].to_numpy(float).reshape(-1, 3, 3)
    C_bb = pairs[C_BB].to_numpy(float).reshape(-1, 3, 3)
    C_ab = pairs[C_AB].to_numpy(float).reshape(-1, 3, 3)
    M_a = np.einsum("kij,kj->ki", R_a, pairs[MEAN_A].to_numpy(float))
    M_b = np.einsum("kij,kj->ki", R_b, pairs[MEAN_B].to_numpy(float))
    V_a = np.einsum("kij,kjl,kml->kim", R_a, C_aa, R_a)  # R_a C_aa R_a^T
    V_b = np.einsum("kij,kjl,kml->kim", R_b, C_bb, R_b)
    V_ab = np.einsum("kij,kjl,kml->kim", R_a, C_ab, R_b)  # R_a C_ab R_b^T
    with np.errstate(invalid="ignore", divide="ignore"):
        if mode == "concatenated":
            D_a = M_a - M_a.mean(axis=1, keepdims=True)  # each axis's mean about the grand mean
            D_b = M_b - M_b.mean(axis=1, keepdims=True)
            var_a = np.trace(V_a, axis1=1, axis2=2) + n * np.sum(D_a**2, axis=1)
            var_b = np.trace(V_b, axis1=1, axis2=2) + n * np.sum(D_b**2, axis=1)
            cov = np.trace(V_ab, axis1=1, axis2=2) + n * np.sum(D_a * D_b, axis=1)
            r = cov / np.sqrt(var_a * var_b)
            return np.where(_varies(var_a, V_a, M_a, n) & _varies(var_b, V_b, M_b, n), r, np.nan)
        if mode in ("per_axis", "per_axis_moving"):
            var_a = np.diagonal(V_a, axis1=1, axis2=2)
            var_b = np.diagonal(V_b, axis1=1, axis2=2)
            r = np.diagonal(V_ab, axis1=1, axis2=2) / np.sqrt(var_a * var_b)
            valid = (
                _varies(var_a, V_a, M_a, n[:, None])
                & _varies(var_b, V_b, M_b, n[:, None])
                & (n[:, None] > 1)
            )
            counted = valid.sum(axis=1)
            total = np.where(valid, r, 0.0).sum(axis=1)
            return np.where(counted > 0, total / np.maximum(counted, 1), np.nan)
    raise ValueError(f"correlation mode {mode!r} is not one of {', '.join(CORRELATION_MODES)}")


def _varies(variance: np.ndarray, V: np.ndarray, M: np.ndarray, n) -> np.ndarray:
    """A signal (or axis) varies when its spread is more than rounding error of its size."""
    size = np.trace(V, axis1=1, axis2=2) + np.squeeze(n) * np.sum(M**2, axis=1)
    size = size[:, None] if np.ndim(variance) == 2 else size
    return variance > 1e-20 * size


def _angle_rows(
    comparison: str,
    calibrations: pd.DataFrame,
    pairs: list[tuple[int, int]],
    k: list[int],
    test: list[str] | None = None,
) -> pd.DataFrame:
    """Rows of ANGLE_COLUMNS for index pairs (a, b) into ``calibrations`` (positional)."""
    if not pairs:
        return pd.DataFrame(columns=ANGLE_COLUMNS)
    ia, ib = np.array(pairs).T
    R = matrices(calibrations)
    first = calibrations.iloc[ia]
    second = calibrations.iloc[ib]
    out = pd.DataFrame(
        {
            "comparison": comparison,
            "subject": first["subject"].to_numpy(),
            "sensor_set": first["sensor_set"].to_numpy(),
            "imu": first["imu"].to_numpy(),
            "segment": first["segment"].to_numpy(),
            "side": first["side"].to_numpy(),
            "test": test if test is not None else first["test"].to_numpy(),
            "k": k,
            "calibration_a": (first["test"] + ":" + first["repetitions"]).to_numpy(),
            "calibration_b": (second["test"] + ":" + second["repetitions"]).to_numpy(),
            "error_angle_deg": error_angle_deg(R[ia], R[ib]),
            "vertical_share": vertical_share(R[ia], R[ib]),
        }
    )
    return out[ANGLE_COLUMNS]


def _subset_groups(calibrations: pd.DataFrame, method: str | None = None):
    """The calibrations of ``method`` (default Kong's) that the spread between subsets is measured on
    (:func:`aceval.calibrate.table.spread_usable`; positional index) and, per (subject, set, IMU,
    test), ``({subset: position}, all repetitions)``.
    """
    table = spread_usable(calibrations, method).reset_index(drop=True)
    groups = []
    for _, group in table.groupby(CALIBRATION_KEY, sort=True):
        by_subset = {parse_subset(rep): pos for pos, rep in zip(group.index, group["repetitions"])}
        groups.append((by_subset, tuple(sorted(set().union(*by_subset)))))
    return table, groups


def incremental_angles(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Obj 3 "incremental" (Kong Eq. 11-12): for each subset A of k repetitions and each repetition
    a not in A, the angle between R(A u {a}) and R(A). ``k`` = |A|.
    """
    table, groups = _subset_groups(calibrations)
    pairs, ks = [], []
    for by_subset, reps in groups:
        for subset, pos in by_subset.items():
            for extra in sorted(set(reps) - set(subset)):
                bigger = tuple(sorted(subset + (extra,)))
                if bigger in by_subset:
                    pairs.append((by_subset[bigger], pos))
                    ks.append(len(subset))
    return _angle_rows("incremental", table, pairs, ks)


def to_last_angles(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Obj 3 "to last" (Kong Eq. 13): the angle between R(all repetitions) and R(A) for every proper
    subset A; Eq. 13 itself is the rows with ``k`` = |A| = 1.
    """
    table, groups = _subset_groups(calibrations)
    pairs, ks = [], []
    for by_subset, reps in groups:
        if reps not in by_subset:
            continue  # the full set is flagged: nothing to converge to
        for subset, pos in by_subset.items():
            if subset != reps:
                pairs.append((by_subset[reps], pos))
                ks.append(len(subset))
    return _angle_rows("to_last", table, pairs, ks)


def test_retest_angles(
    calibrations: pd.DataFrame, k: int = 3, method: str | None = None
) -> pd.DataFrame:
    """Obj 4 (Kong Eq. 15): the angle between R(A) and R(A') for every pair of distinct subsets of
    ``k`` repetitions (45 pairs for 3 of 5), of Kong's calibrations or another ``method``'s.
    """
    table, groups = _subset_groups(calibrations, method)
    pairs = []
    for by_subset, _ in groups:
        same_size = sorted(s for s in by_subset if len(s) == k)
        pairs += [(by_subset[a], by_subset[b]) for a, b in itertools.combinations(same_size, 2)]
    return _angle_rows("test_retest", table, pairs, [k] * len(pairs))


def cross_test_angles(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Obj 5 (Kong Eq. 16): for each (subject, set, IMU), the angle between the full-set
    calibrations of every two tests that calibrate it; ``test`` is the pair, e.g. 'T1-T2'.
    """
    table = full_sets(calibrations).reset_index(drop=True)
    pairs, names = [], []
    for _, group in table.groupby(["subject", "sensor_set", "imu"], sort=True):
        group = group.sort_values("test")
        for a, b in itertools.combinations(group.index, 2):
            pairs.append((a, b))
            names.append(f"{table.loc[a, 'test']}-{table.loc[b, 'test']}")
    ks = [int(table.loc[a, "n_reps"]) for a, _ in pairs]
    return _angle_rows("cross_test", table, pairs, ks, names)


def all_angles(calibrations: pd.DataFrame, test_retest_k: int = 3) -> pd.DataFrame:
    """Objectives 3-5 in one tidy table (``comparison`` says which)."""
    if calibrations.empty:
        return pd.DataFrame(columns=ANGLE_COLUMNS)
    return _concat(
        [
            incremental_angles(calibrations),
            to_last_angles(calibrations),
            test_retest_angles(calibrations, test_retest_k),
            cross_test_angles(calibrations),
        ]
    )


#: the order of :func:`all_angles`' comparisons
COMPARISONS = ["incremental", "to_last", "test_retest", "cross_test"]


def in_angle_order(angles: pd.DataFrame) -> pd.DataFrame:
    """Angles of several subjects, each computed by :func:`all_angles` on its own calibrations,
    in the row order :func:`all_angles` gives on all of them at once (comparison, then subject;
    within a subject its own order): the same table, so the same sums and tables.
    """
    rank = angles["comparison"].map({name: k for k, name in enumerate(COMPARISONS)})
    order = pd.DataFrame({"rank": rank, "subject": angles["subject"]})
    order = order.sort_values(["rank", "subject"], kind="stable").index
    return angles.loc[order].reset_index(drop=True)


def _concat(parts: list[pd.DataFrame]) -> pd.DataFrame:
    parts = [p for p in parts if len(p)]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=ANGLE_COLUMNS)


# --- Obj 1 and 2: which calibrated signals are correlated --------------------------------------


def _joined(first: pd.DataFrame, second: pd.DataFrame, on: list[str]) -> pd.DataFrame:
    """Rows of ``first`` and ``second`` matched on ``on`` (columns suffixed _a and _b), with their
    rotations as ``R_a`` and ``R_b`` ((3, 3) arrays).
    """
    merged = first.merge(second, on=on, suffixes=("_a", "_b"))
    merged["R_a"] = list(merged[[f"{c}_a" for c in R_COLUMNS]].to_numpy(float).reshape(-1, 3, 3))
    merged["R_b"] = list(merged[[f"{c}_b" for c in R_COLUMNS]].to_numpy(float).reshape(-1, 3, 3))
    return merged


def frontal_lateral_plan(full: pd.DataFrame, sensor_sets: list[str]) -> pd.DataFrame:
    """Obj 1 (Eq. 7-8): per (subject, IMU, T_ex) where both sensor sets have a full-set
    calibration, one row with both rotations (columns ``R_a``, ``R_b`` as (3, 3) arrays).
    """
    set_a, set_b = sensor_sets
    merged = _joined(
        full[full["sensor_set"] == set_a],
        full[full["sensor_set"] == set_b],
        ["subject", "imu", "test"],
    )
    merged = merged.sort_values(["subject", "imu", "test"])
    return pd.DataFrame(
        {
            "subject": merged["subject"],
            "imu": merged["imu"],
            "segment": merged["segment_a"],
            "side": merged["side_a"],
            "t_ex": merged["test"],
            "R_a": merged["R_a"],
            "R_b": merged["R_b"],
        }
    ).reset_index(drop=True)


def segment_pair_plan(full: pd.DataFrame, pairs: dict[str, dict]) -> pd.DataFrame:
    """Obj 2 (Eq. 9-10): per sensor set, pair of segments (same side) and T_ex that calibrates
    both IMUs, one row with both rotations. ``pairs``: ``{name: {"segments": [a, b], "t_ap": [...]}}``.
    """
    parts = []
    for name, spec in pairs.items():
        seg_a, seg_b = spec["segments"]
        merged = _joined(
            full[full["segment"] == seg_a],
            full[full["segment"] == seg_b],
            ["subject", "sensor_set", "side", "test"],
        )
        parts.append(
            pd.DataFrame(
                {
                    "pair": name,
                    "subject": merged["subject"],
                    "sensor_set": merged["sensor_set"],
                    "side": merged["side"],
                    "imu_a": merged["imu_a"],
                    "imu_b": merged["imu_b"],
                    "t_ex": merged["test"],
                    "t_ap": [list(spec["t_ap"])] * len(merged),
                    "R_a": merged["R_a"],
                    "R_b": merged["R_b"],
                }
            )
        )
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
