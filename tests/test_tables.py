"""Paired t-tests, Holm, the mixed model, the shares of variance and the paper's tables on
hand-computed cases."""

import numpy as np
import pandas as pd
import pytest

from aceval.evaluation.stats import holm, paired_by_set, paired_ttest
from aceval.report import kong2016
from aceval.report.outputs import find

from .runner import REPO

RESULTS = REPO / "results"


def test_paired_ttest_matches_a_hand_computation():
    """Differences 1, 2, 3: mean 2, SD 1, t = 2 / (1 / sqrt 3) = 3.464 with 2 df, p = 0.0742,
    95 % CI 2 +- 4.303 / sqrt 3, d_z = 2."""
    a = np.array([2.0, 4.0, 6.0])
    b = np.array([1.0, 2.0, 3.0])
    out = paired_ttest(a, b)
    assert out["n"] == 3 and out["mean_difference"] == pytest.approx(2.0)
    assert out["t"] == pytest.approx(2 * np.sqrt(3))
    assert out["p"] == pytest.approx(0.0742, abs=1e-4)
    assert (out["ci95_low"], out["ci95_high"]) == pytest.approx(
        (2 - 4.3027 / np.sqrt(3), 2 + 4.3027 / np.sqrt(3)), abs=1e-3
    )
    assert out["cohens_dz"] == pytest.approx(2.0)
    assert out["mean_a"] == pytest.approx(4.0) and out["sd_b"] == pytest.approx(1.0)


def test_paired_ttest_is_undefined_without_variation_or_pairs():
    out = paired_ttest(np.array([1.0, 2.0]), np.array([0.0, 1.0]))  # constant difference
    assert np.isnan(out["p"]) and out["mean_difference"] == 1.0
    assert paired_ttest(np.array([]), np.array([]))["n"] == 0
    with pytest.raises(ValueError, match="differ in length"):
        paired_ttest(np.ones(3), np.ones(4))


def test_holm_by_hand():
    # sorted 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> monotone 0.06
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])
    assert np.isnan(holm([np.nan, 0.5])[0]) and holm([np.nan, 0.5])[1] == 0.5


def test_pairing_drops_units_present_in_one_set_only():
    table = pd.DataFrame(
        {
            "unit": [1, 2, 3, 1, 2],
            "sensor_set": ["f", "f", "f", "l", "l"],
            "value": [1.0, 2.0, 9.0, 0.5, 1.0],
        }
    )
    out = paired_by_set(table, "value", ["unit"], ["f", "l"])
    assert out["n"] == 2 and out["mean_difference"] == pytest.approx(0.75)


def angle_rows(values_by_set: dict, comparison="test_retest", segment="head", test="T1"):
    rows = []
    for sensor_set, values in values_by_set.items():
        for k, value in enumerate(values):
            rows.append(
                {
                    "comparison": comparison,
                    "subject": "S1",
                    "sensor_set": sensor_set,
                    "imu": "IMU1",
                    "segment": segment,
                    "side": "center",
                    "test": test,
                    "k": 3,
                    "calibration_a": f"{test}:{k}",
                    "calibration_b": f"{test}:x",
                    "error_angle_deg": value,
                    "vertical_share": 1.0,
                }
            )
    return pd.DataFrame(rows)


def test_table9_mean_sd_n_published_value_and_flag():
    angles = angle_rows({"frontal": [1.0, 2.0, 3.0], "lateral": [0.5, 0.5, 0.5]})
    table = kong2016.build(9, None, angles, ["frontal", "lateral"])
    head = table[(table["t_ex"] == "T1") & (table["segment"] == "head")].iloc[0]
    assert head["n"] == 6
    assert head["mean"] == pytest.approx(np.mean([1, 2, 3, 0.5, 0.5, 0.5]), abs=1e-4)
    assert head["sd"] == pytest.approx(np.std([1, 2, 3, 0.5, 0.5, 0.5], ddof=1), abs=1e-4)
    assert head["published_mean"] == 0.345 and head["flag"] == ">1 deg"
    assert head["difference"] == pytest.approx(head["mean"] - 0.345, abs=1e-4)
    # rows of the paper this dataset has no data for are kept, with n = 0
    assert (table[table["t_ex"] == "T6"]["n"] == 0).all()
    markdown = kong2016.to_markdown(table, find("table", "9"), "demo", simulated=True)
    assert (
        "SIMULATED" in markdown
        and "1.250 ± 1.037 †" in markdown
        and "not in this dataset" in markdown
    )


def test_table8_names_the_set_with_the_smaller_angle():
    angles = angle_rows(
        {"frontal": [1.0, 2.0, 3.5], "lateral": [0.4, 0.6, 0.9]}, comparison="incremental"
    )
    table = kong2016.build(8, None, angles, ["frontal", "lateral"])
    head = table[(table["segment"] == "head") & (table["test"] == "paper")].iloc[0]
    assert head["better"] == "lateral" and head["published_better"] == "frontal"
    assert head["n"] == 3 and head["p_holm"] == pytest.approx(head["p"])  # one testable row
    assert "paper frontal" in kong2016.to_markdown(
        table, find("table", "8"), "demo", simulated=False
    )


def _two_imu_angles(effect, seed=3):
    """Per subject two IMUs (left and right thigh) x 20 test-retest angles per set; the frontal
    set worse by the subject's ``effect``."""
    rng = np.random.default_rng(seed)
    parts = []
    for s, e in enumerate(effect):
        for imu in ("thigh_l", "thigh_r"):
            for sensor_set, shift in (("frontal", e), ("lateral", 0.0)):
                rows = angle_rows({sensor_set: 1.0 + s / 5 + shift + rng.normal(0, 0.05, 20)},
                                  comparison="incremental", segment="thigh")  # fmt: skip
                parts.append(rows.assign(subject=f"S{s}", imu=imu))
    return pd.concat(parts, ignore_index=True)


def test_the_subject_is_the_unit_and_the_mixed_model_reads_its_cells():
    """Issue 27: 5 subjects x 2 thighs x 20 pooled angles per set. The paper-style test pairs 200
    dependent angles; the test on subjects pairs 5 subject means (left and right averaged inside
    the subject, checked against scipy by hand), with the smallest p an exact test reaches; the
    mixed model reads the 10 (subject, IMU) cells' differences, 5 groups."""
    from scipy import stats

    angles = _two_imu_angles([0.3, -0.2, 0.25, 0.1, -0.05])
    table = kong2016.build(8, None, angles, ["frontal", "lateral"]).set_index(["segment", "test"])
    paper, units, mixed = (table.loc[("thigh", t)] for t in ("paper", "units", "mixed"))
    assert paper["n"] == 200 and paper["p"] < 1e-4  # pooled: many dependent pairs, tiny p
    means = angles.groupby(["subject", "sensor_set"])["error_angle_deg"].mean().unstack()
    by_hand = stats.ttest_rel(means["frontal"], means["lateral"])
    assert units["n"] == 5 and units["p"] == pytest.approx(by_hand.pvalue, abs=1e-3)
    assert units["p"] > 0.05 and units["smallest_p"] == pytest.approx(2 / 2**5)
    assert mixed["n"] == 10 and mixed["n_groups"] == 5
    assert mixed["mean_difference"] == pytest.approx(
        means["frontal"].mean() - means["lateral"].mean(), abs=1e-3
    )
    assert np.isfinite(mixed["p"]) and "not_converged" not in mixed["fit_flags"]
    markdown = kong2016.to_markdown(
        kong2016.build(8, None, angles, ["frontal", "lateral"]), find("table", "8"), "demo", False
    )
    assert "paired t-test on subjects" in markdown and "random intercept per subject" in markdown


def test_one_subject_gives_no_subject_test_whatever_its_two_sides_say():
    """Issue 27's first point: one person's left vs right thigh is not a test (it gave p 0.0497)."""
    angles = _two_imu_angles([0.3])
    units = kong2016.build(8, None, angles, ["frontal", "lateral"]).set_index("test").loc["units"]
    assert units["n"] == 1 and np.isnan(units["p"])


def test_a_mixed_model_says_how_its_fit_ended(monkeypatch):
    """Issue 42. Every subject's cells average to the same set effect: the subjects' variance is
    estimated at zero, a boundary (singular) fit by the variance ratio, flagged and still tested;
    subjects that differ by more than their cells do: an interior fit, whatever the scale of the
    values (statsmodels' own warning compared the variance with 0.01 in the data's units). One
    subject only: not fitted, no p; a fit that did not converge keeps its estimate but has no p."""
    from aceval.evaluation import stats

    rng = np.random.default_rng(1)
    offset = rng.normal(0, 0.005, 6)  # the subjects differ far less than their cells
    cells = pd.DataFrame([
        {"subject": f"S{s}", "cell": imu, "mean_a": 1.0 + offset[s] + rng.normal(0, 0.1),
         "mean_b": 0.8}
        for s in range(6) for imu in ("l", "r")
    ])  # fmt: skip
    fit = stats.mixed_model_of_cells(cells)
    assert fit["fit_flags"] == "boundary" and fit["p"] < 1e-3
    assert fit["mean_difference"] == pytest.approx(0.2, abs=0.02) and fit["n_groups"] == 6
    subjects = rng.normal(0, 0.001, 6)  # tiny values, subjects apart by 10x their cells' spread
    interior = pd.DataFrame([
        {"subject": f"S{s}", "cell": imu, "mean_a": 0.002 + subjects[s] + rng.normal(0, 1e-4),
         "mean_b": 0.0}
        for s in range(6) for imu in ("l", "r")
    ])  # fmt: skip
    assert stats.mixed_model_of_cells(interior)["fit_flags"] == ""
    one = stats.mixed_model_of_cells(cells[cells["subject"] == "S0"])
    assert np.isnan(one["p"]) and one["note"].startswith("not fitted")
    real = stats._fit_differences
    monkeypatch.setattr(stats, "_fit_differences",
                        lambda d, g: (real(d, g)[0], ["not_converged"]))  # fmt: skip
    failed = stats.mixed_model_of_cells(cells)
    assert failed["fit_flags"] == "not_converged" and np.isnan(failed["p"])
    assert np.isfinite(failed["mean_difference"]) and np.isnan(failed["ci95_low"])


def test_an_interior_mixed_model_of_balanced_cells_is_the_subjects_t_test():
    """Issue 42: a Wald z with a normal reference gave p 0.211 where the subjects' t-test gave
    0.280. With two cells per subject and the subjects' variance interior, the REML estimate is
    the mean of the subjects' means and its t on subjects - 1 degrees of freedom is the paired
    t-test on the subjects: same estimate, interval and p."""
    from scipy import stats as scipy_stats

    from aceval.evaluation.stats import mixed_model_of_cells

    rng = np.random.default_rng(4)
    subject = rng.normal(0.05, 0.2, 6)
    cells = pd.DataFrame([
        {"subject": f"S{s}", "cell": imu, "mean_a": subject[s] + rng.normal(0, 0.05), "mean_b": 0.0}
        for s in range(6) for imu in ("l", "r")
    ])  # fmt: skip
    fit = mixed_model_of_cells(cells)
    means = cells.groupby("subject")["mean_a"].mean()
    t_test = scipy_stats.ttest_1samp(means, 0.0)
    assert fit["fit_flags"] == "" and fit["df"] == 5
    assert fit["mean_difference"] == pytest.approx(means.mean(), rel=1e-4)
    assert fit["p"] == pytest.approx(t_test.pvalue, rel=1e-3)
    ci = t_test.confidence_interval(0.95)
    assert (fit["ci95_low"], fit["ci95_high"]) == pytest.approx((ci.low, ci.high), rel=1e-3)


def test_the_smallest_p_an_exact_test_reaches():
    """2 / 2**n: 5 subjects cannot reach p < 0.05 (0.0625); p < 0.001 needs 11."""
    from aceval.evaluation.stats import smallest_sign_flip_p

    assert smallest_sign_flip_p(5) == pytest.approx(0.0625)
    assert smallest_sign_flip_p(10) > 0.001 > smallest_sign_flip_p(11)


def test_variance_shares_equal_statsmodels_type_ii_with_the_interaction_and_per_subject():
    """The array-based shares are anova_lm's type II sums of squares over the total, on an
    unbalanced table with an interaction; a factor's share with its interaction is the model
    without any term containing it against the full one; each subject's own share, chance
    removed (epsilon squared), averages to about 0 for a factor with no effect."""
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    from aceval.evaluation.stats import subject_shares, variance_shares

    rng = np.random.default_rng(1)
    n = 600
    data = pd.DataFrame({"subject": rng.integers(0, 6, n), "a": rng.integers(0, 4, n),
                         "b": rng.choice(list("xyz"), n), "c": rng.integers(0, 5, n)})  # fmt: skip
    data["v"] = (0.2 * data["a"] + (data["b"] == "x") * 0.5
                 + ((data["a"] == 2) & (data["b"] == "y")) * 0.8 + rng.normal(size=n))  # fmt: skip
    shares = variance_shares(data, "v", ["a", "b", "c"], [("a", "b")]).set_index("factor")
    anova = anova_lm(smf.ols("v ~ C(a) * C(b) + C(c)", data).fit(), typ=2)
    total = ((data["v"] - data["v"].mean()) ** 2).sum()
    for term, name in (("a", "C(a)"), ("b", "C(b)"), ("c", "C(c)"), ("a:b", "C(a):C(b)")):
        assert shares.loc[term, "eta_squared"] == pytest.approx(
            anova.loc[name, "sum_sq"] / total, rel=1e-9
        )
    without_a = smf.ols("v ~ C(b) + C(c)", data).fit().ssr
    full = smf.ols("v ~ C(a) * C(b) + C(c)", data).fit().ssr
    assert shares.loc["a", "involved"] == pytest.approx((without_a - full) / total, rel=1e-9)
    per_subject = subject_shares(data, "v", ["a", "b", "c"], [("a", "b")])
    assert len(per_subject) == 6 and abs(per_subject["c"].mean()) < 0.02
    assert shares.loc["c", "low"] < 0.01 and shares.loc["a", "subject_mean"] > 0.05
    assert (shares["n_subjects"] == 6).all()
    one_level = variance_shares(data.assign(b="x"), "v", ["a", "b"]).set_index("factor")
    assert np.isnan(one_level.loc["b", "eta_squared"])
    # a factor the others span (a design that confounds it) has no share of its own: not a number
    confounded = variance_shares(data.assign(d=data["b"]), "v", ["a", "b", "d"]).set_index("factor")
    assert confounded.loc["a", "aliased"] == 0 and confounded.loc["b", "aliased"] == 2
    assert np.isnan(confounded.loc["b", "eta_squared"]) and np.isnan(
        confounded.loc["d", "eta_squared"]
    )


def test_table3_and_table11_average_their_units_beside_the_paper():
    """Table 3: one unit per subject x IMU x T_ex x T_ap, its repetitions averaged (0.98 and 0.96
    -> 0.97 for S1, 0.99 for S2: mean 0.98, n 2), the paper's 0.803 beside the feet in T6, the
    flagged row left out; Table 11: the cross-test angles per pair of tests and segment."""
    base = {"objective": "frontal_lateral", "signal": "acc", "sensor_set": "frontal", "imu": "foot_l",
            "segment": "foot", "t_ex": "T6", "t_ap": "T6", "flag": ""}  # fmt: skip
    correlations = pd.DataFrame([
        {**base, "subject": "S1", "rep": 1, "correlation": 0.98},
        {**base, "subject": "S1", "rep": 2, "correlation": 0.96},
        {**base, "subject": "S2", "rep": 1, "correlation": 0.99},
        {**base, "subject": "S2", "rep": 2, "correlation": 0.2, "flag": "lag_at_bound"},
    ])  # fmt: skip
    foot = (
        kong2016.build(3, correlations, None, []).set_index(["t_ap", "segment"]).loc[("T6", "foot")]
    )
    assert foot["mean"] == pytest.approx(0.98) and foot["n"] == 2
    assert foot["published_mean"] == 0.803 and foot["published_flag"] == "<=0.95"
    angles = angle_rows(
        {"frontal": [4.0, 6.0]}, comparison="cross_test", segment="foot", test="T5-T6"
    )
    row = (
        kong2016.build(11, None, angles, [])
        .set_index(["t_ex_pair", "segment"])
        .loc[("T5-T6", "foot")]
    )
    assert (
        row["mean"] == pytest.approx(5.0) and row["n"] == 2 and np.isfinite(row["published_mean"])
    )


def test_tables_refuse_numbers_the_paper_does_not_have():
    with pytest.raises(ValueError, match="Table 12"):
        kong2016.build(12, None, None, ["a", "b"])


def test_one_sensor_set_gives_untestable_ttests_and_an_explicit_figure(tmp_path):
    from aceval.report import figures

    angles = angle_rows({"main": [1.0, 2.0, 3.0]}, comparison="incremental")
    table = kong2016.build(8, None, angles, ["main"])
    assert (table["n"] == 0).all() and table["p"].isna().all()
    from aceval.evaluation.correlations import CORRELATION_COLUMNS

    empty = pd.DataFrame(columns=CORRELATION_COLUMNS)
    figures.plot(6, empty, None, tmp_path / "figure6.png", "demo")
    assert (tmp_path / "figure6.png").stat().st_size > 0


def recomputed_set_tests(datasets) -> int:
    """Issue 27: the p of each committed Table 7, 8, 10 test on subjects and of each mixed model
    of ``datasets`` follows from the committed cells (results/*/tables/set_test_units.csv):
    scipy's paired t-test on the subjects' means, statsmodels' MixedLM on the cells' differences.
    The number of t-tests checked."""
    from scipy import stats

    from aceval.evaluation.stats import mixed_model_of_cells

    checked = 0
    for dataset in datasets:
        units_path = RESULTS / dataset / "tables" / "set_test_units.csv"
        units = pd.read_csv(units_path)
        for (number, row), cells in units.groupby(["table", "row"]):
            table = pd.read_csv(units_path.parent / f"table{number}.csv")
            committed = table[table[table.columns[0]] == row].set_index("test")
            subjects = cells.groupby("subject")[["mean_a", "mean_b"]].mean()
            assert committed.loc["units", "n"] == len(subjects), (units_path, number, row)
            if len(subjects) > 1 and (subjects["mean_a"] - subjects["mean_b"]).std() > 0:
                p = stats.ttest_rel(subjects["mean_a"], subjects["mean_b"]).pvalue
                assert p == pytest.approx(committed.loc["units", "p"], rel=0.01, abs=2e-4)
                checked += 1
            mixed = mixed_model_of_cells(cells)
            assert committed.loc["mixed", "n"] == mixed["n"], (units_path, number, row)
            if np.isfinite(committed.loc["mixed", "p"]):
                assert mixed["p"] == pytest.approx(committed.loc["mixed", "p"], rel=0.01, abs=2e-4)
    return checked


#: the committed datasets with set tests; the powered design's (93 subjects) in the slow tier
SET_TESTS = sorted(p.parent.parent.name for p in RESULTS.glob("*/tables/set_test_units.csv"))
POWERED = "kong_powered"


def test_every_committed_set_test_is_recomputed_from_its_committed_cells():
    assert POWERED in SET_TESTS
    assert recomputed_set_tests([d for d in SET_TESTS if d != POWERED]) >= 10


@pytest.mark.slow  # 14 mixed models of 93 subjects (1.5 CPU-s)
def test_every_committed_set_test_of_the_powered_design_is_recomputed_from_its_cells():
    assert recomputed_set_tests([POWERED]) >= 10


def test_every_p_value_column_is_written_by_one_rule_in_the_csvs_and_the_markdown():
    """p, p_holm and flag_value's p_value: 3 significant digits in a CSV (4 decimals would write
    1e-5 as 0.0, a p of exactly 0), '<0.001' below 0.001 in Markdown (not 0.000), 3 decimals
    from 0.001 up, 'n/a' without one; any other float keeps 4 decimals / 3 decimals."""
    p = [1.234e-5, 0.000996, 0.001, 0.01234, 0.5, np.nan]
    table = pd.DataFrame({"p": p, "p_holm": p, "p_value": p, "median_deg": [1.23456, 1e-5] * 3})
    csv = kong2016.rounded(table.copy())
    for column in ("p", "p_holm", "p_value"):
        assert csv[column].tolist()[:5] == [1.23e-5, 0.000996, 0.001, 0.0123, 0.5]
        assert np.isnan(csv[column].iloc[5])
    assert csv["median_deg"].tolist()[:2] == [1.2346, 0.0]
    text = kong2016.named_markdown(table, "a table", "units", "lab", False)
    rows = [line.split("|")[1:-1] for line in text.splitlines() if line.startswith("| ")][1:]
    cells = [[c.strip() for c in row] for row in rows]
    for k in range(3):
        column = [row[k] for row in cells]
        assert column == ["<0.001", "<0.001", "0.001", "0.012", "0.500", "n/a"]
    assert [row[3] for row in cells][:2] == ["1.235", "0.000"]
