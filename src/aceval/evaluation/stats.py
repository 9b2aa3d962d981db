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


def unit_means_by_set(
    table: pd.DataFrame,
    value: str,
    unit: list[str],
    sets: list[str],
    set_column: str = "sensor_set",
) -> dict:
    """Paired t-test on independent units: each unit's (e.g. subject x IMU) mean ``value`` per
    sensor set, paired across the sets; units present in only one set are dropped.
    """
    return paired_by_set(table, value, unit, sets, set_column)


def mixed_model_by_set(
    table: pd.DataFrame,
    value: str,
    sets: list[str],
    group: str = "subject",
    set_column: str = "sensor_set",
    random_slope: bool = False,
) -> dict:
    """Linear mixed model ``value ~ set`` with a random intercept per ``group`` (statsmodels
    MixedLM, REML) and, with ``random_slope``, a random set effect per group too, on every row of
    ``table``: the contrast set a - set b with its 95 % CI, z and p (Wald). A random intercept
    alone still treats the rows of one group as independent given its mean, so with many
    dependent rows per subject it keeps the pooled test's optimism; the random slope lets the set
    effect vary by subject, which is what a test across subjects needs. ``n`` counts rows,
    ``n_groups`` the groups; NaN where the model cannot be fitted (fewer than 2 groups, one set
    missing, or no variation); ``note`` says why or how it ended.
    """
    data = table[table[set_column].isin(sets)][[value, set_column, group]].dropna()
    out = {
        "mean_a": np.nan, "mean_b": np.nan, "mean_difference": np.nan, "ci95_low": np.nan,
        "ci95_high": np.nan, "n": len(data), "n_groups": data[group].nunique(), "z": np.nan, "p": np.nan,
        "note": "",
    }  # fmt: skip
    if data[set_column].nunique() < 2:  # nothing to compare
        out.update(n=0, n_groups=0, note="not fitted: one set only")
        return out
    means = data.groupby(set_column)[value].mean()
    out["mean_a"], out["mean_b"] = means.get(sets[0], np.nan), means.get(sets[1], np.nan)
    if out["n_groups"] < 2 or data[value].std() == 0:
        out["note"] = "not fitted: needs 2 subjects and some variation"
        return out
    import warnings

    import statsmodels.formula.api as smf
    from statsmodels.tools.sm_exceptions import ConvergenceWarning

    data = data.assign(in_a=(data[set_column] == sets[0]).astype(float), y=data[value])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            model = smf.mixedlm(
                "y ~ in_a", data, groups=data[group], re_formula="~in_a" if random_slope else None
            )
            fit = model.fit(reml=True)
        except (ValueError, np.linalg.LinAlgError) as exc:
            out["note"] = f"not fitted: {exc}"
            return out
    low, high = fit.conf_int().loc["in_a"]
    out.update(
        mean_difference=float(fit.params["in_a"]), ci95_low=float(low), ci95_high=float(high),
        z=float(fit.tvalues["in_a"]), p=float(fit.pvalues["in_a"]),
        note="did not converge" if any(issubclass(w.category, ConvergenceWarning) for w in caught) else "",
    )  # fmt: skip
    return out


def variance_shares(table: pd.DataFrame, value: str, factors: list[str]) -> dict[str, float]:
    """Share of the variance of ``value`` explained by each factor (type II sums of squares of an
    additive linear model ``value ~ C(f1) + C(f2) + ...``, each divided by the total sum of
    squares): eta squared, 0-1. NaN for a factor with one level.
    """
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    data = table[[value, *factors]].dropna()
    used = [f for f in factors if data[f].nunique() > 1]
    shares = dict.fromkeys(factors, np.nan)
    if not used or len(data) <= sum(data[f].nunique() for f in used):
        return shares
    formula = f"Q('{value}') ~ " + " + ".join(f"C(Q('{f}'))" for f in used)
    anova = anova_lm(smf.ols(formula, data).fit(), typ=2)
    total = float(((data[value] - data[value].mean()) ** 2).sum())
    for f in used:
        shares[f] = float(anova.loc[f"C(Q('{f}'))", "sum_sq"] / total) if total > 0 else np.nan
    return shares
