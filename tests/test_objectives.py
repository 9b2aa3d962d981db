"""Kong Objectives 1-5 on hand-made cases with known answers."""

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.calibrate import table as calibrations_table
from aceval.calibrate.table import all_subsets, subset_label
from aceval.data.contract import R_COLUMNS
from aceval.evaluation import objectives
from aceval.signals import alignment


def calibration_table(
    rotation_of, reps=(1, 2, 3, 4, 5), tests=("T1",), sets=("frontal",), imus=("IMU1",)
):
    """A calibration table with every subset of ``reps``; ``rotation_of(test, subset)`` gives R."""
    rows = []
    for sensor_set, imu, test in itertools.product(sets, imus, tests):
        for subset in all_subsets(list(reps)):
            R = rotation_of(test, subset)
            rows.append(
                {
                    "subject": "S1",
                    "sensor_set": sensor_set,
                    "imu": imu,
                    "segment": "head",
                    "side": "center",
                    "test": test,
                    "repetitions": subset_label(subset),
                    "n_reps": len(subset),
                    **dict(zip(R_COLUMNS, np.asarray(R).ravel())),
                    "flag": "",
                }
            )
    return pd.DataFrame(rows)


def yaw(deg):
    return Rotation.from_euler("z", deg, degrees=True).as_matrix()


# --- correlation -------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", objectives.CORRELATION_MODES)
def test_identical_signals_correlate_perfectly_and_opposite_ones_negatively(mode, rng):
    signal = rng.normal(size=(200, 3))
    moving = np.arange(200) % 3 > 0
    assert objectives.correlation_3d(signal, signal, mode, moving) == pytest.approx(1.0)
    assert objectives.correlation_3d(signal, 2 * signal + 0.5, mode, moving) == pytest.approx(1.0)
    assert objectives.correlation_3d(signal, -signal, mode, moving) == pytest.approx(-1.0)


def test_moving_correlation_ignores_rest_and_sees_a_heading_error(rng):
    """Rest at a shared gravity level inflates the concatenated correlation; over the moving samples
    a 15 deg heading error lowers the per-axis correlation far more than the concatenated one."""
    t = np.linspace(0, 8, 800)
    motion = np.column_stack([3 * np.sin(2 * t), 0.6 * np.sin(3 * t + 1), 2 * np.cos(2 * t)])
    rest = np.zeros((800, 3))
    moving = np.r_[np.zeros(800, bool), np.ones(800, bool)]
    a = np.vstack([rest, motion]) + [0.0, 0.0, -9.81] + rng.normal(0, 0.05, (1600, 3))
    b = a + rng.normal(0, 0.05, a.shape)
    turned = b @ yaw(15).T
    drop = {m: objectives.correlation_3d(a, b, m, moving) - objectives.correlation_3d(a, turned, m, moving)
            for m in objectives.CORRELATION_MODES}  # fmt: skip
    assert drop["per_axis_moving"] > 5 * drop["concatenated"] > 0
    with pytest.raises(ValueError, match="moving"):
        objectives.correlation_3d(a, b, "per_axis_moving")


@pytest.mark.parametrize("shift", [-7, 0, 12])
def test_best_lag_recovers_a_known_shift(shift, rng):
    """Two sensors sampled with a known offset: the cross-correlation of the acceleration
    magnitudes finds it, and the aligned overlap pairs the same instants."""
    n = 600
    truth = np.column_stack(
        [np.sin(np.linspace(0, 20, n + 40)) * k for k in (1.0, 2.0, 0.5)]
    ) + rng.normal(0, 0.05, (n + 40, 3))
    a = truth[20 + shift : 20 + shift + n]  # a[t] = truth[t + 20 + shift]
    b = truth[20 : 20 + n] + rng.normal(0, 0.05, (n, 3))  # b[t] = truth[t + 20]
    lag = alignment.best_lag(a, b, max_lag=25)
    assert lag == -shift  # a[t + lag] = truth[t + 20] = b[t]
    part_a, part_b = alignment.aligned(len(a), len(b), lag)
    assert np.allclose(a[part_a], truth[20 : 20 + n][part_b])
    assert alignment.best_lag(a, b, max_lag=0) == 0  # the window limits the search


@pytest.mark.parametrize("mode", objectives.CORRELATION_MODES)
def test_correlation_from_moments_equals_the_samples_for_any_calibration(mode, rng):
    """The one-pass moments of a recording pair give the correlation of the pair calibrated by
    any rotations: the same number as correlating the rotated samples, for every mode."""
    from aceval.signals.reduction import moments

    t = np.linspace(0, 6, 600)
    a = np.column_stack([np.sin(2 * t), 0.3 * np.cos(3 * t), 0.1 * t]) + [0.5, 0.0, -9.81]
    b = a @ Rotation.random(random_state=1).as_matrix().T + rng.normal(0, 0.05, a.shape)
    moving = (t > 1) & (t < 5)
    window = moving if mode == "per_axis_moving" else slice(None)
    pairs = pd.DataFrame([moments(a[window], b[window])] * 4)
    R_a = Rotation.random(4, random_state=2).as_matrix()
    R_b = Rotation.random(4, random_state=3).as_matrix()
    expected = [
        objectives.correlation_3d(a @ Ra.T, b @ Rb.T, mode, moving) for Ra, Rb in zip(R_a, R_b)
    ]
    got = objectives.correlation_from_moments(pairs, R_a, R_b, mode)
    assert got == pytest.approx(expected, abs=1e-12)


def test_correlation_from_moments_leaves_out_what_does_not_vary():
    """An axis constant in the calibrated signal has no correlation (per_axis leaves it out), and a
    pair without samples has none at all, as for the samples themselves."""
    from aceval.signals.reduction import moments

    rng = np.random.default_rng(0)
    a = np.column_stack([rng.normal(size=50), rng.normal(size=50), np.full(50, 9.81)])
    b = a + rng.normal(0, 0.1, a.shape) * [1, 1, 0]
    pairs = pd.DataFrame([moments(a, b), {"n": 0}])
    identity = np.stack([np.eye(3)] * 2)
    got = objectives.correlation_from_moments(pairs, identity, identity, "per_axis")
    assert got[0] == pytest.approx(objectives.correlation_3d(a, b, "per_axis"), abs=1e-12)
    assert np.isnan(got[1])


def test_best_lag_is_the_argmax_of_the_full_cross_correlation(rng):
    """Only the lags in the window are computed: the same lag as the full cross-correlation
    (numpy's) restricted to that window."""
    a, b = rng.normal(size=(300, 3)), rng.normal(size=(280, 3))
    x = np.linalg.norm(a, axis=1) - np.linalg.norm(a, axis=1).mean()
    y = np.linalg.norm(b, axis=1) - np.linalg.norm(b, axis=1).mean()
    full = np.correlate(x, y, mode="full")
    lags = np.arange(-(len(y) - 1), len(x))
    for window in (0, 5, 40, 400):
        inside = np.abs(lags) <= window
        assert alignment.best_lag(a, b, window) == lags[inside][np.argmax(full[inside])]


def test_concatenated_correlation_counts_axis_levels_per_axis_does_not(rng):
    """Two static sensors with independent noise around gravity: the concatenated signal is
    dominated by the shared axis levels (r ~ 1), the per-axis correlations by the noise (r ~ 0)."""
    gravity = np.array([0.0, 0.0, -9.81])
    a = gravity + rng.normal(0, 0.02, (500, 3))
    b = gravity + rng.normal(0, 0.02, (500, 3))
    assert objectives.correlation_3d(a, b, "concatenated") > 0.999
    assert abs(objectives.correlation_3d(a, b, "per_axis")) < 0.2


def test_per_axis_correlation_leaves_out_constant_axes(rng):
    a = rng.normal(size=(100, 3))
    b = a.copy()
    b[:, 1] = 0.0  # constant: no correlation defined on y
    assert objectives.correlation_3d(a, b, "per_axis") == pytest.approx(1.0)
    assert np.isnan(objectives.correlation_3d(np.zeros((10, 3)), np.zeros((10, 3)), "per_axis"))


def test_correlation_rejects_mismatched_shapes_and_unknown_modes():
    with pytest.raises(ValueError, match="same shape"):
        objectives.correlation_3d(np.zeros((5, 3)), np.zeros((6, 3)))
    with pytest.raises(ValueError, match="not one of"):
        objectives.correlation_3d(np.ones((5, 3)), np.ones((5, 3)), "spearman")


# --- error angles (Obj 3-5) --------------------------------------------------------------------


def test_identical_calibrations_give_zero_angles_and_the_expected_number_of_comparisons():
    base = Rotation.random(random_state=2).as_matrix()
    table = calibration_table(lambda test, subset: base, tests=("T1", "T2", "T3"))
    angles = objectives.all_angles(table, test_retest_k=3)
    np.testing.assert_allclose(angles["error_angle_deg"], 0.0, atol=1e-6)
    counts = angles.groupby(["comparison", "test"]).size()
    # per test: sum_{k=1..4} C(5,k) (5-k) = 75 incremental, 30 to-last, C(10,2) = 45 test-retest
    assert (counts.loc["incremental"] == 75).all()
    assert (counts.loc["to_last"] == 30).all()
    assert (counts.loc["test_retest"] == 45).all()
    assert set(counts.loc["cross_test"].index) == {"T1-T2", "T1-T3", "T2-T3"}


def test_a_known_yaw_per_repetition_comes_back_as_the_angle():
    """R(subset) = yaw(sum of the subset's repetition numbers) R0: adding repetition a turns the
    calibration by a degrees, the full set differs from {R1} by 14 degrees."""
    base = Rotation.random(random_state=5).as_matrix()
    table = calibration_table(lambda test, subset: yaw(sum(subset)) @ base)
    incremental = objectives.incremental_angles(table)
    # calibration_a is the bigger subset (R_e = R(A u {a}) R(A)^-1, Eq. 11), so the angle is a
    expected = [
        sum(calibrations_table.parse_subset(a.split(":")[1]))
        - sum(calibrations_table.parse_subset(b.split(":")[1]))
        for a, b in zip(incremental["calibration_a"], incremental["calibration_b"])
    ]
    np.testing.assert_allclose(incremental["error_angle_deg"], expected, atol=1e-6)
    to_last = objectives.to_last_angles(table).set_index("calibration_b")["error_angle_deg"]
    assert to_last["T1:R1"] == pytest.approx(14.0)
    assert to_last["T1:R1+R2+R3+R4"] == pytest.approx(5.0)
    # the error rotation is about the body vertical, as Kong notes for a shared z0
    np.testing.assert_allclose(objectives.incremental_angles(table)["vertical_share"], 1.0)


def test_cross_test_angle_is_the_yaw_between_the_tests():
    base = Rotation.random(random_state=9).as_matrix()
    offsets = {"T3": 0.0, "T5": 7.5, "T6": -2.0}
    table = calibration_table(lambda test, subset: yaw(offsets[test]) @ base, tests=tuple(offsets))
    cross = objectives.cross_test_angles(table).set_index("test")["error_angle_deg"]
    assert cross["T3-T5"] == pytest.approx(7.5)
    assert cross["T3-T6"] == pytest.approx(2.0)
    assert cross["T5-T6"] == pytest.approx(9.5)


def test_flagged_calibrations_are_left_out():
    base = np.eye(3)
    table = calibration_table(lambda test, subset: base)
    table.loc[table["repetitions"] == "R1+R2+R3+R4+R5", "flag"] = "not_planar"
    assert objectives.to_last_angles(table).empty  # nothing to converge to
    assert calibrations_table.full_sets(table).empty
    assert not (objectives.incremental_angles(table)["calibration_a"] == "T1:R1+R2+R3+R4+R5").any()


def test_test_retest_pairs_are_the_distinct_k_subsets():
    table = calibration_table(lambda test, subset: np.eye(3), reps=(1, 2, 3, 4))
    pairs = objectives.test_retest_angles(table, k=3)
    assert len(pairs) == 6  # C(C(4,3), 2)
    assert (pairs["calibration_a"] != pairs["calibration_b"]).all()


# --- Obj 1/2 planning --------------------------------------------------------------------------


def test_frontal_lateral_plan_pairs_the_same_imu_across_sets_and_skips_single_sets():
    table = calibration_table(
        lambda test, subset: np.eye(3), sets=("frontal", "lateral"), imus=("IMU1", "IMU2")
    )
    table = table[~((table["sensor_set"] == "lateral") & (table["imu"] == "IMU2"))]
    plan = objectives.frontal_lateral_plan(
        calibrations_table.full_sets(table), ["frontal", "lateral"]
    )
    assert list(plan["imu"]) == ["IMU1"]


def test_segment_pair_plan_needs_a_common_calibrating_test():
    head = calibration_table(lambda t, s: np.eye(3), tests=("T1", "T2"), imus=("IMU1",))
    chest = calibration_table(lambda t, s: yaw(3), tests=("T2", "T3"), imus=("IMU2",)).assign(
        segment="chest"
    )
    plan = objectives.segment_pair_plan(
        calibrations_table.full_sets(pd.concat([head, chest])),
        {"head-chest": {"segments": ["head", "chest"], "t_ap": ["T1"]}},
    )
    assert list(plan["t_ex"]) == ["T2"]
    assert (plan["imu_a"] == "IMU1").all() and (plan["imu_b"] == "IMU2").all()


def test_empty_inputs_give_empty_tables_not_errors():
    assert objectives.all_angles(pd.DataFrame()).empty
    assert list(objectives.all_angles(pd.DataFrame()).columns) == objectives.ANGLE_COLUMNS


def test_unflagged_reads_an_empty_flag_however_the_csv_reader_typed_the_column(tmp_path):
    """A flag column with no flag at all is read back as numbers (NaN), one with flags as strings
    (an empty flag NaN); written by hand, an empty flag is ''. Each way, the rows without a flag
    are the unflagged ones."""
    from aceval.report.results import read_tables

    (tmp_path / "a.csv").write_text("x,flag\n1,\n2,\n")
    (tmp_path / "b.csv").write_text("x,flag\n3,low_rho\n4,\n")
    no_flags = read_tables([tmp_path / "a.csv"])
    assert pd.api.types.is_numeric_dtype(no_flags["flag"])
    assert calibrations_table.unflagged(no_flags).tolist() == [True, True]
    joined = read_tables([tmp_path / "a.csv", tmp_path / "b.csv"])
    assert calibrations_table.unflagged(joined).tolist() == [True, True, False, True]
    by_hand = pd.DataFrame({"flag": ["", "no_overlap", np.nan]})
    assert calibrations_table.unflagged(by_hand).tolist() == [True, False, True]


def test_one_offset_per_repetition_is_pooled_over_the_pairs():
    """Two sets on two clocks: the pooled offset is the true one even where one pair alone would
    pick another (a pair whose magnitudes carry little but noise)."""
    rng = np.random.default_rng(1)
    pairs = []
    for k in range(4):
        signal = rng.normal(0, 1, (400, 3)) + np.sin(np.arange(400) / (7 + k))[:, None]
        pairs.append((signal[9:], signal[:-9] + 0.05 * rng.normal(0, 1, (391, 3))))
    flat = rng.normal(0, 1, (391, 3))
    pairs.append((flat, rng.normal(0, 1, (391, 3))))  # noise: its own best lag is anywhere
    assert alignment.pooled_lag(pairs, max_lag=25) == -9
    assert alignment.best_lag(*pairs[-1], max_lag=25) != -9


@pytest.mark.slow
def test_the_pass_aligns_the_two_sets_by_one_offset_and_none_inside_a_set(tmp_path):
    """Simulated sets share one time base: each repetition gets one offset for all its
    frontal-lateral pairs, near 0 (the two sets sit at different points of the segment and wobble
    apart, so their magnitudes differ: here 5, -1, 0, 0 samples), and Obj 2's pairs (inside one
    set) are never shifted; the lateral set's recordings delayed by 7 samples move the offset by
    -7 (within a sample)."""
    from aceval.cli import main
    from aceval.data.dataset import load_dataset
    from aceval.signals.reduction import reduce_recordings

    lab = tmp_path / "lab"
    assert main(["simulate", "kong", "--out", str(lab), "--subjects", "1", "--repetitions", "2",
                 "--seed", "2", "--format", "csv"]) == 0  # fmt: skip
    pairs = reduce_recordings(load_dataset(lab), tests=["T1", "T5"]).pairs
    assert (pairs["flag"] == "").all()
    per_rep = pairs.groupby(["objective", "test", "rep"])["lag_samples"]
    assert (per_rep.nunique() == 1).all() and (pairs["lag_samples"].abs() <= 10).all()
    before = per_rep.first()["frontal_lateral"]["T5"]
    sheet = pd.read_csv(lab / "recordings.tsv", sep="\t")
    for path in sheet[(sheet["sensor_set"] == "lateral") & (sheet["test"] == "T5")]["path"]:
        table = pd.read_csv(lab / path)
        values = table.columns.drop("t")
        table[values] = np.vstack([np.repeat(table[values].to_numpy()[:1], 7, 0),
                                   table[values].to_numpy()[:-7]])  # fmt: skip
        table.to_csv(lab / path, index=False)
    pairs = reduce_recordings(load_dataset(lab), tests=["T5"]).pairs
    frontal_lateral = pairs[pairs["objective"] == "frontal_lateral"]
    after = frontal_lateral.groupby("rep")["lag_samples"]
    assert (after.nunique() == 1).all()
    assert all(abs(after.first()[rep] - (lag - 7)) <= 1 for rep, lag in before.items())
    assert (pairs.loc[pairs["objective"] != "frontal_lateral", "lag_samples"] == 0).all()
