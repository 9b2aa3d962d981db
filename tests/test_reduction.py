"""The one pass over the recordings (aceval.signals.reduction) and the correlations from its moments."""

import pandas as pd
import pytest

from aceval.calibrate.pipeline import calibrate
from aceval.data.dataset import load_dataset
from aceval.evaluation.correlations import correlations
from aceval.signals.reduction import reduce_recordings
from aceval.simulate import SimOptions, simulate_box


@pytest.fixture(scope="module")
def boxes(clean):
    """Two simulated rigid boxes (two sensor sets each: Obj 1 pairs), two repetitions."""
    options = SimOptions(repetitions=2)
    return load_dataset(
        clean.shared("boxes", lambda at: simulate_box(at, 5, n_subjects=2, options=options))
    )


@pytest.fixture(scope="module")
def reduced(boxes):
    return {s: reduce_recordings(boxes, s) for s in ("BOX1", "BOX2")}


def _correlations(dataset, reductions):
    reduced = list(reductions)
    summaries = pd.concat([r.summaries for r in reduced], ignore_index=True)
    pairs = pd.concat([r.pairs for r in reduced], ignore_index=True)
    calibrations, _ = calibrate(dataset, summaries, subsets="full")  # Obj 1-2 use the full set
    return correlations(dataset, calibrations, pairs)


@pytest.mark.slow  # every calibration of two subjects, three times
def test_several_subjects_in_one_call_are_each_subjects_own_pairs(boxes, reduced):
    """A job of several subjects correlates each subject's recordings with its own calibrations:
    the same table as one call per subject (a pair is never looked up across subjects)."""
    together = _correlations(boxes, reduced.values())
    apart = pd.concat(
        [_correlations(boxes, [reduced["BOX1"]]), _correlations(boxes, [reduced["BOX2"]])],
        ignore_index=True,
    )
    key = [
        "objective",
        "subject",
        "imu",
        "t_ex",
        "t_ap",
        "rep",
        "signal",
        "mode",
        "heading_error_deg",
    ]
    together = together.sort_values(key).reset_index(drop=True)
    apart = apart.sort_values(key).reset_index(drop=True)
    assert len(together) > 100 and set(together["subject"]) == {"BOX1", "BOX2"}
    pd.testing.assert_frame_equal(together, apart)
    # the two boxes move differently: their correlations are not copies of each other
    first = together[together["subject"] == "BOX1"]["correlation"].to_numpy()
    second = together[together["subject"] == "BOX2"]["correlation"].to_numpy()
    assert len(first) == len(second) and (first != second).any()


def test_each_recording_is_read_once_and_every_pair_of_the_two_sets_is_reduced(boxes, reduced):
    reduced = reduced["BOX1"]
    motion = boxes.recordings.query("subject == 'BOX1' and test != 'T0'")
    per_set = motion.groupby("sensor_set").size()
    # one Obj 1 pair per recording of the first set, for acc and gyr, over all and moving samples
    assert len(reduced.pairs) == per_set.iloc[0] * 2 * 2
    assert (reduced.pairs["lag_samples"].abs() <= 50).all() and reduced.report.ok
    # the sensitivity rows are one per unit (mean over repetitions), not one per repetition
    table = _correlations(boxes, [reduced])
    sensitivity = table[table["objective"] == "frontal_lateral_sensitivity"]
    assert sensitivity["rep"].isna().all()
    assert not sensitivity.duplicated(["imu", "t_ex", "t_ap", "mode", "heading_error_deg"]).any()
