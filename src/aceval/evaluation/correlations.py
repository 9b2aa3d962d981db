"""Kong Objectives 1 and 2 (Eq. 7-10): the correlation of two time-aligned recordings after their
calibrations, from the pair moments of the one pass (nothing reads the samples again).
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    moments = _PairMoments.of(pairs, mode, headings_deg)
    sensor_sets = list(dataset.meta["sensor_sets"])
    if len(sensor_sets) == 2 and len(full):
        for plan in frontal_lateral_plan(full, sensor_sets).to_dict("records"):
            base = {
                "objective": "frontal_lateral",
                "subject": plan["subject"],
                "sensor_set": "|".join(sensor_sets),
                "imu": plan["imu"],
                "segment": plan["segment"],
                "side": plan["side"],
                "t_ex": plan["t_ex"],
            }
            for t_ap in motion:
                moments.correlate(
                    base,
                    plan["imu"],
                    "",
                    t_ap,
                    plan["R_a"],
                    plan["R_b"],
                    ("acc", "gyr"),
                    bool(headings_deg),
                )
    if segment_pairs and len(full):
        for plan in segment_pair_plan(full, segment_pairs).to_dict("records"):
            base = {
                "objective": "segment_pair",
                "subject": plan["subject"],
                "sensor_set": plan["sensor_set"],
                "imu": plan["imu_a"],
                "imu_b": plan["imu_b"],
                "pair": plan["pair"],
                "side": plan["side"],
                "t_ex": plan["t_ex"],
            }
            for t_ap in [t for t in plan["t_ap"] if t in motion]:
                moments.correlate(
                    base,
                    plan["imu_a"],
                    plan["imu_b"],
                    t_ap,
                    plan["R_a"],
                    plan["R_b"],
                    ("acc",),
                    False,
                )
    return _sensitivity_unit_means(moments.table(pairs))


@dataclass
class _PairMoments:
    """The pair moments of one pass, looked up by key and read by position (not a pandas row per
    pair), and the correlation rows asked of them so far (``rows``; ``wanted``: (row, pair row,
    R_a, R_b, mode) for each correlation still to compute).
    """

    index: dict
    reps: dict
    lags: np.ndarray
    n_overlaps: np.ndarray
    flags: np.ndarray
    mode: str
    turns: dict
    rows: list = field(default_factory=list)
    wanted: list = field(default_factory=list)

    @classmethod
    def of(cls, pairs: pd.DataFrame, mode: str, headings_deg) -> _PairMoments:
        # the pair moments by (objective, subject, set, IMU, IMU b, test, rep, signal, window)
        keys = [
            "objective",
            "subject",
            "sensor_set",
            "imu",
            "imu_b",
            "test",
            "rep",
            "signal",
            "window",
        ]
        lookup = pairs[keys].assign(imu_b=pairs["imu_b"].fillna(""), rep=pairs["rep"].astype(int))
        return cls(
            index={key: k for k, key in enumerate(lookup.itertuples(index=False, name=None))},
            reps=lookup.groupby(keys[:4] + ["test"])["rep"].unique().to_dict(),
            lags=pairs["lag_samples"].to_numpy(),
            n_overlaps=pairs["n_overlap"].to_numpy(),
            flags=pairs["flag"].to_numpy(dtype=object),
            mode=mode,
            turns={h: Rotation.from_euler("z", h, degrees=True).as_matrix() for h in headings_deg},
        )

    def correlate(self, base, imu, imu_b, t_ap, R_a, R_b, signals, sensitivity) -> None:
        """Ask for the correlation of every repetition of ``t_ap`` of the pair ``base`` names
        (and, with ``sensitivity``, of the acceleration with each heading error, every mode).
        """
        unit = (base["objective"], base["subject"], base["sensor_set"], imu)
        for rep in sorted(int(r) for r in self.reps.get((*unit, t_ap), [])):
            for signal in signals:
                key = (*unit, imu_b, t_ap, rep, signal)
                k = self.index[(*key, _window(self.mode))]
                flag = self.flags[k] if isinstance(self.flags[k], str) else ""
                row = {
                    **base,
                    "t_ap": t_ap,
                    "rep": rep,
                    "signal": signal,
                    "mode": self.mode,
                    "heading_error_deg": 0.0,
                    "lag_samples": int(self.lags[k]),
                    "n_samples": int(self.n_overlaps[k]),
                    "correlation": np.nan,
                    "flag": flag,
                }
                self.rows.append(row)
                if flag:
                    continue
                self.wanted.append((len(self.rows) - 1, k, R_a, R_b, self.mode))
                if sensitivity and signal == "acc":
                    for heading, turn in self.turns.items():
                        for m in CORRELATION_MODES:
                            self.rows.append(
                                {
                                    **row,
                                    "objective": "frontal_lateral_sensitivity",
                                    "mode": m,
                                    "heading_error_deg": heading,
                                }
                            )
                            at = self.index[(*key, _window(m))]
                            self.wanted.append((len(self.rows) - 1, at, R_a, turn @ R_b, m))

    def table(self, pairs: pd.DataFrame) -> pd.DataFrame:
        """The rows asked for, their correlations computed from the moments, one mode at a time."""
        table = pd.DataFrame(self.rows, columns=CORRELATION_COLUMNS)
        for m in {w[4] for w in self.wanted}:
            chosen = [w for w in self.wanted if w[4] == m]
            values = correlation_from_moments(
                pairs.iloc[[w[1] for w in chosen]],
                np.array([w[2] for w in chosen]),
                np.array([w[3] for w in chosen]),
                m,
            )
            table.loc[[w[0] for w in chosen], "correlation"] = values
        return table


def _window(mode: str) -> str:
    """The pair moments a correlation ``mode`` reads (``moving``: the trimmed movement only)."""
    return "moving" if mode == "per_axis_moving" else "all"


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
