"""What each flag is worth (beyond the papers): how many calibrations it removes, and
whether the ones it removes are measurably worse than the ones it keeps.

A flag takes a calibration out of every median and verdict, and out of the decision unless the
truths found its calibrations no worse (:mod:`aceval.evaluation.decision_rules`, which reads the
committed tables of this module). That is worth its price only where the calibrations it removes
lie farther from the truth than the unflagged ones.
:func:`flag_value_table` measures it on the calibrations from all repetitions (every method, the
peers included): per flag and method (and over all methods), the calibrations carrying the flag,
those it alone removes (no other flag but the comparison flags, which take no calibration out:
:data:`aceval.calibrate.table.COMPARISON_FLAGS`), and the distance of flagged and unflagged
calibrations (no flag but the comparison flags; judging a comparison flag, no flag at all)

* to the ground truth (``error_deg``) where the dataset has one, else
* to the consensus of the other methods' unflagged calibrations of the same IMU and test (the
  chordal mean rotation, :meth:`scipy.spatial.transform.Rotation.mean`; a unit with no other
  unflagged method has no consensus).

``worse``: a one-sided Mann-Whitney test that the flagged distances are larger than the unflagged
ones of the same method (``p_value``; the calibrations are not independent units: the same
subjects and IMUs recur, so read it as a screen, not a verdict). ``verdict`` 'earns its keep'
where the flagged median is larger and p < 0.05, 'not measurably worse' where it is not, 'too few'
with fewer than 3 flagged or unflagged distances.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation
from scipy.stats import mannwhitneyu

from aceval.calibrate.table import (
    CALIBRATION_KEY,
    COMPARISON_FLAGS,
    flag_sets,
    full_set_rows,
    matrices,
    unflagged,
)
from aceval.data.rotations import error_angle_deg

COLUMNS = [
    "flag",
    "method",
    "reference",
    "n_calibrations",
    "n_flagged",
    "n_only_this_flag",
    "n_imus_flagged",
    "median_flagged_deg",
    "median_only_this_flag_deg",
    "median_unflagged_deg",
    "n_flagged_with_distance",
    "n_unflagged_with_distance",
    "p_value",
    "verdict",
]
#: flags that say a row is no calibration at all (a peer that does not apply): not judged here
NOT_CALIBRATIONS = ("not_applicable",)
#: the one-sided test's level for 'earns its keep'
ALPHA = 0.05
#: fewer flagged or unflagged distances than this: 'too few'
MIN_N = 3


def consensus_distance_deg(calibrations: pd.DataFrame) -> np.ndarray:
    """Each calibration's angle (deg) to the chordal mean of the other methods' unflagged
    calibrations of the same unit (subject, set, IMU, test); NaN without one or without R.
    """
    R = matrices(calibrations)
    finite = np.isfinite(R).all(axis=(1, 2))
    clean = unflagged(calibrations).to_numpy() & finite
    methods = calibrations["method"].to_numpy()
    out = np.full(len(calibrations), np.nan)
    for rows in calibrations.groupby(CALIBRATION_KEY, sort=False).indices.values():
        for i in rows[finite[rows]]:
            others = rows[clean[rows] & (methods[rows] != methods[i])]
            if len(others):
                mean = Rotation.from_matrix(R[others]).mean().as_matrix()
                out[i] = error_angle_deg(R[i], mean)
    return out


def flag_value_table(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Per flag and method (and ``method`` 'all'): what the flag removes and how far its
    calibrations lie from the reference against the unflagged ones (module docstring).
    """
    if calibrations.empty or "flag" not in calibrations:
        return pd.DataFrame(columns=COLUMNS)
    full = full_set_rows(calibrations).reset_index(drop=True)
    truth = "error_deg" in full and np.isfinite(full["error_deg"].astype(float)).any()
    distance = full["error_deg"].to_numpy(float) if truth else consensus_distance_deg(full)
    reference = "truth" if truth else "consensus of the other methods"
    names = flag_sets(full["flag"])
    imu = full[["subject", "sensor_set", "imu"]].astype(str).agg("|".join, axis=1)
    rows = []
    for flag in sorted(frozenset().union(*names) - set(NOT_CALIBRATIONS)):
        kept = frozenset(COMPARISON_FLAGS) - {flag}  # what the unflagged rows may carry
        clean = names.map(kept.issuperset).to_numpy()
        carries = names.map(lambda f, flag=flag: flag in f).to_numpy()
        alone = names.map(lambda f, flag=flag, kept=kept: f - kept == {flag}).to_numpy()
        methods = sorted(full.loc[carries, "method"].unique())
        for method in ["all", *methods] if len(methods) > 1 else methods:
            # 'all': over the methods that carry the flag (the unflagged ones of the same methods)
            mine = full["method"].isin(methods if method == "all" else [method]).to_numpy()
            rows.append(
                _row(
                    flag,
                    method,
                    reference,
                    distance,
                    carries & mine,
                    alone & mine,
                    clean & mine,
                    imu,
                    mine,
                )
            )
    return pd.DataFrame(rows, columns=COLUMNS)


def _row(flag, method, reference, distance, carries, alone, clean, imu, mine) -> dict:
    """One row of :func:`flag_value_table`."""
    flagged, kept = distance[carries], distance[clean]
    flagged, kept = flagged[np.isfinite(flagged)], kept[np.isfinite(kept)]
    p = np.nan
    if len(flagged) >= MIN_N and len(kept) >= MIN_N:
        p = float(mannwhitneyu(flagged, kept, alternative="greater").pvalue)
    if np.isnan(p):
        verdict = "too few"
    elif p < ALPHA and np.median(flagged) > np.median(kept):
        verdict = "earns its keep"
    else:
        verdict = "not measurably worse"
    only = distance[alone]
    return {
        "flag": flag,
        "method": method,
        "reference": reference,
        "n_calibrations": int(mine.sum()),
        "n_flagged": int(carries.sum()),
        "n_only_this_flag": int(alone.sum()),
        "n_imus_flagged": int(imu[carries].nunique()),
        "median_flagged_deg": float(np.median(flagged)) if len(flagged) else np.nan,
        "median_only_this_flag_deg": float(np.nanmedian(only))
        if np.isfinite(only).any()
        else np.nan,
        "median_unflagged_deg": float(np.median(kept)) if len(kept) else np.nan,
        "n_flagged_with_distance": len(flagged),
        "n_unflagged_with_distance": len(kept),
        "p_value": p,
        "verdict": verdict,
    }
