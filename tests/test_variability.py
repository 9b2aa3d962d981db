"""The variability statistics measured alike on real and simulated data (issue 30), and the
simulator kept inside the real ranges it was set from."""

import pandas as pd
import pytest

from aceval.evaluation.variability import real_vs_simulated, variability_table

from .runner import REPO

#: the simulator's parameters set from real recordings: (statistic, test, segment) and the real
#: dataset each was set from (docs/simulation.md, "Parameters and sources")
SET_FROM = {("repetition_heading_deg", "T6", "shank"): "hugadb"}


def test_statistics_are_medians_over_a_subjects_units():
    """Two subjects; S1's two thighs turned 1 and 3 deg per repetition on average (its median 2),
    S2's one thigh 5 deg: per subject, not pooled."""
    angles = pd.DataFrame(
        [
            {"comparison": "to_last", "k": 1, "test": "T6", "segment": "thigh", "subject": s,
             "sensor_set": "a", "imu": imu, "error_angle_deg": value}
            for s, imu, values in (("S1", "L", [0.5, 1.5]), ("S1", "R", [3.0]), ("S2", "L", [5.0]))
            for value in values
        ]
    )  # fmt: skip
    table = variability_table(None, angles, None).set_index("subject")
    assert table.loc["S1", "value"] == pytest.approx(2.0) and table.loc["S1", "n_units"] == 2
    assert table.loc["S2", "value"] == pytest.approx(5.0)
    side_by_side = real_vs_simulated(
        {"hugadb": variability_table(None, angles, None), "kong_sim": table.reset_index()}
    )
    assert set(side_by_side["kind"]) == {"real", "simulated"}


def test_the_simulation_stays_inside_the_real_ranges_it_was_set_from():
    """The committed results: every statistic a simulator parameter was set from lies, on
    kong_sim, within the range over the real dataset's subjects (results/variability/)."""
    table = pd.read_csv(REPO / "results" / "variability" / "real_vs_simulated.csv")
    table = table.set_index(["statistic", "test", "segment", "dataset"])
    for (statistic, test, segment), real in SET_FROM.items():
        simulated = table.loc[(statistic, test, segment, "kong_sim"), "median"]
        low, high = table.loc[(statistic, test, segment, real), ["min", "max"]]
        assert low <= simulated <= high, (statistic, test, segment, simulated, (low, high))


def test_the_side_by_side_table_is_what_the_committed_datasets_say():
    """results/variability/ is regenerated from the committed per-dataset tables."""
    from aceval.evaluation.variability import REAL, SIMULATED

    tables = {
        name: pd.read_csv(REPO / "results" / name / "tables" / "variability.csv")
        for name in (*REAL, *SIMULATED)
    }
    committed = pd.read_csv(REPO / "results" / "variability" / "real_vs_simulated.csv")
    rebuilt = real_vs_simulated(tables).reset_index(drop=True)
    pd.testing.assert_frame_equal(
        rebuilt, committed, check_dtype=False, check_exact=False, atol=2e-4
    )
