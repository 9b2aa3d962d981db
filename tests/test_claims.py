"""The claims' verdicts (issue 27): the four kinds, the rules on built evidence, and the sources
the rules cite, each on a case whose answer is known by hand."""

import numpy as np
import pandas as pd
import pytest

from aceval.report import claims, kong_claims, ricci2014, ricci_claims, summary
from aceval.report.claims import FAILS, HOLDS, INCONCLUSIVE, UNTESTABLE


def test_a_verdict_follows_the_interval_and_can_be_inconclusive():
    assert claims.beyond(1.0, 2.0, 0.5, ">") == HOLDS
    assert claims.beyond(0.1, 0.4, 0.5, ">") == FAILS
    assert claims.beyond(0.4, 0.6, 0.5, ">") == INCONCLUSIVE
    assert claims.beyond(np.nan, np.nan, 0.5, "<") == INCONCLUSIVE  # one subject: no interval
    # two one-sided tests: the 90 % interval inside the margin, or the 95 % one wholly outside
    assert claims.equivalent(-0.01, 0.01, -0.02, 0.02, 0.019) == HOLDS
    assert claims.equivalent(0.03, 0.05, 0.025, 0.06, 0.019) == FAILS
    assert claims.equivalent(-0.01, 0.03, -0.02, 0.04, 0.019) == INCONCLUSIVE
    assert claims.every([HOLDS, INCONCLUSIVE]) == INCONCLUSIVE
    assert claims.every([HOLDS, FAILS, INCONCLUSIVE]) == FAILS
    assert claims.every([]) == UNTESTABLE


def _angles(values: dict, comparison="test_retest", k=3) -> pd.DataFrame:
    """values[(subject, test, segment)] = error angles -> an angles table."""
    rows = [
        {"comparison": comparison, "subject": s, "test": t, "segment": seg, "k": k,
         "error_angle_deg": v, "vertical_share": 1.0}
        for (s, t, seg), vs in values.items() for v in vs
    ]  # fmt: skip
    return pd.DataFrame(rows)


def _evidence(tables=None, angles=None, correlations=None, calibrations=None):
    return kong_claims.Evidence(tables or {}, correlations, angles, calibrations)


def _verdict(rules, start, evidence):
    rule = next(r for r in rules if r.claim.startswith(start))
    return rule.apply(evidence)


def test_obj4_is_judged_on_the_subjects_interval():
    """Five subjects with test-retest angles around 0.5 deg: below Kong's 1 deg; around 1.0 with a
    wide spread: inconclusive; around 1.5: does not hold; one subject: inconclusive (no interval)."""
    rng = np.random.default_rng(0)

    def judged(centre, spread, subjects=5):
        angles = _angles({(f"S{s}", "T1", "head"): centre + rng.normal(0, spread, 3)
                          for s in range(subjects)})  # fmt: skip
        return _verdict(kong_claims.RULES, "< 1 deg excluding", _evidence(angles=angles)).verdict

    assert judged(0.5, 0.05) == HOLDS
    assert judged(1.0, 0.3) == INCONCLUSIVE
    assert judged(1.5, 0.05) == FAILS
    assert judged(0.5, 0.05, subjects=1) == INCONCLUSIVE
    claim = _verdict(kong_claims.RULES, "< 1 deg excluding", _evidence())
    assert claim.verdict == UNTESTABLE
    box = _angles({("box", "EDGE", "box"): [0.3, 0.4]})  # a rigid box is not a body segment
    assert (
        _verdict(kong_claims.RULES, "< 1 deg excluding", _evidence(angles=box)).verdict
        == UNTESTABLE
    )


def _set_rows(number, segments, low, high, n=5):
    return {number: pd.DataFrame({"segment": segments, "test": "units", "mean_difference":
                                  (np.array(low) + np.array(high)) / 2, "ci95_low": low,
                                  "ci95_high": high, "n": n})}  # fmt: skip


def test_set_preference_reads_the_interval_and_says_when_the_paper_p_is_out_of_reach():
    """Frontal better for the head (difference < 0), lateral for the thigh (> 0): holds when both
    intervals exclude 0 on the paper's side; the paper's p < 0.001 cannot be reached by an exact
    test on 5 subjects, and the numbers say so."""
    rule = kong_claims._set_preference(8)
    holds = rule(_evidence(_set_rows(8, ["head", "thigh"], [-0.9, 0.2], [-0.3, 0.8])))
    assert holds[0] == HOLDS and "out of reach by design" in holds[1]
    assert rule(_evidence(_set_rows(8, ["head", "thigh"], [0.1, 0.2], [0.5, 0.8])))[0] == FAILS
    assert (
        rule(_evidence(_set_rows(8, ["head", "thigh"], [-0.9, -0.1], [-0.3, 0.8])))[0]
        == INCONCLUSIVE
    )
    assert "out of reach" not in rule(_evidence(_set_rows(8, ["head"], [-0.9], [-0.3], n=12)))[1]
    assert rule(_evidence())[0] == UNTESTABLE


def test_no_difference_is_an_equivalence_within_the_papers_sd():
    """Table 7: thighs-shanks 'no difference' holds when the difference's 90 % interval lies in
    +-0.019 (the paper's SD), not because p >= 0.05."""

    def table7(ts_low, ts_high, n=10):
        return {7: pd.DataFrame({"pair": ["head-chest", "thighs-shanks"], "test": "units",
                                 "mean_difference": [-0.02, (ts_low + ts_high) / 2],
                                 "ci95_low": [-0.03, ts_low], "ci95_high": [-0.01, ts_high],
                                 "n": n})}  # fmt: skip

    assert kong_claims._segment_pair_sets(_evidence(table7(-0.005, 0.005)))[0] == HOLDS
    # p would be far above 0.05 here, but the interval reaches beyond the margin: not shown equal
    assert kong_claims._segment_pair_sets(_evidence(table7(-0.04, 0.04)))[0] == INCONCLUSIVE
    assert kong_claims._segment_pair_sets(_evidence(table7(0.03, 0.05)))[0] == FAILS


def test_shares_of_variance_are_judged_on_their_intervals_against_cohens_sizes():
    def factors(t_ex, t_ap, segment):
        rows = [("t_ex", *t_ex), ("t_ap", *t_ap), ("segment", *segment)]
        return {"correlation_factors": pd.DataFrame(
            [{"objective": "Obj 1", "factor": f, "eta_squared": (lo + hi) / 2, "low": lo, "high": hi,
              "n": 100} for f, lo, hi in rows])}  # fmt: skip

    assert kong_claims._factors(_evidence(factors((0, 0.005), (0.2, 0.3), (0.15, 0.4))))[0] == HOLDS
    assert (
        kong_claims._factors(_evidence(factors((0.02, 0.05), (0.2, 0.3), (0.15, 0.4))))[0] == FAILS
    )
    assert (
        kong_claims._factors(_evidence(factors((0, 0.005), (0.1, 0.3), (0.15, 0.4))))[0]
        == INCONCLUSIVE
    )


def test_the_obj1_claim_shows_the_sensitivity_curve_beside_it():
    """Issue 27: 'mostly > 0.95' holds even when a 30 deg heading error keeps the correlation
    above 0.95; the claim's numbers say so, and the smallest error detected in half the units."""
    curve = pd.DataFrame({"mode": "concatenated", "heading_error_deg": [0.0, 10.0, 30.0],
                          "mean": [0.998, 0.99, 0.971], "detected_share": [0.05, 0.2, 0.6]})  # fmt: skip
    text = kong_claims._insensitivity(curve)
    assert (
        "still above 0.95" in text and "0.998 -> 0.971" in text and "30 deg" in text.split(";")[-1]
    )
    assert "still above" not in kong_claims._insensitivity(curve.assign(mean=[0.9, 0.85, 0.8]))
    assert "no heading error" in kong_claims._insensitivity(curve.assign(detected_share=0.1))
    assert kong_claims._insensitivity(None) == ""


def test_obj1_detection_uses_a_reference_per_segment_and_t_ap():
    """Two cells whose correct correlations differ (0.99 and 0.90): a unit turned so that it
    falls to 0.95 is detected in the first cell and not in the second; a reference pooled over
    both cells would miss it (0.95 is above the pooled 5th percentile)."""
    from aceval.report.kong2016 import correlation_sensitivity

    rows = []
    for seg, base in (("head", 0.99), ("foot", 0.90)):
        for s in range(20):
            for error, value in (
                (0.0, base + 0.001 * (s % 5)),
                (30.0, 0.95 if seg == "head" else base),
            ):
                rows.append({"objective": "frontal_lateral_sensitivity", "subject": f"S{s}",
                             "imu": seg, "segment": seg, "t_ex": "T1", "t_ap": "T1",
                             "mode": "concatenated", "heading_error_deg": error, "rep": 1,
                             "correlation": value, "flag": ""})  # fmt: skip
    table = correlation_sensitivity(pd.DataFrame(rows)).set_index("heading_error_deg")
    assert table.loc[30.0, "detected_share"] == pytest.approx(0.5)  # every head unit, no foot one
    assert table.loc[0.0, "detected_share"] == 0.0


def test_claims_true_by_construction_are_checks_of_the_code():
    code = [r for r in kong_claims.RULES + ricci_claims.RULES if r.section == claims.CODE]
    assert {r.objective for r in code} == {"Obj 3-5", "Ricci residuals"}


def test_ricci_supported_movement_is_judged_on_the_childrens_interval():
    """The paper's reading (FEB vs FE, the same movement) decides; the elbow movement FFEB is a
    second reading that does not."""
    ttest = pd.DataFrame({
        "reading": [ricci2014.PRIMARY_READING] * 2 + ["elbow vs shoulder movement (FFEB vs FE)"],
        "segment": ["upper_arm_r", "forearm_r", "forearm_r"], "supported": ["FEB", "FEB", "FFEB"],
        "unsupported": ["FE", "FE", "FE"], "n": 40, "mean_difference": [0.05, 0.04, -0.02],
        "ci95_low": [0.03, 0.01, -0.05], "ci95_high": [0.07, 0.07, 0.01], "p": [1e-4, 0.01, 0.3],
    })  # fmt: skip
    evidence = ricci_claims.Evidence({"ricci_ttest": ttest}, None)
    assert ricci_claims._supported(evidence)[0] == HOLDS
    ttest.loc[1, "ci95_low"] = -0.01
    assert ricci_claims._supported(evidence)[0] == INCONCLUSIVE


def test_ricci_table1_and_iterations_are_equivalences_within_the_papers_sd():
    table1 = pd.DataFrame({"test": ["TS/US/FS", "TS/US/FS"], "segment": ["thorax", "forearm_l"],
                           "mean": [0.975, 0.97], "sd": [0.01, 0.01], "n": 40,
                           "published_mean": [0.98, 0.97], "published_sd": [0.006, 0.022]})  # fmt: skip
    assert ricci_claims._static(ricci_claims.Evidence({"ricci_table1": table1}, None))[0] == HOLDS
    low = table1.assign(mean=[0.95, 0.97])  # 0.95 < 0.97 - 0.006: below the paper's 'about'
    assert ricci_claims._static(ricci_claims.Evidence({"ricci_table1": low}, None))[0] == FAILS
    moving = table1.assign(test="FE", mean=[0.978, 0.97], published_mean=[0.98, 0.97])
    assert (
        ricci_claims._movements(ricci_claims.Evidence({"ricci_table1": moving}, None))[0] == HOLDS
    )
    far = moving.assign(mean=[0.95, 0.97])
    assert ricci_claims._movements(ricci_claims.Evidence({"ricci_table1": far}, None))[0] == FAILS
    rng = np.random.default_rng(0)
    calibrations = pd.DataFrame([
        {"method": "ricci_lm", "subject": f"C{c}", "segment": seg, "side": side,
         "n_iterations": mean + rng.integers(-1, 2)}
        for c in range(40) for seg, mean in (("thorax", 6), ("forearm", 7)) for side in ("l", "r")
    ])  # fmt: skip
    verdict, numbers = ricci_claims._iterations(ricci_claims.Evidence({}, calibrations))
    assert verdict == HOLDS and "n 40 children" in numbers  # a child's two sides are one unit
    slow = calibrations.assign(n_iterations=calibrations["n_iterations"] + 3)
    assert ricci_claims._iterations(ricci_claims.Evidence({}, slow))[0] == FAILS


def test_summary_counts_every_kind_of_verdict():
    found = [claims.Claim("Obj 1", "a", "r", HOLDS, ""), claims.Claim("Obj 1", "b", "r", INCONCLUSIVE, ""),
             claims.Claim("Obj 1", "c", "r", UNTESTABLE, "")]  # fmt: skip
    text = summary.to_markdown(found, "demo", "a demo", False, [])
    assert "1 hold, 0 do not hold, 1 inconclusive, 1 not testable" in text
