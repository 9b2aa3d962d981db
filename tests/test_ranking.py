"""Issue 42: the methods ranked against a ground truth with intervals over the subjects, not over
legs or calibrations."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from aceval.evaluation.ranking import methods_ranking


def _calibrations(errors: dict) -> pd.DataFrame:
    """errors[(method, subject, imu, test)] = error to the truth (deg), one full set each."""
    return pd.DataFrame([
        {"method": method, "subject": subject, "sensor_set": "frontal", "imu": imu,
         "segment": "thigh", "test": test, "n_reps": 5, "flag": "", "error_deg": error}
        for (method, subject, imu, test), error in errors.items()
    ])  # fmt: skip


def test_methods_are_ranked_over_subjects_not_legs():
    """Two methods, four subjects with two thighs each: each subject's legs are averaged into
    one value, the intervals are scipy's over the 4 subjects, the difference to the first is
    paired by subject; a static-pose method with cells of its own is not ranked with them."""
    rng = np.random.default_rng(0)
    errors = {}
    for s in range(4):
        for imu in ("thigh_l", "thigh_r"):
            errors[("kong", f"S{s}", imu, "T6")] = 2.0 + s * 0.3 + rng.normal(0, 0.1)
            errors[("triad", f"S{s}", imu, "T6")] = 3.0 + s * 0.3 + rng.normal(0, 0.1)
            errors[("static", f"S{s}", imu, "T0")] = 0.5
    ranking = methods_ranking(_calibrations(errors)).set_index("method")
    assert list(ranking.index) == ["kong", "triad"] and (ranking["n_subjects"] == 4).all()
    table = _calibrations(errors)
    means = table[table["method"] == "triad"].groupby("subject")["error_deg"].mean()
    low, high = stats.t.interval(0.95, 3, means.mean(), stats.sem(means))
    assert (ranking.loc["triad", "low"], ranking.loc["triad", "high"]) == pytest.approx((low, high))
    assert ranking.loc["triad", "difference_low"] > 0.5 and ranking.loc["kong", "cells"] == 1
