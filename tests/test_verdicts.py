"""Verdicts from subject-level cells (issues 42, 51): each cell's own interval shows a claim over
every cell (intersection-union), the intervals simultaneous over the cells fail it; a smallest
effect of interest gives "no relevant difference"; the way an undecided claim leans; the subjects
that would decide it, checked against statsmodels' power and against simulation."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from aceval.evaluation import verdicts as v
from aceval.evaluation.verdicts import (
    FAILS,
    HOLDS,
    INCONCLUSIVE,
    NEGLIGIBLE,
    UNTESTABLE,
    Requirement,
)


def _cells(values: dict) -> pd.DataFrame:
    """{cell: values over the subjects} -> the long cells table."""
    return pd.DataFrame(
        [
            {"cell": cell, "subject": f"S{s}", "value": x}
            for cell, xs in values.items()
            for s, x in enumerate(xs)
        ]
    )


def test_each_cell_has_its_own_interval_and_one_bonferroni_over_the_claims_cells():
    """Three cells: the simultaneous interval is scipy's t-interval at 1 - 0.05 / 3, the cell's
    own at 95 % (for "mostly", both are the simultaneous one)."""
    values = {"a": [1.0, 2.0, 3.0, 4.0], "b": [0.5, 0.7, 0.2, 0.9], "c": [2.0, 2.5, 2.1, 2.9]}
    requirements = {c: Requirement.of("<", 5.0) for c in values}
    table = v.estimates(_cells(values), requirements).set_index("cell")
    mostly = v.estimates(_cells(values), requirements, "majority").set_index("cell")
    for cell, xs in values.items():
        low, high = stats.t.interval(1 - 0.05 / 3, len(xs) - 1, np.mean(xs), stats.sem(xs))
        own = stats.t.interval(0.95, len(xs) - 1, np.mean(xs), stats.sem(xs))
        assert tuple(table.loc[cell, ["low", "high"]]) == pytest.approx((low, high))
        assert tuple(table.loc[cell, ["low_each", "high_each"]]) == pytest.approx(own)
        assert tuple(mostly.loc[cell, ["low_each", "high_each"]]) == pytest.approx((low, high))


def test_holds_over_every_cell_needs_no_adjustment_and_fails_need_it():
    """Eight cells of five subjects, each 1.5 below 1 (SD 0.79): every cell's own 95 % interval
    is below 1 (holds: an intersection-union test); their intervals simultaneous over the 8
    cells are not. The same distance above the bound: each own interval wholly above, not the
    simultaneous ones: inconclusive, leaning 'does not hold'."""
    base = np.array([-1.0, 0.0, 1.0, -0.5, 0.5])
    below = {f"c{k}": -0.5 + base for k in range(8)}
    requirements = {c: Requirement.of("<", 1.0) for c in below}
    table = v.estimates(_cells(below), requirements)
    assert (table["high_each"] < 1.0).all() and (table["high"] > 1.0).all()
    assert v.judge(_cells(below), requirements).verdict == HOLDS
    above = {c: 2.0 - x for c, x in below.items()}
    judged = v.judge(_cells(above), requirements)
    assert (judged.estimates["low_each"] > 1.0).all() and (judged.estimates["low"] < 1.0).all()
    assert judged.verdict == INCONCLUSIVE and judged.leaning == FAILS


def test_no_relevant_difference_within_the_smallest_effect_of_interest():
    """Superiority '> 0' with a smallest effect of 1: a cell whose interval lies within +-1 is
    negligible (here significant on the wrong side, the old rule's 'does not hold'); every cell
    negligible or shown: no relevant difference; the leaning and the subjects that would decide
    it that way."""
    requirement = Requirement.of(">", 0.0, 1.0)
    tiny = {"a": [-0.05, -0.04, -0.06, -0.05, -0.03], "b": [2.0, 2.2, 1.9, 2.1, 2.3]}
    judged = v.judge(_cells(tiny), dict.fromkeys(tiny, requirement))
    assert judged.estimates["state"].tolist() == ["negligible", "shown"]
    assert judged.verdict == NEGLIGIBLE
    without = v.judge(_cells(tiny), dict.fromkeys(tiny, Requirement.of(">", 0.0)))
    assert without.verdict == FAILS
    wide = {"a": [2.0, -1.5, 1.8, -1.2, 0.5, 0.2]}
    leaning = v.judge(_cells(wide), dict.fromkeys(wide, requirement))
    assert leaning.verdict == INCONCLUSIVE and leaning.leaning == NEGLIGIBLE
    n = leaning.n_to_decide
    req = v.requirement_arrays([requirement])
    mean, sd = np.array([np.mean(wide["a"])]), np.array([np.std(wide["a"], ddof=1)])
    assert v.decide_probability(mean, sd, req, "all", NEGLIGIBLE, int(n)) >= v.POWER
    assert v.decide_probability(mean, sd, req, "all", NEGLIGIBLE, int(n) - 1) < v.POWER
    rng = np.random.default_rng(2)
    draws = rng.normal(mean, sd, size=(4000, int(n), 1))
    codes = v.verdict_codes(
        draws.mean(axis=1), draws.std(axis=1, ddof=1), np.full((4000, 1), int(n)), req
    )
    assert np.mean(codes == 3) == pytest.approx(0.8, abs=0.04)


def test_one_cell_beyond_its_bound_after_adjustment_fails_the_claim_and_not_before():
    """Cell b's unadjusted 95 % interval is wholly above 1 (the old rule: 'does not hold'); over
    13 cells its simultaneous interval reaches below 1: inconclusive, leaning 'does not hold'."""
    rng = np.random.default_rng(3)
    values = {f"c{k}": 0.4 + rng.normal(0, 0.1, 5) for k in range(12)}
    values["b"] = np.array([1.6, 2.5, 3.4, 2.2, 1.9])
    low95 = stats.t.interval(0.95, 4, np.mean(values["b"]), stats.sem(values["b"]))[0]
    assert low95 > 1.0
    judged = v.judge(_cells(values), {c: Requirement.of("<", 1.0) for c in values})
    assert judged.verdict == INCONCLUSIVE and judged.leaning == FAILS
    assert judged.deciding["cell"] == "b" and judged.m == 13
    assert judged.level == pytest.approx(1 - 0.05 / 13)
    far = {**values, "b": values["b"] + 3.0}
    assert v.judge(_cells(far), {c: Requirement.of("<", 1.0) for c in far}).verdict == FAILS


def test_holds_needs_every_cell_and_mostly_needs_more_than_half():
    shown = {"a": [0.1, 0.2, 0.15, 0.12], "b": [0.3, 0.25, 0.28, 0.31]}
    requirements = {c: Requirement.of("<", 1.0) for c in shown}
    assert v.judge(_cells(shown), requirements).verdict == HOLDS
    mixed = {**shown, "c": [2.0, 2.1, 1.9, 2.05]}  # one cell well beyond
    requirements = {c: Requirement.of("<", 1.0) for c in mixed}
    assert v.judge(_cells(mixed), requirements).verdict == FAILS
    assert v.judge(_cells(mixed), requirements, "majority").verdict == HOLDS  # 2 of 3
    half = {**mixed, "d": [2.0, 2.2, 1.8, 2.1]}  # 2 of 4 beyond: "mostly" cannot be met
    requirements = {c: Requirement.of("<", 1.0) for c in half}
    assert v.judge(_cells(half), requirements, "majority").verdict == FAILS
    assert v.judge(_cells({}), {}).verdict == UNTESTABLE


def test_equivalence_holds_inside_the_margin_and_fails_wholly_outside_it():
    requirement = {"d": Requirement.within(0.0, 0.004)}
    inside = {"d": [0.0005, -0.0004, 0.0002, 0.0001, -0.0003]}
    outside = {"d": [0.010, 0.012, 0.011, 0.0105, 0.0115]}
    wide = {"d": [0.0, 0.006, -0.006, 0.003, -0.002]}
    assert v.judge(_cells(inside), requirement).verdict == HOLDS
    assert v.judge(_cells(outside), requirement).verdict == FAILS
    assert v.judge(_cells(wide), requirement).verdict == INCONCLUSIVE
    assert Requirement.within(0.0, 0.004).text() == "> -0.004 and < 0.004"


def test_one_subject_gives_no_interval_and_the_claim_is_not_testable():
    judged = v.judge(_cells({"a": [0.1]}), {"a": Requirement.of("<", 1.0)})
    assert judged.verdict == UNTESTABLE and np.isnan(judged.estimates["low"].iloc[0])
    assert judged.estimates["n"].tolist() == [1]
    two = v.judge(
        _cells({"a": [0.1], "b": [0.2, 0.3]}), dict.fromkeys("ab", Requirement.of("<", 1.0))
    )
    assert two.verdict == INCONCLUSIVE  # one cell has an interval: testable, not decided


def test_n_to_decide_of_one_cell_is_statsmodels_power_of_a_one_sided_t_test():
    """One cell, d = 0.5 SD on the claim's side: the n for 80 % power of the one-sided t-test at
    2.5 % (the 95 % interval's side) is statsmodels' solve_power, rounded up."""
    from statsmodels.stats.power import TTestPower

    req = v.requirement_arrays([Requirement.of(">", 0.0)])
    n = v.n_to_decide(np.array([0.5]), np.array([1.0]), req, "all", HOLDS)
    expected = TTestPower().solve_power(0.5, alpha=0.025, power=0.8, alternative="larger")
    assert n == np.ceil(expected)


def test_n_to_decide_reaches_its_power_in_simulation():
    """Three cells of normal subjects (means 0.3, 0.5, 0.8 SD below a bound): at the n found,
    about 80 % of simulated studies show every cell (the rule's own code judges them)."""
    mean, sd = np.array([-0.3, -0.5, -0.8]), np.ones(3)
    req = v.requirement_arrays([Requirement.of("<", 0.0)] * 3)
    n = int(v.n_to_decide(mean, sd, req, "all", HOLDS))
    rng = np.random.default_rng(0)
    draws = rng.normal(mean, sd, size=(4000, n, 3))
    codes = v.verdict_codes(
        draws.mean(axis=1), draws.std(axis=1, ddof=1), np.full((4000, 3), n), req
    )
    assert np.mean(codes == 0) == pytest.approx(0.8, abs=0.03)
    codes_before = v.verdict_codes(
        draws[:, : n - 3].mean(axis=1),
        draws[:, : n - 3].std(axis=1, ddof=1),
        np.full((4000, 3), n - 3),
        req,
    )
    assert np.mean(codes_before == 0) < 0.8


def test_poisson_binomial_tail_by_brute_force():
    import itertools

    p = np.array([0.1, 0.5, 0.7, 0.9])
    for k in range(5):
        brute = sum(
            np.prod([q if hit else 1 - q for q, hit in zip(p, hits)])
            for hits in itertools.product([0, 1], repeat=4)
            if sum(hits) >= k
        )
        assert v.at_least(p, k) == pytest.approx(brute)
