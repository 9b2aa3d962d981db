"""Every comparator of the claims' rules, table-driven (issue 44, on issue 42's rule in
evaluation/verdicts.py): each side of a bound, both boundaries, NaN and infinities, equivalence
margins, how cells combine into a verdict, and the formatting of the numbers a claim prints."""

import numpy as np
import pandas as pd
import pytest

from aceval.evaluation import verdicts
from aceval.evaluation.verdicts import Requirement, requirement_arrays
from aceval.report import claims
from aceval.report.claims import FAILS, HOLDS, INCONCLUSIVE, NEGLIGIBLE, UNTESTABLE

NAN, INF = float("nan"), float("inf")


def state(low, high, requirement: Requirement, low_each=None, high_each=None) -> str:
    """One cell's interval against its requirement: 'shown', 'beyond', 'negligible' or
    'undecided' (``low_each``, ``high_each``: its own interval, default the same one)."""
    each = [None if v is None else np.array([v]) for v in (low_each, high_each)]
    shown, beyond, negligible = verdicts.cell_states(
        np.array([low]), np.array([high]), requirement_arrays([requirement]), *each
    )
    assert shown[0] + beyond[0] + negligible[0] <= 1, "a cell has one state"
    if shown[0] or beyond[0]:
        return "shown" if shown[0] else "beyond"
    return "negligible" if negligible[0] else "undecided"


# (low, high, limit, side, state): an interval wholly on one side, wholly on the other,
# straddling the limit, and touching it from each end
SIDES = [
    # "<": shown when the whole interval is below; at the limit is not below
    (0.1, 0.4, 0.5, "<", "shown"),
    (0.1, 0.5, 0.5, "<", "undecided"),
    (0.4, 0.6, 0.5, "<", "undecided"),
    (0.5, 0.9, 0.5, "<", "beyond"),
    (0.6, 0.9, 0.5, "<", "beyond"),
    # "<=": the limit itself is on the claim's side
    (0.1, 0.5, 0.5, "<=", "shown"),
    (0.1, 0.4, 0.5, "<=", "shown"),
    (0.4, 0.6, 0.5, "<=", "undecided"),
    (0.5, 0.9, 0.5, "<=", "undecided"),
    (0.6, 0.9, 0.5, "<=", "beyond"),
    # ">"
    (0.6, 0.9, 0.5, ">", "shown"),
    (0.5, 0.9, 0.5, ">", "undecided"),
    (0.4, 0.6, 0.5, ">", "undecided"),
    (0.1, 0.5, 0.5, ">", "beyond"),
    (0.1, 0.4, 0.5, ">", "beyond"),
    # ">="
    (0.5, 0.9, 0.5, ">=", "shown"),
    (0.6, 0.9, 0.5, ">=", "shown"),
    (0.4, 0.6, 0.5, ">=", "undecided"),
    (0.1, 0.5, 0.5, ">=", "undecided"),
    (0.1, 0.4, 0.5, ">=", "beyond"),
    # negative limits and a point interval
    (-2.0, -1.5, -1.0, "<", "shown"),
    (-0.5, -0.5, -1.0, ">", "shown"),
    (-1.0, -1.0, -1.0, ">=", "shown"),
    (-1.0, -1.0, -1.0, ">", "beyond"),
]


@pytest.mark.parametrize("low, high, limit, side, expected", SIDES)
def test_a_cell_on_every_side_and_boundary(low, high, limit, side, expected):
    assert state(low, high, Requirement.of(side, limit)) == expected


@pytest.mark.parametrize("side", ["<", "<=", ">", ">="])
@pytest.mark.parametrize("low, high", [(NAN, NAN), (-INF, INF)])
def test_a_cell_without_a_finite_interval_is_undecided(low, high, side):
    """Fewer than two subjects give NaN bounds; neither side is shown."""
    assert state(low, high, Requirement.of(side, 0.5)) == "undecided"


def test_an_unknown_side_is_refused():
    with pytest.raises(ValueError, match="not one of"):
        Requirement.of("==", 0.5)


# (low, high, margin, state): equivalence is the open region target +- margin (two one-sided
# tests on the same simultaneous interval)
EQUIVALENT = [
    (-0.01, 0.01, 0.019, "shown"),
    (-0.018, 0.018, 0.019, "shown"),
    (-0.019, 0.01, 0.019, "undecided"),  # touching the margin is not inside
    (-0.01, 0.019, 0.019, "undecided"),
    (-0.01, 0.03, 0.019, "undecided"),
    (-0.03, 0.01, 0.019, "undecided"),
    (-0.05, 0.05, 0.019, "undecided"),  # wide: neither
    (0.03, 0.05, 0.019, "beyond"),  # wholly above +margin
    (-0.05, -0.03, 0.019, "beyond"),  # wholly below -margin
    (0.019, 0.06, 0.019, "beyond"),  # from the open region's edge outwards: outside it
    (-0.06, -0.019, 0.019, "beyond"),
]


@pytest.mark.parametrize("low, high, margin, expected", EQUIVALENT)
def test_equivalence_on_both_sides_and_boundaries(low, high, margin, expected):
    assert state(low, high, Requirement.within(0.0, margin)) == expected


@pytest.mark.parametrize(
    "target, expected",
    [(1.0, "shown"), (0.995, "shown"), (1.005, "shown"), (1.2, "beyond"), (0.8, "beyond")]
    + [(1.04, "undecided"), (0.96, "undecided")],
)
def test_equivalence_is_centred_on_its_target(target, expected):
    """An interval 1.0 +- 0.02 against target +- 0.05."""
    assert state(0.98, 1.02, Requirement.within(target, 0.05)) == expected


def test_requirements_print_their_bounds():
    assert Requirement.of("<", 2.5).text() == "< 2.5"
    assert Requirement.of(">=", 0.14).text() == ">= 0.14"
    assert Requirement.within(0.0, 0.004).text() == "> -0.004 and < 0.004"
    assert Requirement.of(">", 0.0, 1.0).text() == "> 0; no relevant difference within +-1"


# (low, high, state) of a superiority cell "> 0" with a smallest effect of interest of 1: within
# +-1 of the bound it is negligible, whichever side and however significant
SUPERIORITY = [
    (0.2, 1.5, "shown"),  # above 0, not within the band: a difference shown, relevance open
    (1.2, 1.5, "shown"),
    (0.2, 0.9, "negligible"),  # above 0 but within +-1: too small to matter
    (-0.5, 0.5, "negligible"),
    (-0.9, -0.1, "negligible"),  # below 0, within the band: not beyond
    (-1.5, -0.1, "beyond"),
    (-0.5, 1.5, "undecided"),
    (-1.0, 0.5, "undecided"),  # touching the band's edge is not inside it
]


@pytest.mark.parametrize("low, high, expected", SUPERIORITY)
def test_a_superiority_cell_with_a_smallest_effect_of_interest(low, high, expected):
    assert state(low, high, Requirement.of(">", 0.0, 1.0)) == expected
    mirrored = {"shown": "shown", "beyond": "beyond"}.get(expected, expected)
    assert state(-high, -low, Requirement.of("<", 0.0, 1.0)) == mirrored


def test_shown_reads_the_cells_own_interval_and_beyond_the_simultaneous_one():
    """An all-cells claim is shown on each cell's own 95 % interval (intersection-union) and
    fails on the simultaneous one: a cell whose own interval is above 0 but whose simultaneous
    interval straddles it is shown; one whose own interval is below 0 but whose simultaneous
    interval straddles it is not beyond."""
    requirement = Requirement.of(">", 0.0)
    assert state(-0.2, 1.0, requirement, 0.1, 0.8) == "shown"
    assert state(-1.0, 0.2, requirement, -0.8, -0.1) == "undecided"
    assert state(-1.0, -0.1, requirement, -0.8, -0.3) == "beyond"


# (cell states, combine, verdict): 'all' needs every cell shown and fails on one beyond;
# 'majority' ("mostly") holds on more than half shown and fails on at least half beyond
COMBINED = [
    (["negligible"], "all", NEGLIGIBLE),
    (["shown", "negligible"], "all", NEGLIGIBLE),
    (["negligible", "undecided"], "all", INCONCLUSIVE),
    (["negligible", "beyond"], "all", FAILS),
    (["negligible", "shown", "shown"], "majority", HOLDS),
    (["negligible", "undecided"], "majority", INCONCLUSIVE),
    (["shown"], "all", HOLDS),
    (["shown"] * 3, "all", HOLDS),
    (["beyond"], "all", FAILS),
    (["shown", "beyond"], "all", FAILS),
    (["undecided", "beyond"], "all", FAILS),
    (["shown", "undecided"], "all", INCONCLUSIVE),
    (["undecided"], "all", INCONCLUSIVE),
    (["shown", "shown", "undecided"], "majority", HOLDS),
    (["shown", "undecided"], "majority", INCONCLUSIVE),  # one of two is not more than half
    (["shown", "beyond"], "majority", FAILS),  # half beyond
    (["shown", "shown", "beyond"], "majority", HOLDS),
    (["undecided", "undecided", "beyond"], "majority", INCONCLUSIVE),
]


@pytest.mark.parametrize("states, combine, verdict", COMBINED)
def test_cells_combine_into_a_verdict(states, combine, verdict):
    states = np.array(states)
    code = verdicts.combined(
        states == "shown", states == "beyond", states == "negligible", combine=combine
    )
    assert verdicts.CODES[int(code)] == verdict


def test_an_unknown_combination_is_refused():
    with pytest.raises(ValueError, match="not one of"):
        verdicts.combined(np.array([True]), np.array([False]), combine="any")


def test_a_claim_without_cells_is_not_testable():
    assert verdicts.judge(pd.DataFrame(), {}).verdict == UNTESTABLE


@pytest.mark.parametrize(
    "mean, low, high, digits, text",
    [
        (2.494, 1.925, 3.0549, 2, "2.49 [1.93, 3.05]"),
        (0.98765, 0.9712, 0.99991, 3, "0.988 [0.971, 1.000]"),
        (-1.5, -2.25, -0.75, 1, "-1.5 [-2.2, -0.8]"),
        (1.0, NAN, NAN, 2, "1.00 (no interval)"),
        (1.0, 0.5, NAN, 2, "1.00 (no interval)"),
        (1.0, INF, 2.0, 2, "1.00 (no interval)"),
        (NAN, 0.5, 1.5, 2, "n/a"),
    ],
)
def test_interval_prints_the_numbers_a_claim_quotes(mean, low, high, digits, text):
    assert claims.interval(mean, low, high, digits) == text


def test_interval_prints_two_decimals_by_default():
    assert claims.interval(2.494, 1.925, 3.0549) == "2.49 [1.93, 3.05]"


def test_present_keeps_the_rows_with_subjects():
    table = pd.DataFrame({"cell": ["a", "b", "c"], "n": [5, 0, 1]})
    assert claims.present(table)["cell"].tolist() == ["a", "c"]
    assert claims.present(None).empty


def test_a_rule_applies_its_judge_and_keeps_its_words():
    rule = claims.Rule("Obj 4", "below 1 deg", "the interval below 1", lambda e: (HOLDS, str(e)))
    claim = rule.apply(0.5)
    assert claim == claims.Claim("Obj 4", "below 1 deg", "the interval below 1", HOLDS, "0.5")
    assert claim.section == claims.PAPER
    code = claims.Rule("Obj 3-5", "c", "r", lambda e: (UNTESTABLE, "why"), claims.CODE)
    assert code.apply(None).section == claims.CODE and code.apply(None).numbers == "why"
    assert claims.VERDICTS == (HOLDS, FAILS, INCONCLUSIVE, NEGLIGIBLE, UNTESTABLE)
