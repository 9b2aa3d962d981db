"""For every sensor, the calibration to use against the lab's tolerance: the methods' disagreement
can fire, the choice rests on evidence from the other sensors and does not flip on a tie, the
verdicts follow the tolerance, and the chosen rotation is in the row (aceval.evaluation.decision,
decision_evidence, decision_rules). Numbers chosen so that the rule and its plausible variants
(the cones or the spreads summed instead of in quadrature, the cone sorted before the evidence,
the sensor's own error as its evidence) give different answers."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.calibrate.table import unflagged
from aceval.data.contract import R_COLUMNS
from aceval.evaluation.decision import CONE, decision_table, flag_disagreements
from aceval.evaluation.decision_evidence import cross_fitted
from aceval.evaluation.decision_rules import (
    CARE,
    NONE,
    NOT_WITHIN,
    USE,
    Evidence,
    Verdict,
    removes,
    verdict,
)

KEY = {"subject": "S1", "sensor_set": "s", "imu": "A", "segment": "shank", "side": "right"}
#: a mounting with no symmetry: a transposed or mis-multiplied rotation is another one
MOUNT = Rotation.from_euler("zyx", [25, -40, 70], degrees=True).as_matrix()


def _row(method, heading_deg, cone=2.0, test="T6", flag="", error=np.nan, n_reps=3, spread=1.0):
    R = Rotation.from_euler("z", heading_deg, degrees=True).as_matrix() @ MOUNT
    return {
        **KEY,
        "test": test,
        "repetitions": "+".join(f"R{k}" for k in range(1, n_reps + 1)),
        "n_reps": n_reps,
        "method": method,
        **dict(zip(R_COLUMNS, R.ravel())),
        "flag": flag,
        CONE: cone,
        "spread95_deg": spread,
        "error_deg": error,
        "error_vertical_share": 1.0,
    }


def _flags(rows, tolerance=10.0):
    return flag_disagreements(pd.DataFrame(rows), tolerance)["flag"].tolist()


def test_two_methods_disagree_beyond_their_spreads_in_quadrature_or_beyond_the_tolerance():
    # spreads 3 and 4: allowed hypot = 5 (the sum would allow 7, the cones of 2 in quadrature 2.8)
    def pair(angle):
        return [_row("kong", 0, spread=3.0), _row("triad", angle, spread=4.0)]

    assert _flags(pair(6.0)) == ["methods_disagree"] * 2  # 5 < 6 < 7
    assert _flags(pair(4.5)) == ["", ""]  # within 5, though beyond the cones' 2.8
    # spreads of 10 allow 14.1, but two methods more than T apart disagree whatever their spread
    wide = [_row("kong", 0, spread=10.0), _row("triad", 12.0, spread=10.0)]
    assert _flags(wide, tolerance=10.0) == ["methods_disagree"] * 2
    assert _flags(wide, tolerance=15.0) == ["", ""]
    # a peer has no spread: it is allowed the widest of aceval's on the unit (4: hypot 5.66)
    peer = [_row("kong", 0, spread=4.0), _row("gaitmap_pca", 5.5, cone=np.nan, spread=np.nan)]
    assert _flags(peer) == ["", ""]
    further = [peer[0], _row("gaitmap_pca", 6.0, cone=np.nan, spread=np.nan)]
    assert _flags(further) == ["methods_disagree"] * 2


def test_of_many_methods_the_outlier_is_flagged_and_the_flag_takes_nothing_out():
    rows = [_row("kong", 0), _row("triad", 0.5), _row("combined", 0.3), _row("ricci_lm", 20)]
    rows += [_row("kong", 40, n_reps=2)]  # a subset: not compared
    rows += [_row("align_vectors", 30, flag="low_rho")]  # taken out by its flag: not compared
    rows += [_row("step_harmonic", 35, flag="step_frequency_disagrees")]  # advisory: compared
    out = flag_disagreements(pd.DataFrame(rows), 10.0)
    assert out["flag"].tolist() == [
        "",
        "",
        "",
        "methods_disagree",
        "",
        "low_rho",
        "step_frequency_disagrees;methods_disagree",
    ]
    assert np.isnan(out.loc[4, "methods_spread_deg"]) and np.isnan(out.loc[5, "methods_spread_deg"])
    assert out.loc[0, "methods_spread_deg"] == pytest.approx(35.0)
    # a comparison flag: the outlier stays in every analysis of its method
    assert unflagged(out).tolist() == [True, True, True, True, True, False, False]
    again = flag_disagreements(out, 10.0)  # run twice: the flag is recomputed, not doubled
    assert again["flag"].tolist() == out["flag"].tolist()


def test_the_evidence_for_a_sensor_never_includes_its_own_error():
    cell = {"segment": "shank", "test": "T6", "method": "kong", "sensor_set": "s"}
    units = pd.DataFrame(
        [
            {**cell, "subject": s, "imu": "A", "value": v}
            for s, v in (("S1", 1), ("S2", 2), ("S3", 30))
        ]
    )
    wanted = pd.DataFrame([{**cell, "subject": s, "imu": "A"} for s in ("S1", "S3", "S4")])
    got = cross_fitted(units, wanted).set_index("subject")
    assert got.loc["S3", "evidence_median_deg"] == 1.5 and got.loc["S3", "evidence_n"] == 2
    assert got.loc["S1", "evidence_median_deg"] == 16.0  # of 2 and 30, not 2 (with its own 1)
    # the median's standard error: sqrt(pi/2) * 1.4826 * MAD / sqrt(n); MAD of (2, 30) is 14
    assert got.loc["S1", "evidence_uncertainty_deg"] == pytest.approx(
        np.sqrt(np.pi / 2) * 1.4826 * 14 / np.sqrt(2)
    )
    assert got.loc["S4", "evidence_median_deg"] == 2.0 and got.loc["S4", "evidence_n"] == 3


def _truth_rows(errors: dict, cones: dict, own: dict | None = None) -> list[dict]:
    """Subject S1's IMU A and the same IMU of S2 and S3 (the evidence), per method their errors."""
    rows = []
    for k, subject in enumerate(["S1", "S2", "S3"]):
        for method, values in errors.items():
            error = (own or {}).get(method, values[k]) if subject == "S1" else values[k]
            heading = 0.1 * (list(errors).index(method) + 1)
            rows.append({**_row(method, heading, cones[method], error=error), "subject": subject})
    return rows


def test_the_choice_follows_the_evidence_of_the_other_sensors_not_the_cone_nor_its_own_error():
    # kong's evidence 1.0 and 1.2 (S2, S3) against triad's 6.0 and 6.2: beyond their standard
    # errors (0.13 each); kong's cone is the larger (4 against 2), and S1's own kong error 9.0
    errors = {"kong": [9.0, 1.0, 1.2], "triad": [0.5, 6.0, 6.2]}
    table = decision_table(pd.DataFrame(_truth_rows(errors, {"kong": 4.0, "triad": 2.0})), 2)
    s1 = table.set_index("subject").loc["S1"]
    assert s1["method"] == "kong" and s1["basis"] == "accuracy" and s1["n_tied"] == 1
    assert s1["evidence_median_deg"] == pytest.approx(1.1) and s1["evidence_n"] == 2
    assert s1["runner_up"] == "triad T6" and s1["margin_deg"] == pytest.approx(5.0)


def test_a_tie_goes_to_a_cone_within_the_tolerance_then_to_the_registry_order():
    # evidence 2.0 +- 1.3 (kong) and 1.5 +- 1.3 (triad): a tie; triad's median is the smaller
    errors = {"kong": [0, 1.0, 3.0], "triad": [0, 0.5, 2.5]}
    both_within = decision_table(pd.DataFrame(_truth_rows(errors, {"kong": 4, "triad": 3})), 2)
    s1 = both_within.set_index("subject").loc["S1"]
    assert s1["method"] == "kong" and s1["n_tied"] == 2  # Kong is first in the registry
    assert s1["runner_up"] == "triad T6" and s1["margin_deg"] == pytest.approx(-0.5)
    kong_outside = decision_table(pd.DataFrame(_truth_rows(errors, {"kong": 6, "triad": 3})), 2)
    assert kong_outside.set_index("subject").loc["S1", "method"] == "triad"
    # a method the registry does not know comes last: added with evidence inside the tie, it
    # changes no choice
    more = {**errors, "my_method": [0, 0.4, 2.4]}
    added = decision_table(
        pd.DataFrame(_truth_rows(more, {"kong": 4, "triad": 3, "my_method": 3})), 2
    )
    assert added.set_index("subject").loc["S1", "method"] == "kong"


def _decide(rows, tolerance=5.0, **extra):
    frame = pd.DataFrame(rows)
    for column, value in extra.items():
        frame[column] = value
    return decision_table(flag_disagreements(frame, tolerance), 2, tolerance_deg=tolerance).iloc[0]


def test_the_verdict_follows_the_tolerance():
    agree = [_row("kong", 0, cone=5.0), _row("triad", 1.0, cone=6.0)]
    use = _decide(agree)
    assert use["verdict_kind"] == USE and use["verdict"] == "use"  # cone 5 = T: within
    assert use["n_behind"] == 2 and use["tolerance_deg"] == 5.0
    assert use["methods_range_deg"] == pytest.approx(1.0)
    care = _decide([_row("kong", 0, cone=5.5), _row("triad", 1.0, cone=6.0)])
    assert care["verdict"] == "use with care: uncertainty 5.5 deg > T 5"
    assert _decide([_row("kong", 0, cone=5.5), _row("triad", 1.0, cone=6.0)], 6.0)["verdict"] == (
        "use"
    )
    far = _decide([_row("kong", 0, cone=10.5), _row("triad", 1.0, cone=11.0)])
    assert far["verdict_kind"] == NOT_WITHIN
    assert far["verdict"].startswith("not within tolerance: uncertainty 10.5 deg > 2T 10")
    alone = _decide([_row("kong", 0, cone=3.0)])
    assert alone["verdict"] == "use with care: no other calibration within T 5 of it"
    apart = _decide([_row("kong", 0, cone=3.0), _row("triad", 5.5, cone=3.0)])
    assert (
        apart["verdict_kind"] == CARE
        and "methods disagree: up to 5.5 deg apart" in apart["verdict"]
    )
    assert "(kong and triad)" in apart["verdict"]
    # the methods range counts two other methods too: triad and combined 6 deg apart
    middle = _decide([_row("kong", 0, 3.0), _row("triad", 3.0, 3.0), _row("combined", -3.0, 3.0)])
    assert middle["methods_spread_deg"] == pytest.approx(3.0) and middle["verdict_kind"] == CARE


def test_the_right_axis_sign_and_a_peer_cap_the_verdict():
    agree = [_row("kong", 0, cone=3.0), _row("triad", 1.0, cone=3.0)]
    assert _decide(agree, right_axis_sign_verified=True)["verdict"] == "use"
    unverified = _decide(agree, right_axis_sign_verified=[np.nan, False])
    assert unverified["verdict"] == "use with care: right-axis sign not verified by the data"
    peer = _decide([_row("gaitmap_pca", 0, cone=np.nan), _row("kong", 0, flag="backward")])
    assert peer["method"] == "gaitmap_pca" and peer["verdict_kind"] == NOT_WITHIN
    assert "not measured on the recording" in peer["verdict"]


def test_a_defect_is_never_chosen_an_advisory_flag_is_and_nothing_left_says_why():
    rows = [
        _row("kong", 0, cone=3.0, flag="backward", error=0.1),  # the best error, a defect
        _row("triad", 1.0, cone=3.0, flag="weight_switch", error=3.0),
        _row("combined", 0.5, cone=3.0, error=5.0),
    ]
    row = _decide(rows)
    assert row["method"] == "triad" and row["advisory_flags"] == "weight_switch"
    assert row["n_unflagged"] == 2 and row["flags_elsewhere"] == "backward x1"
    none = _decide([_row("kong", 0, flag="not_planar"), _row("triad", 0, flag="backward")])
    assert none["verdict_kind"] == NONE and np.isnan(none["method"])
    assert none["verdict"] == "no trustworthy calibration: backward x1; not_planar x1"
    assert np.isnan(none[R_COLUMNS].to_numpy(float)).all()


def test_the_decision_carries_the_chosen_rotation_sensor_to_body():
    rows = [_row("kong", 0, cone=3.0), _row("triad", 2.0, cone=2.0, test="T5")]
    row = _decide(rows)
    chosen = pd.DataFrame(rows).set_index(["method", "test"]).loc[(row["method"], row["test"])]
    assert row["method"] == "kong"  # a tie without evidence: the registry's order
    assert np.array_equal(row[R_COLUMNS].to_numpy(float), chosen[R_COLUMNS].to_numpy(float))


def test_the_decision_names_the_recordings_its_calibrations_were_made_from():
    """Each row carries its subject's recordings' fingerprint (what apply checks a decision
    against), taken from a calibration that has one: a peer's row (none) does not blank it."""
    rows = [_row("kong", 0, cone=3.0), _row("triad", 2.0, cone=2.0, test="T5")]
    row = _decide(rows, recordings_sha1=["abc", np.nan])
    assert row["recordings_sha1"] == "abc"
    assert np.isnan(_decide(rows)["recordings_sha1"])


def test_flags_that_take_a_calibration_out_and_the_verdict_type():
    flags = pd.Series(["", np.nan, "weight_switch", "weight_switch;low_rho", "backward"])
    assert removes(flags).tolist() == [False, False, False, True, True]
    with pytest.raises(ValueError, match="no verdict"):
        Verdict("fine")
    e = Evidence(cone=12.0, methods_range=np.nan, disagreeing="", n_behind=3)
    assert verdict(e, 5.0).kind == NOT_WITHIN and verdict(e, 6.0).kind == CARE
    assert verdict(e, 12.0).text == "use" and verdict(e, 12.0).numbers["cone_deg"] == 12.0
    assert Verdict(CARE, ("a", "b")).text == "use with care: a; b"


def test_the_flag_readers_keep_an_empty_tables_columns():
    """A dataset without Kong's rows (Ricci's design): the readers' masks are boolean, so that
    selecting with them keeps the columns (an object-typed empty mask selects columns instead)."""
    from aceval.calibrate.table import has_flag, only_flags, spread_usable

    empty = pd.DataFrame(columns=["subject", "method", "flag"])
    assert has_flag(empty["flag"], "backward").dtype == bool
    assert only_flags(empty, ["unstable"]).dtype == bool and removes(empty["flag"]).dtype == bool
    assert list(spread_usable(empty).columns) == ["subject", "method", "flag"]


def test_calibrations_without_a_cone_are_not_within_tolerance_and_say_why():
    """Ricci's functional design has no cone column: its best calibration is named, not within
    tolerance, its uncertainty not measured on the recording."""
    rows = pd.DataFrame([_row("ricci_lm", 0), _row("triad", 1.0)]).drop(
        columns=[CONE, "spread95_deg"]
    )
    row = decision_table(flag_disagreements(rows, 5.0), 2).iloc[0]
    assert row["method"] == "ricci_lm" and row["verdict_kind"] == NOT_WITHIN
    assert (
        row["verdict"] == "not within tolerance: its uncertainty is not measured on the recording"
    )


def test_without_evidence_a_tie_goes_by_cone_class_then_registry_and_beyond_2t_to_the_smaller():
    # no truth, no subsets: no evidence at all; cones 9 (kong) and 6 (triad) are both within 2T:
    # the registry's order (kong), not the smaller cone; beyond 2T (14 and 12): the smaller
    within_2t = _decide([_row("kong", 0, cone=9.0), _row("triad", 1.0, cone=6.0)])
    assert within_2t["method"] == "kong" and within_2t["n_tied"] == 2
    assert within_2t["evidence_n"] == 0 and np.isnan(within_2t["margin_deg"])
    beyond = _decide([_row("kong", 0, cone=14.0), _row("triad", 1.0, cone=12.0)])
    assert beyond["method"] == "triad" and beyond["verdict_kind"] == NOT_WITHIN
    one_within = _decide([_row("kong", 0, cone=11.0), _row("triad", 1.0, cone=9.5)])
    assert one_within["method"] == "triad" and one_within["verdict_kind"] == CARE


def test_a_tie_goes_to_the_calibration_that_agrees_with_the_other_methods():
    # three methods, no evidence, all within T: kong is the outlier (6 deg from the other two,
    # whose spreads allow 1.4): flagged methods_disagree, so triad comes before it
    rows = [_row("kong", 6.0, 3.0), _row("triad", 0.0, 3.0), _row("combined", 0.5, 3.0)]
    row = _decide(rows, tolerance=10.0)
    assert row["disagreeing"] == "kong" and row["method"] == "triad"
    assert row["runner_up"] == "combined T6"


def _chosen(errors: dict, cones: dict, flags: dict | None = None) -> pd.Series:
    """S1's decision row from the other subjects' errors per method (:func:`_truth_rows`)."""
    rows = _truth_rows(errors, cones)
    for row in rows:
        row["flag"] = (flags or {}).get(row["method"], "")
    return decision_table(pd.DataFrame(rows), 2).set_index("subject").loc["S1"]


def test_a_tie_is_within_the_two_standard_errors_in_quadrature_not_their_sum_nor_the_larger():
    # triad's evidence 1.5 (0.5, 2.5), kong's from two values 2 apart too: each standard error
    # sqrt(pi/2) * 1.4826 * 1 / sqrt(2) = 1.314; in quadrature 1.858, summed 2.628, larger 1.314
    cones = {"kong": 3.0, "triad": 3.0}
    apart = _chosen({"kong": [0, 2.7, 4.7], "triad": [0, 0.5, 2.5]}, cones)  # 2.2 apart
    assert apart["method"] == "triad" and apart["n_tied"] == 1  # the sum would tie: kong
    assert apart["margin_deg"] == pytest.approx(2.2)
    close = _chosen({"kong": [0, 2.1, 4.1], "triad": [0, 0.5, 2.5]}, cones)  # 1.6 apart
    assert close["method"] == "kong" and close["n_tied"] == 2  # the larger would not tie: triad


def test_the_evidence_orders_before_the_cone_class_and_the_disagreement_flag():
    # kong's evidence is the best by far, its cone within 2T only; triad (cone 7, flagged
    # methods_disagree) is second by evidence, combined (cone 2) third: the order of the evidence
    # outside a tie, whatever the cone or the flag
    errors = {"kong": [0, 1.0, 1.2], "triad": [0, 6.0, 6.2], "combined": [0, 9.0, 9.2]}
    row = _chosen(
        errors, {"kong": 7.0, "triad": 7.0, "combined": 2.0}, {"triad": "methods_disagree"}
    )
    assert row["method"] == "kong" and row["n_tied"] == 1 and row["verdict_kind"] == CARE
    assert row["runner_up"] == "triad T6" and row["margin_deg"] == pytest.approx(5.0)


def test_a_peer_with_better_evidence_is_not_chosen_over_a_measured_cone():
    errors = {"kong": [0, 3.0, 3.2], "gaitmap_pca": [0, 0.5, 0.7]}
    row = _chosen(errors, {"kong": 3.0, "gaitmap_pca": np.nan})
    assert row["method"] == "kong" and row["n_tied"] == 1 and not isinstance(row["runner_up"], str)


def test_the_cone_classes_include_their_bounds_t_and_2t():
    # no evidence: a tie; a cone of exactly T is within T, one of exactly 2T within 2T, and one
    # of exactly MAX_CONE_DEG may be chosen (the registry's order: kong before triad)
    assert _decide([_row("kong", 0, cone=5.0), _row("triad", 1.0, cone=4.0)])["method"] == "kong"
    assert _decide([_row("kong", 0, cone=10.0), _row("triad", 1.0, cone=6.0)])["method"] == "kong"
    from aceval.evaluation.decision import MAX_CONE_DEG

    widest = _decide([_row("kong", 0, cone=MAX_CONE_DEG)])
    assert widest["method"] == "kong" and widest["n_unflagged"] == 1


def test_the_methods_range_and_the_calibrations_behind_count_as_documented():
    # triad from another test, 8 deg away: not in the methods' range of kong's test (NaN), and not
    # within T of it (n_behind 1, its own)
    row = _decide([_row("kong", 0, cone=3.0), _row("triad", 8.0, cone=3.0, test="T5")])
    assert row["method"] == "kong" and np.isnan(row["methods_range_deg"])
    assert row["verdict"] == "use with care: no other calibration within T 5 of it"
    # methods exactly T apart are not more than T apart
    e = Evidence(cone=3.0, methods_range=5.0, disagreeing="kong and triad", n_behind=2)
    assert verdict(e, 5.0).kind == USE


def test_a_peer_is_allowed_the_widest_spread_of_acevals_methods_on_its_unit():
    # kong's spread 4 and triad's 1: the peer 5 deg from both is allowed hypot(4, 4) = 5.66 from
    # kong and hypot(4, 1) = 4.12 from triad: it disagrees with one of two, not flagged (given
    # the narrowest, 1, it would disagree with both)
    rows = [
        _row("kong", 0, spread=4.0),
        _row("triad", 0, spread=1.0),
        _row("gaitmap_pca", 5.0, cone=np.nan, spread=np.nan),
    ]
    assert _flags(rows) == ["", "", ""]


def test_the_evidences_spread_is_the_median_absolute_deviation_of_at_least_two_others():
    cell = {"segment": "shank", "test": "T6", "method": "kong", "sensor_set": "s"}
    values = {"S1": 1.0, "S2": 2.0, "S3": 30.0}
    units = pd.DataFrame(
        [{**cell, "subject": s, "imu": "A", "value": v} for s, v in values.items()]
    )
    lone = {**cell, "test": "T5"}
    units = pd.concat([units, pd.DataFrame([{**lone, "subject": "S1", "imu": "A", "value": 4.0}])])
    wanted = pd.DataFrame(
        [{**cell, "subject": "S4", "imu": "A"}, {**lone, "subject": "S2", "imu": "A"}]
    )
    got = cross_fitted(units, wanted)
    # 1, 2 and 30: median 2, absolute deviations 1, 0, 28: their median 1 (their mean 9.7)
    se = np.sqrt(np.pi / 2) * 1.4826 * 1.0 / np.sqrt(3)
    assert got.loc[0, "evidence_uncertainty_deg"] == pytest.approx(se)
    # one other IMU: a median without a standard error
    assert got.loc[1, "evidence_n"] == 1 and got.loc[1, "evidence_uncertainty_deg"] == np.inf


def test_without_a_truth_the_evidence_is_the_other_subjects_test_retest_angle():
    # per subject and method: all 4 repetitions, and two distinct subsets of 2 (R1+R2, R3+R4)
    # that many degrees apart: triad 0.5-0.7 (the other subjects'), kong 6.0-6.2; S1's own differ
    apart = {"kong": [0.1, 6.0, 6.2], "triad": [9.0, 0.5, 0.7]}
    rows = []
    for k, subject in enumerate(["S1", "S2", "S3"]):
        for method, angles in apart.items():
            rows.append({**_row(method, 0.0, cone=3.0, n_reps=4), "subject": subject})
            for label, heading in (("R1+R2", 0.0), ("R3+R4", angles[k])):
                subset = _row(method, heading, cone=3.0, n_reps=2)
                rows.append({**subset, "subject": subject, "repetitions": label})
    table = decision_table(pd.DataFrame(rows), 2).set_index("subject")
    s1 = table.loc["S1"]
    assert s1["basis"] == "repeatability" and s1["method"] == "triad"
    assert s1["evidence_median_deg"] == pytest.approx(0.6) and s1["evidence_n"] == 2
    assert s1["runner_up"] == "kong T6" and s1["margin_deg"] == pytest.approx(5.5)
    none = _decide([_row("kong", 0, cone=3.0)])  # no truth, no subsets: no evidence at all
    assert none["basis"] == "repeatability" and none["evidence_n"] == 0
