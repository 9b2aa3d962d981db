"""For every sensor, the calibration to trust (issue 39): methods that disagree beyond their
uncertainties say so, the decision rests on accuracy where there is a truth and on repeatability
where there is none, and every committed decision table holds to what it says."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.contract import R_COLUMNS
from aceval.evaluation.decision import CONE, MAX_CONE_DEG, decision_table, flag_disagreements

from .runner import REPO

KEY = {"subject": "S1", "sensor_set": "s", "imu": "A", "segment": "shank", "side": "right"}


def _row(method, heading_deg, cone=2.0, test="T6", flag="", error=np.nan, n_reps=3, reps=None):
    R = Rotation.from_euler("z", heading_deg, degrees=True).as_matrix()
    return {
        **KEY,
        "test": test,
        "repetitions": reps or "+".join(f"R{k}" for k in range(1, n_reps + 1)),
        "n_reps": n_reps,
        "method": method,
        **dict(zip(R_COLUMNS, R.ravel())),
        "flag": flag,
        CONE: cone,
        "error_deg": error,
        "error_vertical_share": 1.0,
    }


def test_two_methods_further_apart_than_their_cones_are_both_flagged_of_many_the_outlier():
    two = flag_disagreements(pd.DataFrame([_row("kong", 0), _row("triad", 5)]))
    assert two["flag"].tolist() == ["methods_disagree"] * 2  # 5 deg > hypot(2, 2) = 2.83
    assert two["methods_spread_deg"].round(6).tolist() == [5.0, 5.0]
    near = flag_disagreements(pd.DataFrame([_row("kong", 0), _row("triad", 2.8)]))
    assert near["flag"].tolist() == ["", ""]  # within hypot(2, 2)
    many = flag_disagreements(
        pd.DataFrame(
            [_row("kong", 0), _row("triad", 1), _row("combined", 0.5), _row("ricci_lm", 20)]
            + [_row("gaitmap_pca", 0.2, cone=np.nan)]  # a peer: allowed the widest cone (2)
            + [_row("kong", 40, n_reps=2, reps="R1+R2")]  # a subset: not compared
            + [_row("align_vectors", 30, flag="low_rho")]  # flagged: not compared
        )
    )
    assert [bool(f) for f in many["flag"]] == [False, False, False, True, False, False, True]
    assert many.loc[3, "flag"] == "methods_disagree"
    assert np.isnan(many.loc[5, "methods_spread_deg"])


def test_the_decision_takes_the_most_accurate_unflagged_calibration_and_says_what_it_rests_on():
    subject2 = {"subject": "S2"}
    rows = [
        _row("kong", 0, error=3.0),
        _row("triad", 0.5, error=1.0),  # triad's median error is the smallest on the shank
        _row("combined", 0.2, flag="weight_switch", error=0.1),  # flagged: never chosen
        {**_row("kong", 0, error=3.0), **subject2},
        {**_row("triad", 1, error=1.0, flag="backward"), **subject2},  # S2: triad flagged
    ]
    table = decision_table(flag_disagreements(pd.DataFrame(rows)), test_retest_k=2)
    assert table["method"].tolist() == ["triad", "kong"]
    assert table["basis"].tolist() == ["accuracy", "accuracy"]
    assert table["n_unflagged"].tolist() == [2, 1] and table["n_calibrations"].tolist() == [3, 2]
    assert table["verdict"].tolist() == ["use", "use"]
    assert "backward x1" in table.loc[1, "flags_elsewhere"]


def test_disagreeing_methods_make_use_with_care_and_nothing_unflagged_no_trustworthy_one():
    rows = [_row("kong", 0, error=1.0), _row("triad", 6, error=2.0), _row("combined", 0.5)]
    table = decision_table(flag_disagreements(pd.DataFrame(rows)))
    assert table.loc[0, "verdict"].startswith("use with care: methods disagree by up to 6.0 deg")
    assert table.loc[0, "disagreeing"] == "triad"  # kong and combined agree: the outlier
    flagged = [_row("kong", 0, flag="not_planar"), _row("triad", 0, cone=120.0)]
    table = decision_table(pd.DataFrame(flagged))
    assert table.loc[0, "verdict"].startswith("no trustworthy calibration: not_planar x1")
    assert table.loc[0, "n_unflagged"] == 0 and pd.isna(table.loc[0, "method"])


def test_without_a_truth_the_decision_rests_on_repeatability_and_says_so():
    rows = []
    for method, spread in (("kong", 3.0), ("triad", 0.5)):
        rows.append(_row(method, 0))
        for k, heading in enumerate((0, spread, -spread)):
            reps = ["R1+R2", "R1+R3", "R2+R3"][k]
            rows.append(_row(method, heading, n_reps=2, reps=reps))
    table = decision_table(pd.DataFrame(rows), test_retest_k=2)
    assert table.loc[0, "basis"] == "repeatability"
    assert table.loc[0, "method"] == "triad"


def _committed_datasets() -> list[str]:
    """Every dataset of the committed configurations (each has a results folder)."""
    import yaml

    return [
        name
        for config in ("config.yaml", "real.yaml")
        for name in yaml.safe_load((REPO / "config" / config).read_text())["run"]
    ]


@pytest.mark.parametrize("dataset", _committed_datasets())
def test_no_committed_decision_recommends_an_undetermined_or_silently_disputed_calibration(dataset):
    """Issue 39: every committed decision table chooses only calibrations with an uncertainty
    within 90 deg, says 'use with care' wherever another method of the same unit disagrees beyond
    the uncertainties, and 'no trustworthy calibration' exactly where it chooses none."""
    table = pd.read_csv(REPO / "results" / dataset / "tables" / "decision.csv")
    assert len(table), dataset
    chosen = table[table["method"].notna()]
    assert (chosen[CONE].fillna(0) <= MAX_CONE_DEG).all()
    disputed = chosen["disagreeing"].notna() & (chosen["disagreeing"].astype(str) != "")
    unmeasured = chosen[CONE].isna()
    assert chosen.loc[disputed | unmeasured, "verdict"].str.startswith("use with care").all()
    assert (chosen.loc[~disputed & ~unmeasured, "verdict"] == "use").all()
    assert table.loc[table["method"].isna(), "verdict"].str.startswith("no trustworthy").all()
    assert (table["n_unflagged"] <= table["n_calibrations"]).all()
