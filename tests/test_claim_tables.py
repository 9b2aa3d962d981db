"""A claim judged on cells, worked by hand (issue 44 after issue 42): the numbers SUMMARY.md prints
for it, the way an undecided claim leans and the subjects that would decide it, and the rows of
claims.csv, claim_estimates.csv and claim_cells.csv. Before, only the slow byte-for-byte
regeneration saw these texts and tables (a mutation benchmark found 138 of report/claims'
mutants reached by no quick test)."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats as scipy_stats

from aceval.evaluation import verdicts
from aceval.evaluation.verdicts import Requirement
from aceval.report import claims
from aceval.report.claims import FAILS, HOLDS, INCONCLUSIVE, UNTESTABLE

SUBJECTS = [f"S{k}" for k in range(1, 6)]
#: cell "a" well below 2.5 deg; cell "b" below on average but its interval reaches past 2.5
VALUES = {"a": [0.8, 1.0, 1.2, 0.9, 1.1], "b": [1.0, 2.6, 1.4, 2.9, 1.6]}


def _cells(values=VALUES) -> pd.DataFrame:
    rows = [(cell, s, v) for cell, vs in values.items() for s, v in zip(SUBJECTS, vs, strict=True)]
    return pd.DataFrame(rows, columns=["cell", "subject", "value"])


def _rule(values=VALUES, combine="all") -> claims.Rule:
    def judge(evidence):
        cells = _cells(values)
        requirements = claims.every_cell(cells, Requirement.of("<", 2.5))
        return claims.Cells(cells, requirements, combine, unit="deg", note="the paper: < 2.5")

    return claims.Rule("Obj 3", "below 2.5 deg", "every cell < 2.5", judge, key="below_2.5")


def _by_hand(values, level=0.975) -> tuple[float, float, float]:
    """Mean and the interval simultaneous over two cells (97.5 % each), or at ``level``."""
    x = np.asarray(values)
    low, high = scipy_stats.t.interval(level, len(x) - 1, loc=x.mean(), scale=scipy_stats.sem(x))
    return float(x.mean()), float(low), float(high)


def test_an_undecided_claim_prints_its_deciding_cell_adjustment_states_and_note():
    claim = _rule().apply(None)
    mean, low, high = _by_hand(VALUES["b"])
    _, own_low, own_high = _by_hand(VALUES["b"], 0.95)
    assert own_high > 2.5 > mean  # undecided by construction, even on its own 95 % interval
    assert claim.verdict == INCONCLUSIVE and claim.key == "below_2.5"
    assert claim.numbers == (
        f"cell closest to failing: b {mean:.2f} [{own_low:.2f}, {own_high:.2f}] deg, "
        f"simultaneous [{low:.2f}, {high:.2f}] (< 2.5 deg); own 95 % intervals for 'holds', "
        "97.5 % simultaneous over 2 cells (Bonferroni) for 'does not hold'; cells shown / beyond "
        "/ undecided: 1 / 0 / 1; n 5 subjects; the paper: < 2.5"
    )
    assert claim.cells["cell"].tolist() == ["a"] * 5 + ["b"] * 5


def test_an_undecided_claim_leans_its_estimates_way_and_says_how_many_would_decide_it():
    claim = _rule().apply(None)
    judgement = claim.judgement
    assert judgement.leaning == HOLDS  # both means are below 2.5
    n = judgement.n_to_decide
    table = judgement.estimates
    req = {k: table[k].to_numpy() for k in verdicts.REQUIREMENT_COLUMNS}
    mean, sd = table["mean"].to_numpy(), table["sd"].to_numpy()
    assert verdicts.decide_probability(mean, sd, req, "all", HOLDS, int(n)) >= verdicts.POWER
    assert verdicts.decide_probability(mean, sd, req, "all", HOLDS, int(n) - 1) < verdicts.POWER
    assert claims.verdict_text(claim) == (
        f"inconclusive (leans 'holds'; about {int(n)} subjects would decide it (80 %))"
    )


def test_a_decided_claim_names_the_cell_closest_to_its_bound_or_farthest_beyond_it():
    below = {"a": [0.8, 1.0, 1.2, 0.9, 1.1], "b": [1.5, 1.7, 1.4, 1.6, 1.5]}
    held = _rule(below).apply(None)
    assert held.verdict == HOLDS and claims.verdict_text(held) == HOLDS
    assert held.numbers.startswith("cell closest to its bound: b ")
    assert "cells shown / beyond / undecided: 2 / 0 / 0" in held.numbers
    above = {"a": [0.8, 1.0, 1.2, 0.9, 1.1], "b": [5.5, 5.7, 5.4, 5.6, 5.5]}
    failed = _rule(above).apply(None)
    assert failed.verdict == FAILS
    assert failed.numbers.startswith("cell farthest beyond its bound: b ")
    assert "1 / 1 / 0" in failed.numbers
    mostly = _rule(below, combine="majority").apply(None)
    assert mostly.numbers.startswith("cell at the majority: ")


def test_margins_are_the_distance_to_the_nearest_bound_in_sds():
    req = verdicts.requirement_arrays(
        [Requirement.of("<", 2.5), Requirement.of(">", 1.0), Requirement.within(0.0, 1.0)] * 2
    )
    mean = np.array([2.0, 2.0, 0.25, 3.0, 0.5, 0.0])
    sd = np.array([0.5, 0.25, 0.25, 0.0, 0.0, 0.0])
    expected = [1.0, 4.0, 3.0, -np.inf, -np.inf, np.inf]
    np.testing.assert_array_equal(verdicts.margins(mean, sd, req), expected)
    # the deciding cell of 'all' is the smallest margin
    cells = _cells()
    judgement = verdicts.judge(cells, claims.every_cell(cells, Requirement.of("<", 2.5)))
    assert judgement.deciding["cell"] == "b"
    assert judgement.estimates["margin"].tolist() == pytest.approx(
        [(2.5 - np.mean(v)) / np.std(v, ddof=1) for v in VALUES.values()]
    )


def test_the_three_committed_tables_of_claims():
    judged = _rule().apply(None)
    plain = claims.Rule("Obj 1", "c", "r", lambda e: (HOLDS, "0.97"), key="plain").apply(None)
    table = claims.claims_table([judged, plain]).set_index("claim")
    mean, low, high = _by_hand(VALUES["b"])
    row = table.loc["below_2.5"]
    assert (row["section"], row["objective"], row["verdict"]) == ("paper", "Obj 3", INCONCLUSIVE)
    assert (row["leaning"], row["n_to_decide"]) == (HOLDS, judged.judgement.n_to_decide)
    assert (row["cells"], row["combine"], row["level"]) == (2, "all", pytest.approx(0.975))
    assert (row["deciding_cell"], row["n"], row["requirement"]) == ("b", 5, "< 2.5")
    assert (row["mean"], row["low"], row["high"]) == pytest.approx((mean, low, high))
    row = table.loc["plain"]
    assert (row["verdict"], row["cells"], row["deciding_cell"], row["leaning"]) == (
        HOLDS,
        0,
        "",
        "",
    )
    assert np.isnan(row["level"]) and np.isnan(row["mean"]) and np.isnan(row["n_to_decide"])
    estimates = claims.estimates_table([judged, plain])
    assert estimates.columns[0] == "claim" and estimates["claim"].tolist() == ["below_2.5"] * 2
    assert estimates["cell"].tolist() == ["a", "b"]
    assert estimates["state"].tolist() == ["shown", "undecided"]
    assert estimates.loc[1, ["low", "high"]].tolist() == pytest.approx([low, high])
    assert claims.estimates_table([plain]).columns.tolist() == ["claim", "cell"]
    cells = claims.cells_table([judged, plain])
    assert cells.columns.tolist() == ["claim", "cell", "subject", "value"]
    assert len(cells) == 10 and set(cells["claim"]) == {"below_2.5"}
    assert cells["value"].tolist() == VALUES["a"] + VALUES["b"]
    assert claims.cells_table([plain]).empty


def test_a_claim_without_cells_and_the_adjustment_text():
    empty = claims.Rule("Obj 2", "c", "r", lambda e: claims.Cells(_cells().iloc[:0], {}))
    claim = empty.apply(None)
    assert claim.verdict == UNTESTABLE and claim.numbers == "no cell"
    assert claims.adjustment(1) == "95 % interval, one cell"
    assert claims.adjustment(13) == (
        "own 95 % intervals for 'holds', 99.6 % simultaneous over 13 cells (Bonferroni) for "
        "'does not hold'"
    )
    assert claims.adjustment(13, "majority") == (
        "99.6 % intervals: simultaneous 95 % over 13 cells (Bonferroni), both verdicts"
    )


def test_labelled_cells_join_their_keys_and_keep_each_subjects_value():
    frame = pd.DataFrame(
        {
            "subject": ["S2", "S1", "S1", "S2"],
            "test": ["T2", "T2", "T1", "T1"],
            "k": [1, 1, 2, 2],
            "v": [1.0, 2.0, 3.0, 4.0],
        }
    )
    cells = claims.labelled(claims.subject_cells(frame, ["test", "k"], "v"), ["test", "k"], "v")
    assert cells.values.tolist() == [
        ["T1 2", "S1", 3.0],
        ["T2 1", "S1", 2.0],
        ["T1 2", "S2", 4.0],
        ["T2 1", "S2", 1.0],
    ]
    assert claims.labelled(frame.iloc[:0], ["test"], "v").columns.tolist() == [
        "cell",
        "subject",
        "value",
    ]
    assert claims.one_cell("x", pd.Series([1.0, 2.0], index=["S1", "S2"])).values.tolist() == [
        ["x", "S1", 1.0],
        ["x", "S2", 2.0],
    ]


def test_the_tables_of_several_claims_are_numbered_afresh_and_empty_ones_keep_their_columns():
    one, two = _rule().apply(None), _rule(combine="majority").apply(None)
    assert claims.cells_table([one, two]).index.tolist() == list(range(20))
    assert claims.estimates_table([one, two]).index.tolist() == list(range(4))
    assert claims.cells_table([]).columns.tolist() == ["claim", "cell", "subject", "value"]
    plain = claims.Rule("Obj 1", "c", "r", lambda e: (HOLDS, "0.97"), key="plain").apply(None)
    row = claims.claims_table([plain]).iloc[0]
    assert (row["combine"], row["requirement"]) == ("", "")
    assert (two.claim, two.rule, two.judgement.combine) == (
        "below 2.5 deg",
        "every cell < 2.5",
        "majority",
    )


def test_the_numbers_text_without_unit_or_note_and_with_its_own_digits():
    def judge(evidence):
        cells = _cells()
        return claims.Cells(cells, claims.every_cell(cells, Requirement.of("<", 2.5)), digits=3)

    claim = claims.Rule("Obj 3", "c", "r", judge).apply(None)
    mean, low, high = _by_hand(VALUES["b"])
    _, own_low, own_high = _by_hand(VALUES["b"], 0.95)
    assert claim.numbers == (
        f"cell closest to failing: b {mean:.3f} [{own_low:.3f}, {own_high:.3f}], simultaneous "
        f"[{low:.3f}, {high:.3f}] (< 2.5); own 95 % intervals for 'holds', 97.5 % simultaneous "
        "over 2 cells (Bonferroni) for 'does not hold'; cells shown / beyond / undecided: 1 / 0 "
        "/ 1; n 5 subjects"
    )


def test_verdict_text_of_a_claim_no_affordable_n_decides():
    table = verdicts.judge(_cells(), {"b": Requirement.of("<", 2.5)}).estimates
    judgement = verdicts.Judgement(INCONCLUSIVE, table, "all", HOLDS, np.nan)
    claim = claims.Claim("Obj 3", "c", "r", INCONCLUSIVE, "", judgement=judgement)
    assert claims.verdict_text(claim) == (
        "inconclusive (leans 'holds'; not decidable with 100,000 subjects at these effects)"
    )


def test_a_claim_without_cells_keeps_the_estimates_columns_and_its_combination():
    judged = verdicts.judge(_cells(), claims.every_cell(_cells(), Requirement.of("<", 2.5)))
    empty = verdicts.judge(pd.DataFrame(), {}, "majority")
    assert empty.verdict == UNTESTABLE and empty.combine == "majority" and empty.m == 0
    assert empty.estimates.columns.tolist() == judged.estimates.columns.tolist()
    assert Requirement.of("<=", 1.0).text() == "<= 1" and Requirement.of(">", 1.0).text() == "> 1"


def test_cells_without_subjects_have_no_estimate():
    requirement = Requirement.of("<", 2.5)
    table = verdicts.estimates(pd.DataFrame(), {"a": requirement, "b": requirement})
    assert table["cell"].tolist() == ["a", "b"] and table["n"].tolist() == [0, 0]
    assert table["n"].dtype.kind == "i" and table["mean"].isna().all()
    assert table["state"].tolist() == ["undecided", "undecided"]
    # a claim over three cells, two without subjects: undecided, and it leans neither way
    judgement = verdicts.judge(
        _cells({"a": VALUES["a"]}),
        {"a": requirement, "b": requirement, "c": requirement},
        "majority",
    )
    assert judgement.verdict == INCONCLUSIVE and judgement.leaning == ""
    assert np.isnan(judgement.n_to_decide)
    claim = claims.Claim("Obj 3", "c", "r", INCONCLUSIVE, "", judgement=judgement)
    assert claims.verdict_text(claim) == "inconclusive (the estimates lean neither way)"


def test_the_leaning_follows_the_claims_own_combination():
    """'mostly' over three cells: one shown, one below on average but wide, one above on average
    but wide: undecided; the point estimates hold for 'mostly' (two of three), not for 'all'."""
    values = {
        "a": [1.0, 1.1, 0.9, 1.0, 1.0],
        "b": [0.5, 4.0, 0.2, 3.8, 0.4],
        "c": [4.5, 1.0, 4.8, 1.2, 4.4],
    }
    requirement = Requirement.of("<", 2.5)
    judgement = verdicts.judge(_cells(values), dict.fromkeys(values, requirement), "majority")
    assert judgement.verdict == INCONCLUSIVE and judgement.leaning == HOLDS
    decided = verdicts.judge(
        _cells(VALUES | {"b": [1.5] * 4 + [1.6]}), dict.fromkeys(VALUES, requirement), "majority"
    )
    assert decided.verdict == HOLDS and decided.combine == "majority"


def test_the_rule_vectorised_over_resamples_and_its_pieces():
    shown = np.array([[True, True, False], [True, False, False]])
    beyond = np.array([[False, False, False], [False, False, True]])
    assert verdicts.combined(shown, beyond, combine="majority").tolist() == [0, 2]
    assert verdicts.combined(shown, beyond, combine="all").tolist() == [2, 1]
    assert verdicts.level(1) == verdicts.level(0) == pytest.approx(0.95)
    assert verdicts.level(4) == pytest.approx(0.9875)
    assert verdicts.shown_level(4) == 0.95 and verdicts.shown_level(4, "majority") == 0.9875
    half = verdicts.half_width([1.0, 1.0, 1.0], [1, 2, 5], 0.95)
    assert np.isnan(half[0])
    assert half[1:] == pytest.approx([scipy_stats.t.ppf(0.975, n - 1) / np.sqrt(n) for n in (2, 5)])
    low_unknown = verdicts.cell_states(
        np.array([np.nan]), np.array([0.4]), verdicts.requirement_arrays([Requirement.of("<", 0.5)])
    )
    assert low_unknown[0].tolist() == [False]
    req = verdicts.requirement_arrays([Requirement.of("<", 2.5)] * 3)
    margins = verdicts.margins(np.array([2.0, 2.5, 3.5]), np.array([1.0, 0.0, 2.0]), req)
    assert margins.tolist() == [0.5, -np.inf, -0.5]


def test_the_probabilities_behind_n_to_decide_by_hand():
    """Each cell's P(shown) and P(beyond) are the noncentral t's one-sided probabilities at its
    distance to each bound; 'mostly' over three cells needs two shown (Poisson binomial)."""
    req = verdicts.requirement_arrays(
        [Requirement.of("<", 2.5), Requirement.of(">", 1.0), Requirement.within(0.0, 1.0)]
    )
    mean, sd, n = np.array([2.0, 1.6, 0.3]), np.array([0.5, 0.4, 0.5]), 12
    shown, beyond, negligible = verdicts.cell_probabilities(mean, sd, req, n, "majority")
    one = lambda d: float(verdicts._one_sided(np.array([d]), n, 1 - 0.05 / 3)[0])  # noqa: E731
    own = lambda d: float(verdicts._one_sided(np.array([d]), n, 0.95)[0])  # noqa: E731
    assert shown[0] == pytest.approx(one(1.0)) and beyond[0] == pytest.approx(one(-1.0))
    assert shown[1] == pytest.approx(one(1.5)) and beyond[1] == pytest.approx(one(-1.5))
    assert shown[2] == pytest.approx(one(2.6) * one(1.4))
    assert beyond[2] == pytest.approx(1 - (1 - one(-2.6)) * (1 - one(-1.4)))
    assert negligible.tolist() == [0.0, 0.0, 0.0]
    p = shown
    two_of_three = p[0] * p[1] + p[0] * p[2] + p[1] * p[2] - 2 * p[0] * p[1] * p[2]
    assert verdicts.decide_probability(mean, sd, req, "majority", HOLDS, n) == pytest.approx(
        two_of_three
    )
    every = verdicts.cell_probabilities(mean, sd, req, n, "all")  # shown on each own interval
    assert every[0][0] == pytest.approx(own(1.0)) and every[1][0] == pytest.approx(one(-1.0))
    assert verdicts.decide_probability(mean, sd, req, "all", HOLDS, n) == pytest.approx(
        every[0].prod()
    )
    b = beyond
    at_least_two = b[0] * b[1] + b[0] * b[2] + b[1] * b[2] - 2 * b[0] * b[1] * b[2]
    assert verdicts.decide_probability(mean, sd, req, "majority", FAILS, n) == pytest.approx(
        at_least_two
    )
    two = {k: v[:2] for k, v in req.items()}
    still = verdicts.cell_probabilities(np.array([2.0, 3.0]), np.array([0.0, 0.0]), two, n)[:2]
    assert still[0].tolist() == [1.0, 1.0] and still[1].tolist() == [0.0, 0.0]
    assert np.isnan(verdicts.n_to_decide(mean, np.array([0.5, np.nan, 0.5]), req, "all", HOLDS))
