"""Paired comparisons of the two sensor sets (Kong Tables 7, 8, 10) with ``scipy.stats`` and
Holm's correction from ``statsmodels``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

TTEST_COLUMNS = [
    "mean_a",
    "sd_a",
    "mean_b",
    "sd_b",
    "mean_difference",
    "ci95_low",
    "ci95_high",
    "cohens_dz",
    "n",
    "t",
    "p",
]


def paired_ttest(a: np.ndarray, b: np.ndarray) -> dict:
    """Two-sided paired t-test of ``a`` vs ``b`` (same units, same order).

    Returns mean and SD (ddof 1) of each, the mean difference a - b with its 95 % confidence
    interval, Cohen's d_z (mean difference / SD of the differences), n, t and p. With fewer than
    2 pairs, or no variation in the differences, the test is undefined: t, p, CI and d_z are NaN.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        raise ValueError(f"paired samples differ in length: {a.shape} vs {b.shape}")
    diff = a - b
    n = len(diff)
    out = {
        "mean_a": np.mean(a) if n else np.nan,
        "sd_a": np.std(a, ddof=1) if n > 1 else np.nan,
        "mean_b": np.mean(b) if n else np.nan,
        "sd_b": np.std(b, ddof=1) if n > 1 else np.nan,
        "mean_difference": np.mean(diff) if n else np.nan,
        "n": n,
        "ci95_low": np.nan,
        "ci95_high": np.nan,
        "cohens_dz": np.nan,
        "t": np.nan,
        "p": np.nan,
    }
    if n > 1 and np.std(diff, ddof=1) > 0:
        from scipy import (
            stats,
        )  # imported here: a second of start-up for the commands that never test

        result = stats.ttest_rel(a, b)
        ci = result.confidence_interval(0.95)
        out.update(
            t=result.statistic,
            p=result.pvalue,
            ci95_low=ci.low,
            ci95_high=ci.high,
            cohens_dz=np.mean(diff) / np.std(diff, ddof=1),
        )
    return {k: float(v) if k != "n" else int(v) for k, v in out.items()}


def paired_by_set(
    table: pd.DataFrame,
    value: str,
    pair_on: list[str],
    sets: list[str],
    set_column: str = "sensor_set",
) -> dict:
    """Paired t-test of ``value`` between two sensor sets: rows are matched on ``pair_on`` (the
    unit of pairing); units present in only one set are dropped.
    """
    wide = table.pivot_table(index=pair_on, columns=set_column, values=value, aggfunc="mean")
    if not set(sets) <= set(wide.columns):
        return paired_ttest(np.array([]), np.array([]))
    wide = wide[sets].dropna()
    return paired_ttest(wide[sets[0]].to_numpy(), wide[sets[1]].to_numpy())


def holm(p_values) -> np.ndarray:
    """Holm-adjusted p-values (NaN stays NaN and is not counted as a test)."""
    p = np.asarray(p_values, float)
    adjusted = np.full_like(p, np.nan)
    finite = np.isfinite(p)
    if finite.any():
        from statsmodels.stats.multitest import multipletests

        adjusted[finite] = multipletests(p[finite], method="holm")[1]
    return adjusted
