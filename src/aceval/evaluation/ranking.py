"""The methods ranked against a ground truth with intervals over the subjects: the
subject, not the calibration or the leg, is the independent unit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.evaluation.methods_comparison import full_set_errors
from aceval.evaluation.stats import mean_ci
from aceval.evaluation.verdicts import half_width, level

CELL = ["segment", "test", "sensor_set"]
RANKING_COLUMNS = [
    "rank",
    "method",
    "cells",
    "n_subjects",
    "mean",
    "low",
    "high",
    "difference_to_first",
    "difference_low",
    "difference_high",
    "difference_level",
]


def shared_cells(errors: pd.DataFrame) -> tuple[list[str], pd.DataFrame]:
    """The methods compared and the cells (segment x test x set) where each has an unflagged
    calibration: the methods whose cells meet the first method's (a method calibrating from a
    static pose has cells of its own, under the static test, and is not ranked with them).
    """
    cells = errors.groupby("method")[CELL].apply(lambda t: set(map(tuple, t.to_numpy())))
    if cells.empty:
        return [], pd.DataFrame(columns=CELL)
    first = errors["method"].iloc[0]
    compared = [m for m in dict.fromkeys(errors["method"]) if cells[m] & cells[first]]
    shared = set.intersection(*(cells[m] for m in compared))
    return compared, pd.DataFrame(sorted(shared), columns=CELL)


def methods_ranking(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Every method's error to the true mounting on the cells all compared methods share
    (:func:`shared_cells`), per subject the mean over its calibrations there (sides and sets
    averaged inside the subject), then over the subjects: ``mean`` with its 95 % t-interval,
    ranked; each method's paired difference to the first-ranked one over the subjects, its
    interval simultaneous over the comparisons (Bonferroni, ``difference_level``).
    """
    errors = full_set_errors(calibrations) if len(calibrations) else calibrations
    if errors is None or errors.empty:
        return pd.DataFrame(columns=RANKING_COLUMNS)
    compared, shared = shared_cells(errors)
    chosen = errors[errors["method"].isin(compared)].merge(shared, on=CELL)
    if chosen.empty:
        return pd.DataFrame(columns=RANKING_COLUMNS)
    wide = chosen.pivot_table(index="subject", columns="method", values="error_deg", aggfunc="mean")
    stats = {m: mean_ci(wide[m]) for m in wide.columns}
    order = sorted(stats, key=lambda m: stats[m][0])
    differences = wide[order].sub(wide[order[0]], axis=0)
    m = max(len(order) - 1, 1)
    rows = []
    for rank, method in enumerate(order, start=1):
        mean, low, high, n = stats[method]
        d = differences[method].dropna()
        half = float(half_width(d.std(), len(d), level(m))) if method != order[0] else np.nan
        rows.append(
            {
                "rank": rank,
                "method": method,
                "cells": len(shared),
                "n_subjects": n,
                "mean": mean,
                "low": low,
                "high": high,
                "difference_to_first": d.mean() if method != order[0] else 0.0,
                "difference_low": d.mean() - half,
                "difference_high": d.mean() + half,
                "difference_level": 1 - 0.05 / m,
            }
        )
    return pd.DataFrame(rows, columns=RANKING_COLUMNS)
