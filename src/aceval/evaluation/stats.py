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
    """Paired t-test on independent units: each unit's (the subject: its IMUs and sides averaged
    inside it) mean ``value`` per sensor set, paired across the sets; units present in only one
    set are dropped.
    """
    return paired_by_set(table, value, unit, sets, set_column)


#: the ways a mixed-model fit can end, each a flag of its own (``fit_flags``, ';'-joined)
FIT_FLAGS = ("not_converged", "hessian_not_pd", "boundary")


def mixed_model_by_set(
    table: pd.DataFrame,
    value: str,
    pair_on: list[str],
    sets: list[str],
    group: str = "subject",
    nested: str | None = None,
    set_column: str = "sensor_set",
) -> dict:
    """Linear mixed model of the paired differences set a - set b (statsmodels MixedLM, REML):
    ``value`` is paired across the sets on ``pair_on`` (as the paper pairs it), and the
    differences ``d ~ 1`` get a random intercept per ``group`` (the subject) and, with ``nested``
    (e.g. 'imu' or 'side'), a variance component for that level within the subject: the design's
    dependence (many pairs per IMU, several IMUs per subject) is in the model, not in n. The
    intercept is the set effect, with its 95 % CI, z and p (Wald).

    ``fit_flags`` (:data:`FIT_FLAGS`, ';'-joined): ``not_converged`` (the optimiser says so, or
    ``fit.converged`` is false), ``hessian_not_pd`` (no valid standard errors) and ``boundary``
    (a variance component estimated at zero: a singular fit; its p stands, flagged). A fit that did
    not converge or has no positive-definite Hessian has no p (it leaves the Holm family). ``n``
    counts paired rows, ``n_groups`` subjects; ``note`` says why a model was not fitted.
    """
    out = {
        "mean_a": np.nan, "mean_b": np.nan, "mean_difference": np.nan, "ci95_low": np.nan,
        "ci95_high": np.nan, "n": 0, "n_groups": 0, "z": np.nan, "p": np.nan, "note": "",
        "fit_flags": "",
    }  # fmt: skip
    wide = table.pivot_table(index=pair_on, columns=set_column, values=value, aggfunc="mean")
    if not set(sets) <= set(wide.columns):
        out["note"] = "not fitted: one set only"
        return out
    wide = wide[sets].dropna().reset_index()
    d = wide.assign(d=wide[sets[0]] - wide[sets[1]])
    out.update(
        mean_a=float(wide[sets[0]].mean()), mean_b=float(wide[sets[1]].mean()), n=len(d),
        n_groups=int(d[group].nunique()),
    )  # fmt: skip
    if out["n_groups"] < 2 or d["d"].std() == 0:
        out["note"] = "not fitted: needs 2 subjects and some variation"
        return out
    fit, flags = _fit_differences(d, group, nested)
    if fit is None:
        out["note"] = f"not fitted: {flags}"
        return out
    low, high = fit.conf_int().loc["Intercept"]
    failed = "not_converged" in flags or "hessian_not_pd" in flags
    out.update(
        mean_difference=float(fit.params["Intercept"]), fit_flags=";".join(flags),
        ci95_low=np.nan if failed else float(low), ci95_high=np.nan if failed else float(high),
        z=np.nan if failed else float(fit.tvalues["Intercept"]),
        p=np.nan if failed else float(fit.pvalues["Intercept"]),
    )  # fmt: skip
    return out


def _fit_differences(d: pd.DataFrame, group: str, nested: str | None):
    """(fit, flags) of ``d ~ 1`` (:func:`mixed_model_by_set`); (None, cause) when it cannot be fitted."""
    import warnings

    import statsmodels.formula.api as smf
    from statsmodels.tools.sm_exceptions import ConvergenceWarning

    data = d.assign(level=d[nested].astype(str)) if nested else d
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            model = smf.mixedlm(
                "d ~ 1", data, groups=data[group],
                vc_formula={"level": "0 + C(level)"} if nested else None,
            )  # fmt: skip
            fit = model.fit(reml=True)
        except (ValueError, np.linalg.LinAlgError) as exc:
            return None, str(exc)
    said = " ".join(str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning))
    flags = []
    if not getattr(fit, "converged", True) or "converge" in said or "failed" in said:
        flags.append("not_converged")
    if "Hessian" in said or not np.isfinite(fit.bse).all():
        flags.append("hessian_not_pd")
    variances = np.concatenate([np.diag(np.atleast_2d(fit.cov_re)), np.atleast_1d(fit.vcomp)])
    if "boundary" in said or (variances <= 1e-8 * max(float(fit.scale), 1e-300)).any():
        flags.append("boundary")
    return fit, flags


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
