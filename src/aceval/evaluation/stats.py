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
    interval, Cohen's d_z (mean difference / SD of the differences), n, t, its degrees of freedom
    (``df``, n - 1; not in :data:`TTEST_COLUMNS`) and p. With fewer than
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
        "df": np.nan,
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
            df=n - 1,
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


def smallest_sign_flip_p(n: int) -> float:
    """The smallest two-sided p an exact sign-flip (permutation) test of a paired difference can
    reach with ``n`` independent units, 2 / 2**n: 0.0625 for 5 subjects. A claim quoting a
    smaller p cannot be confirmed by a distribution-free test on fewer units (a t-test gets
    there only through its normality assumption: |t| > 8.6 for p < 0.001 with n = 5).
    """
    return 2.0 / 2.0**n if n > 0 else float("nan")


def mean_ci(values, level: float = 0.95) -> tuple[float, float, float, int]:
    """``(mean, low, high, n)``: the mean of independent ``values`` (NaN dropped) and its
    t-interval at ``level`` (NaN with fewer than 2 values).
    """
    x = np.asarray(values, float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return float("nan"), float("nan"), float("nan"), 0
    sd = float(x.std(ddof=1)) if len(x) > 1 else float("nan")
    return (float(x.mean()), *summary_ci(float(x.mean()), sd, len(x), level), len(x))


def summary_ci(mean: float, sd: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """The t-interval ``(low, high)`` at ``level`` of a mean of ``n`` independent values with SD
    ``sd`` (NaN with fewer than 2).
    """
    if n < 2 or not np.isfinite(sd):
        return float("nan"), float("nan")
    from scipy import stats

    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * sd / np.sqrt(n))
    return mean - half, mean + half


def cell_means_by_set(
    table: pd.DataFrame,
    value: str,
    pair_on: list[str],
    cell: list[str],
    sets: list[str],
    set_column: str = "sensor_set",
) -> pd.DataFrame:
    """The paired design reduced to its cells: ``value`` paired across the two ``sets`` on
    ``pair_on`` (rows of one set only dropped), then each ``cell``'s (e.g. subject x IMU) mean per
    set, columns ``mean_a`` and ``mean_b`` (an empty table when a set is missing). The cells are
    what the subject-level test and the mixed model read, and what is committed
    (``set_test_units``) so that both can be recomputed.
    """
    wide = table.pivot_table(index=pair_on, columns=set_column, values=value, aggfunc="mean")
    if not set(sets) <= set(wide.columns):
        return pd.DataFrame(columns=[*cell, "mean_a", "mean_b"])
    wide = wide[sets].dropna().reset_index()
    means = wide.groupby(cell, sort=True)[sets].mean().reset_index()
    return means.rename(columns={sets[0]: "mean_a", sets[1]: "mean_b"})


def subject_test(cells: pd.DataFrame) -> dict:
    """Paired t-test on the subjects (the independent unit): each subject's mean of its cells'
    means per set (its IMUs and sides weigh equally), with ``smallest_p``
    (:func:`smallest_sign_flip_p`).
    """
    subjects = cells.groupby("subject")[["mean_a", "mean_b"]].mean()
    out = paired_ttest(subjects["mean_a"].to_numpy(), subjects["mean_b"].to_numpy())
    return out | {"n_groups": out["n"], "smallest_p": smallest_sign_flip_p(out["n"])}


#: the ways a mixed-model fit can end, each a flag of its own (``fit_flags``, ';'-joined)
FIT_FLAGS = ("not_converged", "hessian_not_pd", "boundary")
#: a fit is on the boundary (singular) when the subjects' variance is below this share of the
#: cells' residual variance (their SD 3 % of it): statsmodels' optimiser of the variance's square
#: root stops short of exactly zero (the singular fits of kong_sim's Table 8 end at about 1e-4)
BOUNDARY_RATIO = 1e-3


def mixed_model_of_cells(cells: pd.DataFrame) -> dict:
    """Linear mixed model of the cells' paired differences (statsmodels MixedLM, REML): each
    cell's mean difference set a - set b (a cell is one IMU, or in Table 7 one side, of one
    subject: its repetitions and subsets, dependent resamples of the same recordings, are
    averaged into it) as ``d ~ 1`` with a random intercept per subject; the cells within a
    subject are the residual level. The intercept is the set effect; its 95 % CI and p use a t
    reference with the between-within degrees of freedom, subjects - 1 (the intercept is a
    between-subject effect; for balanced cells this is the exact test, equal to the paired t-test
    on the subjects when the fit is interior): ``t`` is the REML estimate over its standard error,
    ``df`` the subjects - 1 (a Wald z with a normal reference is optimistic with few subjects).

    Where statsmodels' default optimisers stop short, the model is refitted with
    :data:`REFIT_METHODS` and the fit with the largest log-likelihood kept (:func:`_fit_differences`).
    ``fit_flags`` (:data:`FIT_FLAGS`, ';'-joined), all read from that final fit:
    ``not_converged`` (its optimiser did not converge), ``hessian_not_pd`` (no valid standard
    errors), ``boundary`` (the subjects' variance below :data:`BOUNDARY_RATIO` of the residual
    one: a singular fit, which treats the cells as independent; its p stands, flagged, and the
    ``note`` gives the paired t-test on the subjects beside it, which does not). A fit that did
    not converge or has no positive-definite Hessian has no p (it leaves the Holm family). ``n``
    counts cells, ``n_groups`` subjects; ``note`` also says why a model was not fitted.
    """
    out = {
        "mean_a": float(cells["mean_a"].mean()) if len(cells) else np.nan,
        "mean_b": float(cells["mean_b"].mean()) if len(cells) else np.nan,
        "mean_difference": np.nan,
        "ci95_low": np.nan,
        "ci95_high": np.nan,
        "n": len(cells),
        "n_groups": int(cells["subject"].nunique()) if len(cells) else 0,
        "t": np.nan,
        "df": np.nan,
        "p": np.nan,
        "note": "",
        "fit_flags": "",
    }
    d = (cells["mean_a"] - cells["mean_b"]).to_numpy(float)
    if out["n_groups"] < 2 or out["n"] <= out["n_groups"] or np.std(d) == 0:
        out["note"] = "not fitted: needs 2 subjects, more cells than subjects and some variation"
        return out
    fit, flags = _fit_differences(d, cells["subject"].to_numpy())
    if fit is None:
        out["note"] = f"not fitted: {flags}"
        return out
    out.update(mean_difference=float(fit.params[0]), fit_flags=";".join(flags))
    if "not_converged" in flags or "hessian_not_pd" in flags:
        return out
    from scipy import stats

    df = out["n_groups"] - 1
    t, se = float(fit.tvalues[0]), float(fit.bse[0])
    half = float(stats.t.ppf(0.975, df)) * se
    if "boundary" in flags:
        paired = subject_test(cells)
        out["note"] = (
            f"subjects' variance on the boundary: the paired t-test on the subjects beside it, "
            f"t {paired['t']:.3f}, p {paired['p']:.3g}"
        )
    return out | {
        "ci95_low": out["mean_difference"] - half,
        "ci95_high": out["mean_difference"] + half,
        "t": t,
        "df": float(df),
        "p": float(2 * stats.t.sf(abs(t), df)),
    }


#: the optimisers tried after statsmodels' default when its fit stops short (not converged, no
#: positive-definite Hessian, a failure, or on the boundary where gradient methods stall): the
#: derivative-free Powell and Nelder-Mead; the fit with the largest REML log-likelihood is kept
REFIT_METHODS = ("powell", "nm")


def _one_fit(model, method: str | None):
    """``(fit, flags)`` of one optimiser (None: statsmodels' default sequence), the flags from
    this fit alone (:data:`FIT_FLAGS`); ``(None, cause)`` when it fails.
    """
    import warnings

    from statsmodels.tools.sm_exceptions import ConvergenceWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            fit = model.fit(reml=True) if method is None else model.fit(reml=True, method=method)
        except (ValueError, np.linalg.LinAlgError) as exc:
            return None, str(exc)
    said = " ".join(str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning))
    ratio = float(np.min(np.diag(np.atleast_2d(fit.cov_re)))) / max(float(fit.scale), 1e-300)
    boundary = ratio < BOUNDARY_RATIO
    flags = []
    if not fit.converged:  # the final optimiser's own word, not the earlier ones' retries
        flags.append("not_converged")
    # on the boundary the variance's own curvature is singular by nature (statsmodels then warns
    # of the whole Hessian); the set effect's standard error is what the test needs
    if not np.isfinite(fit.bse_fe).all() or ("Hessian" in said and not boundary):
        flags.append("hessian_not_pd")
    if boundary:
        flags.append("boundary")
    return fit, flags


def _fit_differences(d: np.ndarray, subjects: np.ndarray):
    """(fit, flags) of ``d ~ 1`` with a random intercept per subject (:func:`mixed_model_of_cells`):
    statsmodels' default optimisers, then, where that fit stops short (flagged, or failed), each
    of :data:`REFIT_METHODS`; the fit with the largest log-likelihood, its flags its own (ties:
    the earlier). (None, cause) when every optimiser fails.
    """
    from statsmodels.regression.mixed_linear_model import MixedLM

    model = MixedLM(d, np.ones((len(d), 1)), groups=subjects)
    best, flags = _one_fit(model, None)
    if best is not None and not flags:
        return best, flags
    cause = flags if best is None else ""
    for method in REFIT_METHODS:
        fit, its_flags = _one_fit(model, method)
        if fit is not None and (best is None or fit.llf > best.llf + 1e-9):
            best, flags = fit, its_flags
    return (best, flags) if best is not None else (None, cause)


def variance_shares(
    table: pd.DataFrame, value: str, factors: list[str], interactions=()
) -> pd.DataFrame:
    """Share of the variance of ``value`` explained by each term of the linear model ``value ~
    C(f1) + C(f2) + ... + C(a):C(b) ...`` (``factors``, then ``interactions``: pairs of factors):
    type II sums of squares over the total sum of squares, eta squared, 0-1 (a main effect against
    the model of every term not containing it; an interaction against the full model).
    ``involved``: the share of the factor together with every interaction it is part of (the
    model without any term containing it against the full model); an interaction's own share.
    ``aliased``: how many of the term's contrasts the others already span (a design that
    confounds it: those contrasts have no share of their own; NaN share when all of them are).

    The subject is the independent unit: ``subject_mean``, ``low``, ``high`` are the mean over the
    subjects of each subject's own ``involved`` share as epsilon squared (:func:`subject_shares`:
    the same model fitted to its rows alone, chance removed) and its 95 % t-interval. ``n`` rows,
    ``n_subjects``.
    """
    terms = [(f,) for f in factors] + [tuple(i) for i in interactions]
    data = table[[value, *factors, "subject"]].dropna()
    pooled = _shares(data[value].to_numpy(float), _term_blocks(data, terms), terms)
    per_subject = subject_shares(data, value, factors, interactions)
    means = [
        mean_ci(per_subject[":".join(t)]) if len(per_subject) else (np.nan,) * 4 for t in terms
    ]
    return pd.DataFrame(
        {
            "factor": [":".join(t) for t in terms],
            "eta_squared": pooled["eta_squared"],
            "involved": pooled["involved"],
            "subject_mean": [m[0] for m in means],
            "low": [m[1] for m in means],
            "high": [m[2] for m in means],
            "aliased": pooled["aliased"],
            "n": len(data),
            "n_subjects": data["subject"].nunique(),
        }
    )


def subject_shares(
    table: pd.DataFrame, value: str, factors: list[str], interactions=()
) -> pd.DataFrame:
    """Each subject's own share of every term and the interactions it is part of (``involved``
    of :func:`variance_shares`, fitted to the subject's rows alone) as epsilon squared (Kelley
    1935: the sum of squares less its degrees of freedom times the residual mean square, over the
    total), which removes what chance alone explains: with 162 units a factor of 6 levels
    explains about 0.03 by chance in eta squared, three times Cohen's small effect. One row per
    subject, one column per term ('t_ap', 't_ap:segment'); NaN where not estimable.
    """
    terms = [(f,) for f in factors] + [tuple(i) for i in interactions]
    data = table[[value, *factors, "subject"]].dropna()
    rows = {}
    for subject, rows_of in data.groupby("subject", sort=True):
        shares = _shares(rows_of[value].to_numpy(float), _term_blocks(rows_of, terms), terms)
        rows[subject] = shares["epsilon"]
    return pd.DataFrame.from_dict(rows, orient="index", columns=[":".join(t) for t in terms])


def _term_blocks(data: pd.DataFrame, terms: list[tuple]) -> list[np.ndarray]:
    """Each term's treatment-coded columns: a factor's dummies, an interaction's products."""
    dummies = {
        f: _dummies(pd.factorize(data[f], sort=True)[0]) for f in {f for t in terms for f in t}
    }
    blocks = []
    for term in terms:
        block = dummies[term[0]]
        for factor in term[1:]:
            other = dummies[factor]
            block = (block[:, :, None] * other[:, None, :]).reshape(len(data), -1)
        blocks.append(block)
    return blocks


def _shares(y: np.ndarray, blocks: list[np.ndarray], terms: list[tuple]) -> dict:
    """Type II eta squared, ``involved`` share and aliased contrasts of each term
    (:func:`variance_shares`).
    """
    eta = np.full(len(terms), np.nan)
    involved = np.full(len(terms), np.nan)
    epsilon = np.full(len(terms), np.nan)
    aliased = np.array([b.shape[1] for b in blocks], float)
    total = float(((y - y.mean()) ** 2).sum())
    full, rank = _residual_ss(y, blocks)
    if total <= 0 or len(y) <= rank:
        return {"eta_squared": eta, "involved": involved, "epsilon": epsilon, "aliased": aliased}
    for k, term in enumerate(terms):
        if len(term) > 1:  # an interaction: the full model without it
            without, rank_without = _residual_ss(y, blocks[:k] + blocks[k + 1 :])
            with_term, rank_with = full, rank
        else:  # a main effect: every term not containing it, without and with it
            base = [b for j, b in enumerate(blocks) if term[0] not in terms[j]]
            without, rank_without = _residual_ss(y, base)
            with_term, rank_with = _residual_ss(y, [*base, blocks[k]])
        aliased[k] = blocks[k].shape[1] - (rank_with - rank_without)
        if rank_with > rank_without:
            eta[k] = max(without - with_term, 0.0) / total
        if rank > rank_without:  # every term containing it, against the full model
            involved[k] = max(without - full, 0.0) / total
            chance = (rank - rank_without) * full / (len(y) - rank)  # its df x residual mean square
            epsilon[k] = (without - full - chance) / total
    return {"eta_squared": eta, "involved": involved, "epsilon": epsilon, "aliased": aliased}


def _dummies(codes: np.ndarray) -> np.ndarray:
    """Treatment coding of one factor: a 0/1 column per level but the first."""
    levels = np.unique(codes)
    return (codes[:, None] == levels[None, 1:]).astype(float)


def _residual_ss(y: np.ndarray, blocks: list[np.ndarray]) -> tuple[float, int]:
    """The residual sum of squares of ``y`` on an intercept and ``blocks``, and the rank."""
    X = np.column_stack([np.ones(len(y)), *blocks])
    coef, _, rank, _ = np.linalg.lstsq(X, y, rcond=None)
    return float(((y - X @ coef) ** 2).sum()), int(rank)


#: subjects from which a coverage's interval resamples the subjects; with fewer, it is the
#: binomial (Clopper-Pearson) interval of the calibrations, which treats them as independent
MIN_SUBJECTS_TO_RESAMPLE = 5


def coverage_interval(
    hit, subjects, n_resamples: int = 1000, seed: int = 0
) -> tuple[float, float, str]:
    """``(low, high, how)``: the 95 % interval of a coverage (the share of ``hit``, one per
    calibration) from resampling the ``subjects`` with replacement (``how`` 'subjects'), or with
    fewer than :data:`MIN_SUBJECTS_TO_RESAMPLE` subjects the Clopper-Pearson interval of the
    calibrations ('binomial'); NaN without calibrations.
    """
    hit = np.asarray(hit, float)
    if len(hit) == 0:
        return float("nan"), float("nan"), ""
    table = pd.DataFrame({"hit": hit, "subject": np.asarray(subjects)})
    sums = table.groupby("subject")["hit"].agg(["sum", "count"]).to_numpy(float)
    if len(sums) < MIN_SUBJECTS_TO_RESAMPLE:
        from scipy import stats

        ci = stats.binomtest(int(hit.sum()), len(hit)).proportion_ci(0.95)
        return float(ci.low), float(ci.high), "binomial"
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(sums), size=(n_resamples, len(sums)))
    shares = sums[draws, 0].sum(axis=1) / sums[draws, 1].sum(axis=1)
    low, high = np.percentile(shares, [2.5, 97.5])
    return float(low), float(high), "subjects"
