"""Every comparator of the claims' rules (report/claims.py), table-driven: each side, both
boundaries, NaN and infinities, and the formatting of the numbers a claim prints (issue 44)."""

import pandas as pd
import pytest

from aceval.report import claims
from aceval.report.claims import FAILS, HOLDS, INCONCLUSIVE, UNTESTABLE

NAN, INF = float("nan"), float("inf")

# (low, high, limit, side, verdict): an interval wholly on one side, wholly on the other,
# straddling the limit, and touching it from each end
BEYOND = [
    # "<": holds when the whole interval is below; at the limit is not below
    (0.1, 0.4, 0.5, "<", HOLDS),
    (0.1, 0.5, 0.5, "<", INCONCLUSIVE),
    (0.4, 0.6, 0.5, "<", INCONCLUSIVE),
    (0.5, 0.9, 0.5, "<", FAILS),
    (0.6, 0.9, 0.5, "<", FAILS),
    # "<=": the limit itself is on the claim's side
    (0.1, 0.5, 0.5, "<=", HOLDS),
    (0.1, 0.4, 0.5, "<=", HOLDS),
    (0.4, 0.6, 0.5, "<=", INCONCLUSIVE),
    (0.5, 0.9, 0.5, "<=", INCONCLUSIVE),
    (0.6, 0.9, 0.5, "<=", FAILS),
    # ">"
    (0.6, 0.9, 0.5, ">", HOLDS),
    (0.5, 0.9, 0.5, ">", INCONCLUSIVE),
    (0.4, 0.6, 0.5, ">", INCONCLUSIVE),
    (0.1, 0.5, 0.5, ">", FAILS),
    (0.1, 0.4, 0.5, ">", FAILS),
    # ">="
    (0.5, 0.9, 0.5, ">=", HOLDS),
    (0.6, 0.9, 0.5, ">=", HOLDS),
    (0.4, 0.6, 0.5, ">=", INCONCLUSIVE),
    (0.1, 0.5, 0.5, ">=", INCONCLUSIVE),
    (0.1, 0.4, 0.5, ">=", FAILS),
    # negative limits and a point interval
    (-2.0, -1.5, -1.0, "<", HOLDS),
    (-0.5, -0.5, -1.0, ">", HOLDS),
    (-1.0, -1.0, -1.0, ">=", HOLDS),
    (-1.0, -1.0, -1.0, ">", FAILS),
]


@pytest.mark.parametrize("low, high, limit, side, verdict", BEYOND)
def test_beyond_on_every_side_and_boundary(low, high, limit, side, verdict):
    assert claims.beyond(low, high, limit, side) == verdict


@pytest.mark.parametrize("side", ["<", "<=", ">", ">="])
@pytest.mark.parametrize("low, high", [(NAN, NAN), (NAN, 0.4), (0.1, NAN), (-INF, 0.4), (0.1, INF)])
def test_beyond_without_a_finite_interval_is_inconclusive(low, high, side):
    assert claims.beyond(low, high, 0.5, side) == INCONCLUSIVE


def test_beyond_refuses_an_unknown_side():
    with pytest.raises(KeyError):
        claims.beyond(0.1, 0.2, 0.5, "==")


# (low90, high90, low, high, margin, verdict): the 90 % interval inside +-margin holds; the 95 %
# interval wholly outside it on either side fails; anything else is undecided
EQUIVALENT = [
    (-0.01, 0.01, -0.02, 0.02, 0.019, HOLDS),
    (-0.018, 0.018, -0.03, 0.03, 0.019, HOLDS),  # the 95 % interval may reach beyond
    (-0.019, 0.01, -0.02, 0.02, 0.019, INCONCLUSIVE),  # touching the margin is not inside
    (-0.01, 0.019, -0.02, 0.02, 0.019, INCONCLUSIVE),
    (-0.01, 0.03, -0.02, 0.04, 0.019, INCONCLUSIVE),
    (-0.03, 0.01, -0.04, 0.02, 0.019, INCONCLUSIVE),
    (0.03, 0.05, 0.025, 0.06, 0.019, FAILS),  # wholly above +margin
    (-0.05, -0.03, -0.06, -0.025, 0.019, FAILS),  # wholly below -margin
    (0.03, 0.05, 0.019, 0.06, 0.019, INCONCLUSIVE),  # the 95 % interval touches +margin
    (-0.05, -0.03, -0.06, -0.019, 0.019, INCONCLUSIVE),  # ... and -margin
    (-0.05, 0.05, -0.06, 0.06, 0.019, INCONCLUSIVE),  # wide: neither
    (0.0, 0.0, 0.0, 0.0, 0.0, INCONCLUSIVE),  # no margin: never inside, never outside
]


@pytest.mark.parametrize("low90, high90, low, high, margin, verdict", EQUIVALENT)
def test_equivalent_on_both_sides_and_boundaries(low90, high90, low, high, margin, verdict):
    assert claims.equivalent(low90, high90, low, high, margin) == verdict


@pytest.mark.parametrize("missing", range(4))
@pytest.mark.parametrize("value", [NAN, INF, -INF])
def test_equivalent_without_a_finite_interval_is_inconclusive(missing, value):
    bounds = [-0.01, 0.01, -0.02, 0.02]
    bounds[missing] = value
    assert claims.equivalent(*bounds, 0.019) == INCONCLUSIVE


@pytest.mark.parametrize(
    "target, verdict",
    [
        (1.0, HOLDS),
        (1.0 - 0.005, HOLDS),
        (1.0 + 0.005, HOLDS),
        (1.2, FAILS),
        (0.8, FAILS),
        (1.0 + 0.04, INCONCLUSIVE),
        (1.0 - 0.04, INCONCLUSIVE),
    ],
)
def test_equivalent_to_shifts_the_estimate_by_the_target(target, verdict):
    """An estimate 1.0 with a 90 % interval +-0.01 and a 95 % one +-0.02, margin 0.05."""
    estimate = pd.Series({"low90": 0.99, "high90": 1.01, "low": 0.98, "high": 1.02})
    assert claims.equivalent_to(estimate, target, 0.05) == verdict
    # the same through a dict, as the rules pass rows of cell estimates
    assert claims.equivalent_to(dict(estimate), target, 0.05) == verdict


def test_equivalent_to_reads_each_bound_from_its_own_column():
    """A 90 % interval inside the margin and a 95 % one far outside it: holds (the 90 % one
    decides); swapping the columns would fail it."""
    estimate = {"low90": 1.0, "high90": 1.04, "low": 1.06, "high": 1.2}
    assert claims.equivalent_to(estimate, 1.02, 0.03) == HOLDS
    assert claims.equivalent_to(estimate, 0.9, 0.03) == FAILS  # the 95 % wholly above 0.93


@pytest.mark.parametrize(
    "verdicts, combined",
    [
        ([], UNTESTABLE),
        ([HOLDS], HOLDS),
        ([HOLDS, HOLDS, HOLDS], HOLDS),
        ([FAILS], FAILS),
        ([HOLDS, FAILS], FAILS),
        ([INCONCLUSIVE, FAILS], FAILS),
        ([HOLDS, INCONCLUSIVE], INCONCLUSIVE),
        ([INCONCLUSIVE], INCONCLUSIVE),
        ([HOLDS, UNTESTABLE], INCONCLUSIVE),  # a part not judged: the whole is not shown
        ([UNTESTABLE, FAILS], FAILS),
    ],
)
def test_every_needs_all_parts(verdicts, combined):
    assert claims.every(verdicts) == combined
    assert claims.every(iter(verdicts)) == combined  # a generator, as the rules pass


def test_tally_counts_holds_fails_and_undecided_in_that_order():
    verdicts = [HOLDS, FAILS, INCONCLUSIVE, HOLDS, UNTESTABLE, HOLDS, INCONCLUSIVE]
    assert claims.tally(verdicts) == "3 / 1 / 2"
    assert claims.tally([]) == "0 / 0 / 0"


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


def test_cells_keeps_the_rows_with_subjects():
    table = pd.DataFrame({"cell": ["a", "b", "c"], "n": [5, 0, 1]})
    assert claims._cells(table)["cell"].tolist() == ["a", "c"]
    assert claims._cells(None).empty


def test_a_rule_applies_its_judge_and_keeps_its_words():
    rule = claims.Rule("Obj 4", "below 1 deg", "the interval below 1", lambda e: (HOLDS, str(e)))
    claim = rule.apply(0.5)
    assert claim == claims.Claim("Obj 4", "below 1 deg", "the interval below 1", HOLDS, "0.5")
    assert claim.section == claims.PAPER
    code = claims.Rule("Obj 3-5", "c", "r", lambda e: (UNTESTABLE, "why"), claims.CODE)
    assert code.apply(None).section == claims.CODE and code.apply(None).numbers == "why"
    assert claims.VERDICTS == (HOLDS, FAILS, INCONCLUSIVE, UNTESTABLE)
