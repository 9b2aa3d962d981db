"""Issue 51: bounds a faithful reproduction can meet, and a claim that sees an absolute error.

* Kong Table 11's published means and SDs taken as the truth: the Obj 5 rules hold at an
  affordable n (before, their bounds were the paper's own estimates: P(holds) = 0 at any n);
* Kong's calibrations turned by 10 or 25 deg about the vertical in every test: the absolute-
  accuracy claim turns to 'does not hold' while the relative one (the recommended test against
  the best other) cannot see it;
* the untestable claims say why: Ricci's without functional axes, Kong's angles without enough
  repetitions, a claim whose cells have one subject each.
"""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.contract import R_COLUMNS
from aceval.evaluation import verdicts
from aceval.evaluation.methods_comparison import with_truth
from aceval.report import kong_angle_claims, kong_claims, summary
from aceval.report.claims import FAILS, HOLDS, INCONCLUSIVE, UNTESTABLE
from aceval.report.kong2016 import reference

RULES = {rule.key: rule for rule in kong_claims.RULES}
OBJ5 = ("obj5_cross_test_about_5", "obj5_feet_thighs_t3_larger", "obj5_recommendation")


def _table11_angles(subjects: int, rng) -> pd.DataFrame:
    """One cross-test angle per subject and Table 11 cell, drawn from a gamma distribution with
    the cell's published mean and SD (an angle is positive and skewed)."""
    rows = []
    for _, cell in reference(11).iterrows():
        shape = (cell["mean_deg"] / cell["sd_deg"]) ** 2
        values = rng.gamma(shape, cell["sd_deg"] ** 2 / cell["mean_deg"], subjects)
        rows += [
            {"comparison": "cross_test", "subject": f"S{s}", "test": cell["t_ex_pair"],
             "segment": cell["segment"], "k": 5, "error_angle_deg": v, "vertical_share": 1.0}
            for s, v in enumerate(values)
        ]  # fmt: skip
    return pd.DataFrame(rows)


def test_table11_as_the_truth_lets_every_obj5_rule_hold():
    """Table 11 as the truth (its means and SDs): by the noncentral t, each Obj 5 rule holds
    with 80 % at an affordable n, and the rules' own code says 'holds' about that often on
    simulated studies of 60 subjects; with the old bound (the paper's 5.39 itself) 'holds' has
    at most the probability of a cell on its bound (2.5 %, the interval's one side) at 100,000
    subjects."""
    published = reference(11)
    rng = np.random.default_rng(11)
    held = {key: 0 for key in OBJ5}
    draws = 15
    for _ in range(draws):
        evidence = kong_claims.Evidence({}, None, _table11_angles(60, rng), None)
        for key in OBJ5:
            held[key] += RULES[key].apply(evidence).verdict == HOLDS
    assert all(count / draws >= 0.7 for count in held.values()), held
    for key in OBJ5:  # the analytic n, on the published cells themselves
        claim = RULES[key].apply(kong_claims.Evidence({}, None, _table11_angles(8, rng), None))
        table = claim.judgement.estimates
        cells = table["cell"].str.split(" ", expand=True)
        pair, segment = (
            (cells[0], cells[1]) if key != "obj5_recommendation" else (cells[1], cells[0])
        )
        truth = published.set_index(["t_ex_pair", "segment"]).loc[list(zip(pair, segment))]
        mean, sd = truth["mean_deg"].to_numpy(), truth["sd_deg"].to_numpy()
        n = verdicts.n_to_decide(mean, sd, verdicts.arrays_of(table), "all", HOLDS)
        assert n <= 60, (key, n)
    small = ~published["segment"].eq("foot") & ~(
        published["segment"].eq("thigh") & published["t_ex_pair"].str.contains("T3")
    )
    old = verdicts.requirement_arrays([verdicts.Requirement.of("<=", 5.39)] * int(small.sum()))
    mean, sd = published.loc[small, "mean_deg"], published.loc[small, "sd_deg"]
    assert verdicts.decide_probability(mean, sd, old, "all", HOLDS, 100_000) <= 0.025 + 1e-9


def test_obj5_bounds_are_the_papers_values_at_the_papers_precision():
    """Waist T1-T3 5.39 +- 5.75 over Kong's 5 subjects: its 95 % interval reaches 12.53; shank
    T5-T6 5.12 +- 4.61 reaches 10.84 (t(0.975, 4) = 2.776)."""
    assert kong_angle_claims.ABOUT_5_DEG == 5.39
    assert kong_angle_claims.ABOUT_5_BOUND == pytest.approx(5.39 + 2.776445 * 5.75 / np.sqrt(5))
    assert kong_angle_claims.UPPER_BOUND.below == pytest.approx(12.53, abs=0.005)
    assert kong_angle_claims.LOWER_BOUND.below == pytest.approx(10.84, abs=0.005)


SEGMENTS = {"head": "T3", "chest": "T3", "waist": "T3", "thigh": "T6", "shank": "T6"}
OTHER_TEST = {"T3": "T1", "T6": "T5"}


def _calibrations(rng, subjects=5) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Kong's calibrations of 5 subjects (both sets, the recommended and one other test per
    segment), each its truth turned by a heading error of N(0, 2) deg and a tilt of N(0, 1):
    (calibrations, truth indexed by subject, set, IMU)."""
    rows, truth = [], []
    for s in range(subjects):
        for sensor_set in ("frontal", "lateral"):
            for k, (segment, test) in enumerate(SEGMENTS.items()):
                imu = f"IMU{k + 1}"
                true = Rotation.random(random_state=rng)
                truth.append({"subject": f"S{s}", "sensor_set": sensor_set, "imu": imu,
                              **dict(zip(R_COLUMNS, true.as_matrix().ravel()))})  # fmt: skip
                for t in (test, OTHER_TEST[test]):
                    error = Rotation.from_euler(
                        "xyz", [rng.normal(0, 1), rng.normal(0, 1), rng.normal(0, 2)], degrees=True
                    )
                    R = (error * true).as_matrix()
                    rows.append({"method": "kong", "subject": f"S{s}", "sensor_set": sensor_set,
                                 "imu": imu, "segment": segment, "test": t, "n_reps": 5,
                                 "repetitions": "1,2,3,4,5", "flag": "",
                                 **dict(zip(R_COLUMNS, R.ravel()))})  # fmt: skip
    return pd.DataFrame(rows), pd.DataFrame(truth).set_index(["subject", "sensor_set", "imu"])


def _turned(calibrations: pd.DataFrame, degrees: float) -> pd.DataFrame:
    """Every calibration turned by ``degrees`` about the body's vertical (z0)."""
    R = calibrations[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    turn = Rotation.from_euler("z", degrees, degrees=True).as_matrix()
    return calibrations.assign(**dict(zip(R_COLUMNS, (turn @ R).reshape(-1, 9).T)))


@pytest.mark.parametrize("degrees", [10.0, 25.0])
def test_a_calibration_turned_in_every_test_turns_the_absolute_claim_not_the_relative_one(degrees):
    """Issue 51: Kong's calibrations turned by 25 deg in every test left every angle and truth
    verdict as it was. The absolute claim (each segment's error below 5 deg, McGinley et al.
    2009) holds on the right calibrations and does not hold on the turned ones; the relative
    claim (recommended test - best other) is the same both ways, an error every test shares
    cancelling in it."""
    rng = np.random.default_rng(51)
    calibrations, truth = _calibrations(rng)
    right = with_truth(calibrations, truth)
    wrong = with_truth(_turned(calibrations, degrees), truth)
    assert right["error_deg"].max() < 8.0
    assert wrong["error_deg"].min() > degrees - 8.0

    def verdicts_of(table):
        evidence = kong_claims.Evidence({}, None, None, table)
        return {
            key: RULES[key].apply(evidence)
            for key in ("truth_kong_error_below_5", "truth_recommended_test")
        }

    before, after = verdicts_of(right), verdicts_of(wrong)
    assert before["truth_kong_error_below_5"].verdict == HOLDS
    assert after["truth_kong_error_below_5"].verdict == FAILS
    for relative in (before["truth_recommended_test"], after["truth_recommended_test"]):
        assert relative.verdict != FAILS  # the turn is the same in every test: it cancels
        # its differences are of the size of the calibrations' own noise, not of the turn
        assert (relative.judgement.estimates["mean"].abs() < degrees / 3).all()


def test_the_absolute_claim_needs_a_truth_and_says_what_it_reads():
    rng = np.random.default_rng(3)
    calibrations, truth = _calibrations(rng)
    assert RULES["truth_kong_error_below_5"].judge(
        kong_claims.Evidence({}, None, None, calibrations.assign(error_deg=np.nan))
    ) == (UNTESTABLE, "no ground truth")
    claim = RULES["truth_kong_error_below_5"].apply(
        kong_claims.Evidence({}, None, None, with_truth(calibrations, truth))
    )
    cells = claim.judgement.estimates["cell"].tolist()
    assert cells == ["head T3", "chest T3", "waist T3", "thigh T6", "shank T6"]
    assert "McGinley et al. 2009" in RULES["truth_kong_error_below_5"].rule


def test_a_dataset_without_ricci_recordings_lists_ricci_claims_as_not_testable():
    found = summary.claims({3: pd.DataFrame()}, {})
    ricci = [c for c in found if c.key.startswith("ricci_")]
    assert len(ricci) == 6 and all(c.verdict == UNTESTABLE for c in ricci)
    assert all("no functional-axis recordings" in c.numbers for c in ricci)
    assert not any(c.key.startswith("code_residuals") for c in found)


def test_angle_claims_say_how_many_repetitions_they_need():
    """Three repetitions: 'incremental' angles exist for k = 1, 2 but k >= 3 needs 4; test-retest
    of 3 of them needs 4; a dataset of feet only has no cell outside T5 and the feet."""
    calibrations = pd.DataFrame({"segment": ["shank"], "n_reps": [3]})
    angles = pd.DataFrame([
        {"comparison": "incremental", "subject": "S1", "test": "T6", "segment": "shank", "k": k,
         "error_angle_deg": 0.5, "vertical_share": 1.0} for k in (1, 2)
    ])  # fmt: skip
    evidence = kong_claims.Evidence({}, None, angles, calibrations)
    verdict, why = RULES["obj3_incremental_k3_below_1"].judge(evidence)
    assert verdict == UNTESTABLE and "needs 4 or more repetitions" in why and "at most 3" in why
    verdict, why = RULES["obj4_test_retest_below_2.1"].judge(evidence)
    assert "needs 4 or more repetitions" in why
    feet = pd.DataFrame([{"comparison": "test_retest", "subject": "S1", "test": "T6",
                          "segment": "foot", "k": 3, "error_angle_deg": 0.5,
                          "vertical_share": 1.0}])  # fmt: skip
    evidence = kong_claims.Evidence({}, None, feet, calibrations.assign(n_reps=5))
    verdict, why = RULES["obj4_test_retest_below_1"].judge(evidence)
    assert verdict == UNTESTABLE and "leaves out" in why


def test_one_subject_per_cell_is_not_testable_and_says_so():
    angles = pd.DataFrame([
        {"comparison": "test_retest", "subject": "S1", "test": "T6", "segment": seg, "k": 3,
         "error_angle_deg": 0.5, "vertical_share": 1.0} for seg in ("thigh", "shank")
    ])  # fmt: skip
    claim = RULES["obj4_test_retest_below_2.1"].apply(kong_claims.Evidence({}, None, angles, None))
    assert claim.verdict == UNTESTABLE
    assert claim.numbers.startswith("no cell has 2 subjects: no interval, so no verdict")
    assert "not decidable" not in claim.numbers


def test_summary_states_each_familys_rule_and_what_it_cannot_see():
    """SUMMARY.md: one rule sentence per family of claims present, and the blind spots."""
    rng = np.random.default_rng(5)
    calibrations, truth = _calibrations(rng)
    evidence = {"calibrations": with_truth(calibrations, truth)}
    found = summary.claims({8: pd.DataFrame()}, evidence)
    sensitivity = pd.DataFrame({"mode": ["concatenated"] * 2, "heading_error_deg": [0.0, 30.0],
                                "mean": [0.998, 0.971]})  # fmt: skip
    text = summary.to_markdown(
        found, "demo", "", True, [], tables={"obj1_sensitivity": sensitivity}
    )
    assert "a claim over every cell holds when each cell's own 95 % interval" in text
    assert "turned 30 deg the mean correlation moves 0.998 -> 0.971" in text
    assert "cannot see a heading error of that size" in text
    assert "Obj 3-4 compare calibrations of one IMU from repetitions of the same test" in text
    assert "Kong's error per segment against 5 deg is absolute" in text
    assert "mostly" not in text.split("## The papers' claims")[1].split("| objective")[0] or any(
        c.judgement is not None and c.judgement.combine == "majority" for c in found
    )
    assert INCONCLUSIVE  # the vocabulary is the claims module's


@pytest.mark.slow
def test_the_regenerated_kong_sim_turned_by_10_or_25_deg_turns_the_absolute_claim(regenerated):
    """The committed configuration regenerated (conftest's ``regenerated``): Kong's own
    calibrations of kong_sim turned by 10 and 25 deg about z0 in every test (median error to the
    truth about 10 and 25 deg per segment). Measured when written: the absolute claim leans
    'holds' (shank T6 4.14 deg, 16 subjects would decide it) and turns to 'does not hold' (thigh
    T6 10.72 and 25.61 deg); the relative claim and the angle claims do not move."""
    import re

    from aceval.data.dataset import load_dataset
    from aceval.evaluation.objectives import all_angles

    folder = regenerated.workdir / "results" / "kong_sim" / "calibrations"
    batches = [
        p for p in sorted(folder.glob("_batch*.csv")) if re.fullmatch(r"_batch\d+\.csv", p.name)
    ]
    calibrations = pd.concat([pd.read_csv(p, low_memory=False) for p in batches], ignore_index=True)
    calibrations = calibrations[calibrations["method"] == "kong"].assign(error_deg=np.nan)
    truth = load_dataset(regenerated.workdir / "resources" / "kong_sim").ground_truth
    found = {}
    for degrees in (0.0, 10.0, 25.0):
        turned = with_truth(_turned(calibrations, degrees) if degrees else calibrations, truth)
        evidence = kong_claims.Evidence({}, None, all_angles(turned, 3), turned)
        found[degrees] = {key: rule.apply(evidence).verdict for key, rule in RULES.items()
                          if key.startswith(("truth", "obj3", "obj4", "obj5"))}  # fmt: skip
    assert found[0.0]["truth_kong_error_below_5"] in (HOLDS, INCONCLUSIVE)
    for degrees in (10.0, 25.0):
        assert found[degrees]["truth_kong_error_below_5"] == FAILS
        unchanged = {k: v for k, v in found[degrees].items() if k != "truth_kong_error_below_5"}
        assert unchanged == {k: v for k, v in found[0.0].items() if k in unchanged}
