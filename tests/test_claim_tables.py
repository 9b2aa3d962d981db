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


def _by_hand(values) -> tuple[float, float, float]:
    """Mean and the interval simultaneous over two cells (97.5 % each)."""
    x = np.asarray(values)
    low, high = scipy_stats.t.interval(0.975, len(x) - 1, loc=x.mean(), scale=scipy_stats.sem(x))
    return float(x.mean()), float(low), float(high)


def test_an_undecided_claim_prints_its_deciding_cell_adjustment_states_and_note():
    claim = _rule().apply(None)
    mean, low, high = _by_hand(VALUES["b"])
    assert high > 2.5 > mean  # undecided by construction
    assert claim.verdict == INCONCLUSIVE and claim.key == "below_2.5"
    assert claim.numbers == (
        f"cell closest to failing: b {mean:.2f} [{low:.2f}, {high:.2f}] deg (< 2.5 deg); "
        "97.5 % intervals: simultaneous 95 % over 2 cells (Bonferroni); cells shown / beyond / "
        "undecided: 1 / 0 / 1; n 5 subjects; the paper: < 2.5"
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
        "99.6 % intervals: simultaneous 95 % over 13 cells (Bonferroni)"
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
