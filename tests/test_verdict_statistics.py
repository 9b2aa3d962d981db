"""Every statistic a verdict of SUMMARY.md reads, against an independent computation: the
intervals against ``scipy.stats``, the effect size and standard deviations by hand, Holm against
``statsmodels``, the exact test's smallest p by enumerating the sign flips, the resampled
intervals against the same draws made here (issue 44). A slip such as the SD over n instead of
n - 1 narrows every interval of SUMMARY.md by about 11 % at 5 subjects: these tests see it."""

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy import stats as scipy_stats

from aceval.evaluation import stats, verdicts
from aceval.report import claims

#: five subjects' values (a verdict's usual sample) and a second, skewed sample
FIVE = np.array([2.1, 3.9, 1.2, 5.6, 3.25])
SKEWED = np.array([0.3, 0.31, 0.35, 0.4, 0.9, 2.5, 0.33])


def t_interval(x, level):
    """The t-interval of the mean, computed by scipy.stats alone."""
    x = np.asarray(x, float)
    return scipy_stats.t.interval(level, len(x) - 1, loc=x.mean(), scale=scipy_stats.sem(x))


@pytest.mark.parametrize("values", [FIVE, SKEWED, FIVE[:2]])
@pytest.mark.parametrize("level", [0.95, 0.90, 0.99])
def test_mean_ci_is_scipys_t_interval(values, level):
    mean, low, high, n = stats.mean_ci(values, level)
    assert n == len(values) and mean == pytest.approx(values.mean(), rel=1e-12)
    assert (low, high) == pytest.approx(t_interval(values, level), rel=1e-12)
    # and the one-sample t-test's own interval says the same
    ci = scipy_stats.ttest_1samp(values, 0.0).confidence_interval(level)
    assert (low, high) == pytest.approx((ci.low, ci.high), rel=1e-12)


def test_mean_ci_worked_by_hand_at_five_subjects():
    """Mean 3.21, SD (n - 1) 1.69278, t(0.975, 4) = 2.776445: 3.21 +- 2.10186 (an SD over n
    would give +- 1.87996, 11 % narrower)."""
    mean, low, high, n = stats.mean_ci(FIVE)
    assert mean == pytest.approx(3.21)
    assert (low, high) == pytest.approx((3.21 - 2.10186, 3.21 + 2.10186), abs=1e-5)


def test_mean_ci_drops_nan_and_has_no_interval_below_two_values():
    with_nan = np.array([*FIVE, np.nan, np.inf])
    assert stats.mean_ci(with_nan) == pytest.approx(stats.mean_ci(FIVE))
    mean, low, high, n = stats.mean_ci([4.0])
    assert (mean, n) == (4.0, 1) and np.isnan(low) and np.isnan(high)
    mean, low, high, n = stats.mean_ci([np.nan])
    assert n == 0 and np.isnan(mean) and np.isnan(low) and np.isnan(high)


@pytest.mark.parametrize("n", [2, 5, 40])
def test_summary_ci_from_mean_sd_n_is_scipys(n):
    low, high = stats.summary_ci(1.5, 0.4, n, 0.95)
    assert (low, high) == pytest.approx(
        scipy_stats.t.interval(0.95, n - 1, loc=1.5, scale=0.4 / np.sqrt(n)), rel=1e-12
    )
    low90, high90 = stats.summary_ci(1.5, 0.4, n, 0.90)
    assert low < low90 < 1.5 < high90 < high
    for undefined in (stats.summary_ci(1.5, 0.4, 1), stats.summary_ci(1.5, np.nan, 5)):
        assert np.isnan(undefined).all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paired_ttest_is_scipys_with_the_effect_size_by_hand(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(1.0, 0.5, 6)
    b = a - rng.normal(0.3, 0.4, 6)
    out = stats.paired_ttest(a, b)
    reference = scipy_stats.ttest_rel(a, b)
    diff = a - b
    assert out["t"] == pytest.approx(reference.statistic, rel=1e-12)
    assert out["p"] == pytest.approx(reference.pvalue, rel=1e-12)
    assert (out["ci95_low"], out["ci95_high"]) == pytest.approx(t_interval(diff, 0.95), rel=1e-12)
    sd_diff = np.sqrt(((diff - diff.mean()) ** 2).sum() / (len(diff) - 1))
    assert out["cohens_dz"] == pytest.approx(diff.mean() / sd_diff, rel=1e-12)
    assert out["mean_difference"] == pytest.approx(diff.mean(), rel=1e-12)
    assert out["sd_a"] == pytest.approx(np.sqrt(((a - a.mean()) ** 2).sum() / 5), rel=1e-12)
    assert out["sd_b"] == pytest.approx(np.sqrt(((b - b.mean()) ** 2).sum() / 5), rel=1e-12)
    assert out["mean_a"] == pytest.approx(a.mean()) and out["mean_b"] == pytest.approx(b.mean())
    assert out["n"] == 6 and isinstance(out["n"], int)
    # a - b and b - a: the same test, mirrored
    mirrored = stats.paired_ttest(b, a)
    assert mirrored["t"] == pytest.approx(-out["t"]) and mirrored["p"] == pytest.approx(out["p"])
    assert mirrored["ci95_low"] == pytest.approx(-out["ci95_high"])
    assert mirrored["cohens_dz"] == pytest.approx(-out["cohens_dz"])


def test_paired_ttest_of_one_pair_has_means_but_no_test():
    out = stats.paired_ttest(np.array([2.0]), np.array([0.5]))
    assert out["n"] == 1 and out["mean_difference"] == 1.5 and out["mean_a"] == 2.0
    assert np.isnan([out["sd_a"], out["sd_b"], out["t"], out["p"], out["ci95_low"]]).all()
    assert np.isnan(out["cohens_dz"]) and np.isnan(out["ci95_high"])
    empty = stats.paired_ttest(np.array([]), np.array([]))
    assert np.isnan([empty["mean_a"], empty["mean_b"], empty["mean_difference"]]).all()


def test_holm_is_statsmodels_and_leaves_nan_out_of_the_family():
    from statsmodels.stats.multitest import multipletests  # here: statsmodels costs 1 CPU-s

    rng = np.random.default_rng(4)
    p = rng.uniform(0, 0.2, 9)
    np.testing.assert_allclose(stats.holm(p), multipletests(p, method="holm")[1], rtol=1e-12)
    with_nan = np.array([0.01, np.nan, 0.04, 0.03, np.nan])
    adjusted = stats.holm(with_nan)
    assert np.isnan(adjusted[[1, 4]]).all()
    # the family is the three finite p-values: 0.01 x 3, then max(0.03 x 2, 0.03), 0.04 x 1 -> 0.06
    np.testing.assert_allclose(adjusted[[0, 2, 3]], [0.03, 0.06, 0.06])
    assert stats.holm([0.6, 0.7]).tolist() == [1.0, 1.0]  # 1.2 capped at 1, then monotone
    assert np.isnan(stats.holm([np.nan, np.nan])).all()
    assert stats.holm([]).shape == (0,)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 7])
def test_smallest_sign_flip_p_is_the_exact_tests_by_enumeration(n):
    """The two-sided sign-flip test of n positive differences: the share of the 2**n sign
    patterns whose |mean| is at least the observed one (only all + and all -)."""
    diff = np.arange(1.0, n + 1)
    flips = np.array(list(itertools.product((-1.0, 1.0), repeat=n)))
    means = np.abs((flips * diff).mean(axis=1))
    p = np.mean(means >= abs(diff.mean()) - 1e-12)
    assert stats.smallest_sign_flip_p(n) == pytest.approx(p)
    assert np.isnan(stats.smallest_sign_flip_p(0))


def _cells():
    """Three subjects, two IMUs each, a set effect of 0.1 plus noise: cell means per set."""
    rows = []
    for s, offset in enumerate([0.0, 0.5, 1.0]):
        for imu, extra in (("a", 0.0), ("b", 0.2)):
            for rep in range(3):
                base = offset + extra + 0.01 * rep
                rows.append(
                    {
                        "subject": f"S{s}",
                        "imu": imu,
                        "rep": rep,
                        "set": "front",
                        "v": base + 0.1 + 0.02 * s,
                    }
                )
                rows.append({"subject": f"S{s}", "imu": imu, "rep": rep, "set": "side", "v": base})
    return pd.DataFrame(rows)


def test_cell_means_and_the_subject_test_average_cells_then_subjects():
    table = _cells()
    cells = stats.cell_means_by_set(
        table,
        "v",
        ["subject", "imu", "rep"],
        ["subject", "imu"],
        ["front", "side"],
        set_column="set",
    )
    assert len(cells) == 6
    by_hand = table.groupby(["subject", "imu", "set"])["v"].mean().unstack()
    np.testing.assert_allclose(cells["mean_a"], by_hand["front"].to_numpy())
    np.testing.assert_allclose(cells["mean_b"], by_hand["side"].to_numpy())
    test = stats.subject_test(cells)
    subjects = table.groupby(["subject", "set"])["v"].mean().unstack()
    reference = scipy_stats.ttest_rel(subjects["front"], subjects["side"])
    assert test["t"] == pytest.approx(reference.statistic) and test["n_groups"] == 3
    assert test["p"] == pytest.approx(reference.pvalue)
    assert test["smallest_p"] == pytest.approx(0.25)
    missing = stats.cell_means_by_set(
        table, "v", ["subject", "imu", "rep"], ["subject"], ["front", "top"], set_column="set"
    )
    assert missing.empty and list(missing.columns) == ["subject", "mean_a", "mean_b"]


def test_paired_by_set_pairs_units_and_averages_repeated_rows():
    table = _cells()
    out = stats.paired_by_set(table, "v", ["subject", "imu"], ["front", "side"], "set")
    wide = table.groupby(["subject", "imu", "set"])["v"].mean().unstack()
    assert out["n"] == 6
    assert out["t"] == pytest.approx(scipy_stats.ttest_rel(wide["front"], wide["side"]).statistic)
    assert stats.paired_by_set(table, "v", ["subject"], ["front", "top"], "set")["n"] == 0


def test_coverage_interval_is_clopper_pearson_below_five_subjects():
    hit = np.array([1, 1, 1, 0, 1, 1, 0, 1, 1, 1], float)
    low, high, how = stats.coverage_interval(hit, ["S1"] * 5 + ["S2"] * 5)
    ci = scipy_stats.binomtest(8, 10).proportion_ci(0.95, method="exact")
    assert how == "binomial" and (low, high) == pytest.approx((ci.low, ci.high), rel=1e-12)
    assert stats.coverage_interval([], [])[2] == ""


def test_coverage_interval_resamples_whole_subjects_from_five_on():
    """The same draws as the function's: subjects with replacement, the share of the drawn
    subjects' calibrations (not a mean of the subjects' shares)."""
    subjects = np.repeat([f"S{k}" for k in range(6)], [2, 4, 3, 5, 2, 4])
    hit = (np.arange(len(subjects)) % 3 != 0).astype(float)
    low, high, how = stats.coverage_interval(hit, subjects, n_resamples=300, seed=7)
    table = pd.DataFrame({"hit": hit, "subject": subjects}).groupby("subject")["hit"]
    sums, counts = table.sum().to_numpy(), table.count().to_numpy()
    draws = np.random.default_rng(7).integers(0, 6, size=(300, 6))
    shares = sums[draws].sum(axis=1) / counts[draws].sum(axis=1)
    assert how == "subjects"
    assert (low, high) == pytest.approx(tuple(np.percentile(shares, [2.5, 97.5])), rel=1e-12)
    assert low <= hit.mean() <= high
    every = stats.coverage_interval(np.ones(len(subjects)), subjects)
    assert every[:2] == (1.0, 1.0)


# --- the claims' estimates (report/claims.py, evaluation/verdicts.py) ---------------------------


def test_cell_estimates_are_scipys_simultaneous_intervals_over_subject_means():
    """Two cells: each cell's interval is scipy's t-interval of its subjects' means at
    1 - 0.05 / 2 (Bonferroni over the claim's two cells), not at 95 %."""
    rng = np.random.default_rng(3)
    frame = pd.DataFrame(
        {
            "subject": np.repeat([f"S{k}" for k in range(5)], 6),
            "segment": np.tile(["head", "thigh"], 15),
            "v": rng.normal(1.0, 0.3, 30),
        }
    )
    cells = claims.subject_cells(frame, ["segment"], "v")
    by_hand = frame.groupby(["subject", "segment"])["v"].mean()
    assert len(cells) == 10
    np.testing.assert_allclose(cells.set_index(["subject", "segment"])["v"], by_hand)
    labelled = claims.labelled(cells, ["segment"], "v")
    requirements = claims.every_cell(labelled, claims.Requirement.of("<", 2.0))
    estimates = verdicts.estimates(labelled, requirements).set_index("cell")
    for segment in ("head", "thigh"):
        values = by_hand.xs(segment, level="segment").to_numpy()
        row = estimates.loc[segment]
        assert row["mean"] == pytest.approx(values.mean()) and row["n"] == 5
        assert row["sd"] == pytest.approx(np.std(values, ddof=1))
        assert (row["low"], row["high"]) == pytest.approx(t_interval(values, 0.975), rel=1e-12)
        assert row["low"] < t_interval(values, 0.95)[0]  # wider than the unadjusted interval


def test_cell_labels_of_several_keys_join_each_key_in_order():
    cells = pd.DataFrame(
        {
            "subject": ["S1", "S2", "S1", "S2"],
            "a": ["x", "x", "y", "y"],
            "b": [1, 1, 2, 2],
            "v": [1.0, 2.0, 3.0, 5.0],
        }
    )
    labelled = claims.labelled(cells, ["a", "b"], "v")
    assert labelled["cell"].tolist() == ["x 1", "x 1", "y 2", "y 2"]
    estimates = verdicts.estimates(labelled, claims.every_cell(labelled, claims.Requirement()))
    assert estimates["cell"].tolist() == ["x 1", "y 2"]
    assert estimates["mean"].tolist() == [1.5, 4.0] and estimates["n"].tolist() == [2, 2]


def test_subject_cells_come_sorted_and_estimates_follow_the_requirements_order():
    """The subjects' cells sorted by subject and cell; the estimates in the order the claim lists
    its requirements, not in the order the rows arrived."""
    frame = pd.DataFrame(
        {
            "subject": ["S2", "S2", "S1", "S1", "S3"],
            "segment": ["thigh", "head", "thigh", "head", "head"],
            "v": [1.0, 2.0, 3.0, 4.0, 5.0],
        }
    )
    cells = claims.subject_cells(frame, ["segment"], "v")
    assert cells[["subject", "segment"]].values.tolist() == [
        ["S1", "head"],
        ["S1", "thigh"],
        ["S2", "head"],
        ["S2", "thigh"],
        ["S3", "head"],
    ]
    labelled = claims.labelled(cells.iloc[[1, 0, 3, 2, 4]], ["segment"], "v")  # thigh first
    requirement = claims.Requirement.of(">", 0.0)
    estimates = verdicts.estimates(labelled, {"head": requirement, "thigh": requirement})
    assert estimates["cell"].tolist() == ["head", "thigh"]
    assert estimates["mean"].tolist() == [pytest.approx(11 / 3), 2.0]


def _eta_by_hand(frame: pd.DataFrame, value: str, factors: list[str]) -> list[float]:
    """Type II eta squared of each factor from dummy-coded least squares (pandas, numpy)."""

    def residual(columns):
        X = np.column_stack(
            [np.ones(len(frame))]
            + [pd.get_dummies(frame[c], drop_first=True).to_numpy(float) for c in columns]
        )
        coef = np.linalg.lstsq(X, frame[value].to_numpy(float), rcond=None)[0]
        return float(((frame[value] - X @ coef) ** 2).sum())

    total = float(((frame[value] - frame[value].mean()) ** 2).sum())
    full = residual(factors)
    return [(residual([g for g in factors if g != f]) - full) / total for f in factors]


def test_variance_share_intervals_are_the_subjects_own_shares_t_interval():
    """The intervals of the shares (Obj 1-2's factors table): the mean over the subjects of each
    subject's own share (epsilon squared, :func:`subject_shares`) and its 95 % t-interval (the
    subject is the unit); the pooled eta squared beside them; neither depends on the units."""
    rng = np.random.default_rng(8)
    n = 160
    data = pd.DataFrame(
        {
            "subject": rng.choice([f"S{k}" for k in (3, 1, 7, 2, 8, 4, 6, 5)], n),
            "a": rng.choice(["p", "q", "r"], n),
            "b": rng.choice(["u", "v"], n),
        }
    )
    data["v"] = (data["a"] == "q") * 0.6 + (data["b"] == "u") * 0.3 + rng.normal(size=n)
    shares = stats.variance_shares(data, "v", ["a", "b"]).set_index("factor")
    np.testing.assert_allclose(shares["eta_squared"], _eta_by_hand(data, "v", ["a", "b"]))
    per_subject = stats.subject_shares(data, "v", ["a", "b"])
    assert sorted(per_subject.index) == [f"S{k}" for k in range(1, 9)]
    for factor in ("a", "b"):
        values = per_subject[factor].dropna().to_numpy()
        assert shares.loc[factor, "subject_mean"] == pytest.approx(values.mean())
        low, high = t_interval(values, 0.95)
        assert shares.loc[factor, ["low", "high"]].tolist() == pytest.approx([low, high])
    assert (shares["n"] == n).all() and (shares["n_subjects"] == 8).all()
    small = stats.variance_shares(data.assign(v=data["v"] / 1000), "v", ["a", "b"])
    columns = ["eta_squared", "subject_mean", "low", "high"]
    np.testing.assert_allclose(small[columns], shares.reset_index()[columns], rtol=1e-9)


def test_variance_shares_need_residual_degrees_of_freedom():
    """A saturated design (as many rows as parameters) or a constant value has no shares."""
    saturated = pd.DataFrame(
        {"subject": ["S1", "S2", "S3"], "a": ["p", "q", "r"], "v": [1.0, 2.0, 4.0]}
    )
    assert stats.variance_shares(saturated, "v", ["a"])["eta_squared"].isna().all()
    constant = saturated.assign(a=["p", "q", "q"], v=1.0)
    assert stats.variance_shares(constant, "v", ["a"])["eta_squared"].isna().all()


def test_coverage_interval_defaults_and_the_five_subject_boundary():
    """The published coverage intervals use the defaults: 1000 resamples of the subjects with
    seed 0, from five subjects on (four: Clopper-Pearson)."""
    rng = np.random.default_rng(2)
    subjects = np.repeat([f"S{k:02d}" for k in range(12)], rng.integers(3, 30, 12))
    hit = (rng.uniform(size=len(subjects)) < np.linspace(0.6, 1.0, len(subjects))).astype(float)
    table = pd.DataFrame({"hit": hit, "subject": subjects}).groupby("subject")["hit"]
    sums, counts = table.sum().to_numpy(), table.count().to_numpy()
    draws = np.random.default_rng(0).integers(0, 12, size=(1000, 12))
    shares = sums[draws].sum(axis=1) / counts[draws].sum(axis=1)
    expected = np.percentile(shares, [2.5, 97.5])
    assert np.percentile(shares, 98.5) != expected[1]  # the case tells percentiles apart
    low, high, how = stats.coverage_interval(hit, subjects)
    assert how == "subjects" and (low, high) == pytest.approx(tuple(expected), rel=1e-12)
    five = np.isin(subjects, [f"S{k:02d}" for k in range(5)])
    assert stats.coverage_interval(hit[five], subjects[five])[2] == "subjects"
    four = np.isin(subjects, [f"S{k:02d}" for k in range(4)])
    assert stats.coverage_interval(hit[four], subjects[four])[2] == "binomial"


def test_summary_ci_is_95_percent_by_default():
    assert stats.summary_ci(1.5, 0.4, 5) == stats.summary_ci(1.5, 0.4, 5, 0.95)
    assert stats.summary_ci(1.5, 0.4, 5)[1] == pytest.approx(1.5 + 2.776445 * 0.4 / np.sqrt(5))


def test_variance_share_intervals_need_two_subjects_and_a_share():
    rng = np.random.default_rng(3)
    data = pd.DataFrame(
        {
            "subject": rng.choice(["S1", "S2"], 60),
            "a": rng.choice(["p", "q"], 60),
            "c": "same",
            "v": rng.normal(size=60),
        }
    )
    two = stats.variance_shares(data, "v", ["a", "c"]).set_index("factor")
    assert np.isfinite(two.loc["a", ["low", "high"]].astype(float)).all()
    assert two.loc["c", ["eta_squared", "low", "high"]].isna().all()  # one level: no share
    one = stats.variance_shares(data.assign(subject="S1"), "v", ["a"])
    assert np.isfinite(one["eta_squared"]).all() and one[["low", "high"]].isna().all().all()


def _mixed_cells(seed: int = 4) -> pd.DataFrame:
    """Six subjects x three cells, a subject effect and a set effect of 0.2."""
    rng = np.random.default_rng(seed)
    rows = []
    for s in range(6):
        subject_effect = rng.normal(0, 0.15)
        for cell in ("l", "r", "c"):
            base = 1.0 + rng.normal(0, 0.1)
            rows.append(
                {
                    "subject": f"S{s}",
                    "cell": cell,
                    "mean_a": base + 0.2 + subject_effect + rng.normal(0, 0.05),
                    "mean_b": base,
                }
            )
    return pd.DataFrame(rows)


def test_mixed_model_of_cells_is_statsmodels_random_intercept_fit():
    """Tables 7, 8 and 10's mixed rows: every entry against MixedLM fitted here (REML)."""
    from statsmodels.regression.mixed_linear_model import MixedLM

    cells = _mixed_cells()
    out = stats.mixed_model_of_cells(cells)
    d = (cells["mean_a"] - cells["mean_b"]).to_numpy()
    fit = MixedLM(d, np.ones((len(d), 1)), groups=cells["subject"]).fit(reml=True)
    df = cells["subject"].nunique() - 1
    half = scipy_stats.t.ppf(0.975, df) * fit.bse[0]
    assert set(out) == {
        "mean_a",
        "mean_b",
        "mean_difference",
        "ci95_low",
        "ci95_high",
        "n",
        "n_groups",
        "t",
        "df",
        "p",
        "note",
        "fit_flags",
    }
    assert (out["n"], out["n_groups"], out["note"], out["fit_flags"]) == (18, 6, "", "")
    assert out["mean_a"] == pytest.approx(cells["mean_a"].mean())
    assert out["mean_b"] == pytest.approx(cells["mean_b"].mean())
    assert out["mean_difference"] == pytest.approx(fit.params[0], rel=1e-9)
    low, high = fit.params[0] - half, fit.params[0] + half
    assert (out["ci95_low"], out["ci95_high"]) == pytest.approx((low, high), rel=1e-9)
    assert out["t"] == pytest.approx(fit.tvalues[0], rel=1e-9) and out["df"] == df == 5
    assert out["p"] == pytest.approx(2 * scipy_stats.t.sf(abs(fit.tvalues[0]), df), rel=1e-9)
    empty = stats.mixed_model_of_cells(cells.iloc[:0])
    assert empty["n"] == 0 and empty["n_groups"] == 0 and np.isnan(empty["mean_b"])
    assert np.isnan(empty["mean_a"]) and empty["note"].startswith("not fitted")


@pytest.mark.parametrize(
    "message, converged, flags, tested",
    [
        # statsmodels' "retrying" of its other optimisers: the final fit decides, not the retry
        ("MixedLM optimization failed, trying a different optimizer may help.", True, "", True),
        ("Gradient optimization failed, |grad| = 0.3", True, "", True),
        ("Gradient optimization failed, |grad| = 0.3", False, "not_converged", False),
        (
            "The Hessian matrix at the estimated parameter values is not positive definite.",
            True,
            "hessian_not_pd",
            False,
        ),
        # statsmodels' absolute test (variance < 0.01 in the data's units) is not aceval's boundary
        ("The MLE may be on the boundary of the parameter space.", True, "", True),
    ],
)
def test_mixed_model_flags_how_the_final_fit_ended(monkeypatch, message, converged, flags, tested):
    """Issue 42: the flags read the final fit (its ``converged``, a Hessian warning) and the
    subjects' variance against the residual one, not statsmodels' intermediate warnings; a fit
    that did not converge or has no positive-definite Hessian has no p."""
    import warnings

    from statsmodels.regression.mixed_linear_model import MixedLM
    from statsmodels.tools.sm_exceptions import ConvergenceWarning

    real = MixedLM.fit

    def warned(self, *args, **kwargs):
        fit = real(self, *args, **kwargs)
        warnings.warn(message, ConvergenceWarning, stacklevel=2)
        fit.converged = converged
        return fit

    monkeypatch.setattr(MixedLM, "fit", warned)
    out = stats.mixed_model_of_cells(_mixed_cells())
    assert out["fit_flags"] == flags and np.isfinite(out["mean_difference"])
    assert np.isfinite(out["p"]) == tested and np.isfinite(out["ci95_low"]) == tested
    assert np.isfinite(out["ci95_high"]) == tested and np.isfinite(out["t"]) == tested


def test_two_pairs_are_a_test_and_their_sds_are_numbers():
    a, b = np.array([1.0, 2.5]), np.array([0.5, 1.0])
    out = stats.paired_ttest(a, b)
    reference = scipy_stats.ttest_rel(a, b)
    assert out["t"] == pytest.approx(reference.statistic) and out["p"] == pytest.approx(
        reference.pvalue
    )
    assert out["sd_a"] == pytest.approx(np.std(a, ddof=1)) and out["sd_b"] == pytest.approx(
        np.std(b, ddof=1)
    )


def test_the_mixed_model_needs_two_subjects_and_more_cells_than_subjects():
    cells = _mixed_cells()
    two = stats.mixed_model_of_cells(cells[cells["subject"].isin(["S0", "S1"])])
    assert two["note"] == "" and np.isfinite(two["mean_difference"]) and two["n_groups"] == 2
    one_each = stats.mixed_model_of_cells(cells.drop_duplicates("subject"))
    assert one_each["note"].startswith("not fitted") and np.isnan(one_each["p"])
    assert one_each["fit_flags"] == ""  # not fitted: no flag of a fit
