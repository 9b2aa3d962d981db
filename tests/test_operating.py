"""Issue 42: the operating characteristics of the claims' rules and the powered design's n, on
cases whose answer is known, and the committed powered design's consistency with its config."""

import numpy as np
import pandas as pd
import pytest
import yaml

from aceval.evaluation.verdicts import Requirement, requirement_arrays
from aceval.report import operating

from .runner import REPO


def _population(means, sd=1.0, subjects=200, seed=0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    return pd.DataFrame(
        rng.normal(means, sd, size=(subjects, len(means))),
        columns=[f"c{k}" for k in range(len(means))],
    )


def test_a_shifted_population_puts_the_deciding_cell_where_the_scenario_says():
    """Three cells below a bound of 0 by 2, 1 and 3 SDs: shifted to 'false by 0.5 SD', the
    closest one lies 0.5 SD above the bound and the others keep their distances to it."""
    wide = _population([-2.0, -1.0, -3.0])
    req = requirement_arrays([Requirement.of("<", 0.0)] * 3)
    moved = operating.shifted(wide, req, "all", -0.5)
    before = -(wide.mean() / wide.std()).to_numpy()  # SDs below the bound
    after = -(moved.mean() / moved.std()).to_numpy()
    assert after[1] == pytest.approx(-0.5)
    np.testing.assert_allclose(after - after[1], before - before[1])
    within = requirement_arrays([Requirement.within(0.0, 0.1)])
    centred = operating.shifted(_population([0.05], sd=1.0), within, "all", 0.5)
    assert centred.mean().iloc[0] == pytest.approx(0.0, abs=1e-12)  # no farther in than the middle


def test_the_rule_says_holds_when_true_and_does_not_hold_when_false_with_enough_subjects():
    """One cell, 200 normal subjects: with 60 subjects drawn, true by 0.5 SD mostly holds and
    false by 0.5 SD mostly fails; with 5, both are mostly inconclusive; at the bound 'holds'
    comes at most 2.5 % of the time (the interval's one side)."""
    wide = _population([0.0])
    req = requirement_arrays([Requirement.of(">", 0.0)])
    rng = np.random.default_rng(1)
    true = operating.sampled(operating.shifted(wide, req, "all", 0.5), req, "all", 60, rng)
    false = operating.sampled(operating.shifted(wide, req, "all", -0.5), req, "all", 60, rng)
    small = operating.sampled(operating.shifted(wide, req, "all", 0.5), req, "all", 5, rng)
    bound = operating.sampled(operating.shifted(wide, req, "all", 0.0), req, "all", 60, rng)
    assert true["p_holds"] > 0.9 and false["p_fails"] > 0.9
    assert small["p_inconclusive"] > 0.6
    assert bound["p_holds"] < 0.04 and bound["p_fails"] < 0.04
    assert true["coverage_median"] == pytest.approx(0.95, abs=0.015)


def test_the_powered_design_is_the_committed_one_with_the_n_fixed_in_advance():
    """config/powered.yaml simulates POWERED_N subjects, and the committed kong_powered results
    judge its claims on that many; the committed power analysis is what fixed it."""
    spec = yaml.safe_load((REPO / "config" / "powered.yaml").read_text())
    assert spec["datasets"]["kong_powered"]["simulate"]["subjects"] == operating.POWERED_N
    cells = pd.read_csv(REPO / "results" / "kong_powered" / "tables" / "claim_cells.csv")
    assert cells["subject"].nunique() == operating.POWERED_N
    power = pd.read_csv(REPO / "results" / "operating_characteristics" / "power.csv")
    assert operating.powered_n(power) == operating.POWERED_N
    assert power.loc[power["affordable"], "n_to_decide"].max() <= operating.AFFORDABLE_N


def test_the_committed_operating_characteristics_cover_every_claim_at_both_n():
    table = pd.read_csv(
        REPO / "results" / "operating_characteristics" / "operating_characteristics.csv"
    )
    kong = table[table["population"].str.startswith("kong_powered")]
    assert set(kong["n"]) == {5, operating.POWERED_N}
    assert set(table["scenario"]) == set(operating.SCENARIOS)
    shares = table[["p_holds", "p_fails", "p_inconclusive"]].sum(axis=1)
    np.testing.assert_allclose(shares, 1.0, atol=1e-9)
    claims = pd.read_csv(REPO / "results" / "kong_powered" / "tables" / "claims.csv")
    assert set(claims.loc[claims["cells"] > 0, "claim"]) == set(kong["claim"])
