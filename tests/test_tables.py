"""Paired t-tests, Holm, the paper's tables and the claim checks on hand-computed cases."""

import numpy as np
import pandas as pd
import pytest

from aceval.evaluation.stats import holm, paired_by_set, paired_ttest
from aceval.report import kong2016, kong_claims, summary
from aceval.report.outputs import find


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


def test_independent_units_and_mixed_model_on_a_known_table():
    """5 subjects x 20 pooled angles per set: the paper-style test pairs 100 dependent angles; the
    test on independent units pairs the 5 subject means (checked against scipy on means computed
    here); the mixed model's contrast is the difference of the means (balanced design)."""
    from scipy import stats

    rng = np.random.default_rng(3)
    effect = np.array(
        [0.3, -0.2, 0.25, 0.1, -0.05]
    )  # a set effect that changes sign across subjects
    parts = []
    for s, e in enumerate(effect):
        base = 1.0 + s / 5
        for sensor_set, shift in (("frontal", e), ("lateral", 0.0)):
            rows = angle_rows(
                {sensor_set: base + shift + rng.normal(0, 0.05, 20)}, comparison="incremental"
            )
            parts.append(rows.assign(subject=f"S{s}"))
    angles = pd.concat(parts, ignore_index=True)
    table = (
        kong2016.build(8, None, angles, ["frontal", "lateral"])
        .set_index(["segment", "test"])
        .loc["head"]
    )
    paper, units, mixed = table.loc["paper"], table.loc["units"], table.loc["mixed"]
    assert paper["n"] == 100 and paper["p"] < 1e-4  # pooled: many dependent pairs, tiny p
    means = angles.groupby(["subject", "sensor_set"])["error_angle_deg"].mean().unstack()
    by_hand = stats.ttest_rel(means["frontal"], means["lateral"])
    assert (
        units["n"] == 5
        and units["p"] == pytest.approx(by_hand.pvalue, abs=1e-3)
        and units["p"] > 0.05
    )
    assert mixed["mean_difference"] == pytest.approx(
        means["frontal"].mean() - means["lateral"].mean(), abs=1e-4
    )
    assert mixed["n"] == 100 and mixed["n_groups"] == 5  # the paired differences
    assert mixed["fit_flags"] in ("", "boundary") and np.isfinite(mixed["p"])
    markdown = kong2016.to_markdown(
        kong2016.build(8, None, angles, ["frontal", "lateral"]), find("table", "8"), "demo", False
    )
    assert "paired t-test on subjects" in markdown and "random intercept per subject" in markdown


def test_a_mixed_model_says_how_its_fit_ended():
    """The same set effect in every subject: the subject's variance is estimated at zero, a
    boundary (singular) fit, flagged and still tested; one subject only: not fitted, no p."""
    from aceval.evaluation.stats import mixed_model_by_set

    rng = np.random.default_rng(0)
    rows = [
        {"subject": f"S{s}", "imu": "IMU1", "rep": r, "sensor_set": name, "v": value}
        for s in range(6)
        for r in range(8)
        for name, value in (("a", 1.0 + rng.normal(0, 0.1)), ("b", 0.8 + rng.normal(0, 0.1)))
    ]
    table = pd.DataFrame(rows)
    fit = mixed_model_by_set(table, "v", ["subject", "imu", "rep"], ["a", "b"])
    assert "boundary" in fit["fit_flags"].split(";") and fit["p"] < 1e-6
    assert fit["mean_difference"] == pytest.approx(0.2, abs=0.05) and fit["n_groups"] == 6
    one = mixed_model_by_set(
        table[table["subject"] == "S0"], "v", ["subject", "imu", "rep"], ["a", "b"]
    )
    assert np.isnan(one["p"]) and one["note"].startswith("not fitted")


def _claim(claims, start):
    return next(c for c in claims if c.claim.startswith(start))


def test_claim_rules_hold_and_fail_on_built_tables():
    # Obj 1-2: T_ex unrelated, T_ap and segment related
    factors = pd.DataFrame({"objective": "Obj 1", "factor": ["t_ex", "t_ap", "segment"],
                            "eta_squared": [0.01, 0.3, 0.2], "n": 120})  # fmt: skip
    assert kong_claims.factor_claim(factors).verdict == summary.HOLDS
    assert (
        kong_claims.factor_claim(factors.assign(eta_squared=[0.08, 0.3, 0.2])).verdict
        == summary.FAILS
    )
    # Obj 5: the recommended tests agree with the designed ones within about 5 deg (Table 11)
    table11 = pd.DataFrame({"t_ex_pair": ["T1-T3", "T2-T3", "T5-T6", "T4-T6"],
                            "segment": ["head", "chest", "thigh", "shank"], "mean": [3.0, 5.2, 4.4, 3.7],
                            "n": 4})  # fmt: skip
    assert kong_claims.recommendation_claim(table11).verdict == summary.HOLDS
    assert (
        kong_claims.recommendation_claim(table11.assign(mean=[3.0, 6.1, 4.4, 3.7])).verdict
        == summary.FAILS
    )
    # set preference, judged on the independent units with the paper's raw p < 0.001
    rows = pd.DataFrame({"segment": ["head", "thigh"], "test": "units", "set_a": "frontal",
                         "set_b": "lateral", "better": ["frontal", "lateral"], "p": [1e-4, 5e-4],
                         "n": 10})  # fmt: skip
    assert kong_claims._set_preference(rows, "Obj 3", "x").verdict == summary.HOLDS
    assert (
        kong_claims._set_preference(rows.assign(p=[1e-4, 0.01]), "Obj 3", "x").verdict
        == summary.FAILS
    )
    pooled = rows.assign(test="paper")  # the pooled test is not what the claim is judged on
    assert kong_claims._set_preference(pooled, "Obj 3", "x").verdict == summary.UNTESTABLE
    # Obj 2 (Table 7), raw p on independent units
    t6 = pd.DataFrame({"pair": ["head-chest"], "t_ap": ["T1"], "mean": [0.97], "n": [5]})
    t7 = pd.DataFrame({"pair": ["head-chest", "thighs-shanks"], "test": "units", "mean_a": [0.96, 0.97],
                       "mean_b": [0.97, 0.97], "p": [0.005, 0.6], "n": 5})  # fmt: skip
    verdict = _claim(kong_claims.obj2_claims(t6, t7), "Paired t-test").verdict
    assert verdict == summary.HOLDS
    t7.loc[0, "p"] = 0.02
    assert _claim(kong_claims.obj2_claims(t6, t7), "Paired t-test").verdict == summary.FAILS
    # the z0 check is reported as a check of the code, not as a claim
    angles = angle_rows({"frontal": [1.0, 2.0]})
    assert [c.section for c in kong_claims.code_checks(angles)] == [summary.CODE]
    assert all(c.section == summary.PAPER for c in kong_claims.obj5_claims(table11))


def test_tables_refuse_numbers_the_paper_does_not_have():
    with pytest.raises(ValueError, match="Table 12"):
        kong2016.build(12, None, None, ["a", "b"])


def test_claims_with_known_tables():
    table9 = pd.DataFrame(
        {"t_ex": ["T1", "T5"], "segment": ["head", "foot"], "mean": [0.5, 1.8], "n": [4, 4]}
    )
    verdicts = {c.claim: c.verdict for c in kong_claims.obj4_claims(table9, None)}
    assert verdicts["Any-3-of-5 test-retest error angle < 2.1 deg on average"] == summary.HOLDS
    assert verdicts["< 1 deg excluding T5 and the feet"] == summary.HOLDS
    table9.loc[0, "mean"] = 1.2
    verdicts = {c.claim: c.verdict for c in kong_claims.obj4_claims(table9, None)}
    assert verdicts["< 1 deg excluding T5 and the feet"] == summary.FAILS
    assert all(c.verdict == summary.UNTESTABLE for c in kong_claims.obj2_claims(None, None))


def test_one_sensor_set_gives_untestable_ttests_and_an_explicit_figure(tmp_path):
    from aceval.report import figures

    angles = angle_rows({"main": [1.0, 2.0, 3.0]}, comparison="incremental")
    table = kong2016.build(8, None, angles, ["main"])
    assert (table["n"] == 0).all() and table["p"].isna().all()
    from aceval.evaluation.correlations import CORRELATION_COLUMNS

    empty = pd.DataFrame(columns=CORRELATION_COLUMNS)
    figures.plot(6, empty, None, tmp_path / "figure6.png", "demo")
    assert (tmp_path / "figure6.png").stat().st_size > 0


def test_every_committed_subject_test_is_recomputed_from_its_committed_units():
    """Issue 27: the p of each committed Table 7, 8, 10 row's test on subjects follows from the
    committed per-subject means (results/*/tables/set_test_units.csv) by scipy's paired t-test."""
    from scipy import stats

    from .runner import REPO

    checked = 0
    for units_path in sorted((REPO / "results").glob("*/tables/set_test_units.csv")):
        units = pd.read_csv(units_path)
        for (number, row), group in units.groupby(["table", "row"]):
            table = pd.read_csv(units_path.parent / f"table{number}.csv")
            key = table.columns[0]
            committed = table[(table[key] == row) & (table["test"] == "units")].iloc[0]
            assert committed["n"] == len(group), (units_path, number, row)
            if len(group) > 1 and (group["mean_a"] - group["mean_b"]).std() > 0:
                p = stats.ttest_rel(group["mean_a"], group["mean_b"]).pvalue
                assert p == pytest.approx(committed["p"], rel=0.01, abs=2e-4), (number, row)
                checked += 1
    assert checked >= 10


def test_the_obj1_claim_shows_the_sensitivity_curve_beside_it():
    """Issue 27: 'mostly > 0.95' holds even when a 30 deg heading error keeps the correlation
    above 0.95; the claim's numbers say so, from table obj1_sensitivity."""
    from aceval.report.kong_claims import _insensitivity

    curve = pd.DataFrame(
        {"mode": "concatenated", "heading_error_deg": [0.0, 30.0], "mean": [0.998, 0.971]}
    )
    assert "still above 0.95" in _insensitivity(curve) and "0.998 -> 0.971" in _insensitivity(curve)
    assert "still above" not in _insensitivity(curve.assign(mean=[0.9, 0.8]))
    assert _insensitivity(None) == ""
