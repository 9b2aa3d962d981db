"""Ricci tables, the reliability of Kong's tests and the methods table on hand-made inputs."""

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from aceval.evaluation import conditioning, methods_comparison, truth_warnings
from aceval.report import methods_section, outputs, ricci2014, summary


def axes_table(rho: dict) -> pd.DataFrame:
    """rho[(test, segment, side)] = list of per-child values -> an axes table."""
    rows = []
    for (test, segment, side), values in rho.items():
        for k, value in enumerate(values):
            rows.append(
                {
                    "subject": f"C{k}",
                    "sensor_set": "main",
                    "imu": f"{segment}{side}",
                    "segment": segment,
                    "side": side,
                    "test": test,
                    "kind": "static" if test == "S" else "motion",
                    "rho": value,
                }
            )
    return pd.DataFrame(rows)


FEB = [0.70, 0.66, 0.72, 0.64, 0.69]
FE = [0.60, 0.61, 0.58, 0.62, 0.57]


def test_rho_table_mean_sd_n_and_the_published_cell():
    axes = axes_table({("FEB", "upper_arm", "right"): FEB, ("S", "thorax", "center"): [0.98, 0.99]})
    table = ricci2014.rho_table(axes, {"S": "TS/US/FS"}).set_index(["test", "segment"])
    cell = table.loc[("FEB", "upper_arm_r")]
    assert cell["mean"] == pytest.approx(np.mean(FEB)) and cell["sd"] == pytest.approx(
        np.std(FEB, ddof=1)
    )
    assert cell["n"] == 5 and cell["published_mean"] == 0.63
    assert table.loc[("TS/US/FS", "thorax"), "published_mean"] == 0.98
    assert (
        table.loc[("TFE", "thorax"), "n"] != table.loc[("TFE", "thorax"), "n"]
    )  # published only: NaN


def test_supported_ttest_is_scipy_paired_ttest_per_side():
    axes = axes_table(
        {
            ("FEB", "upper_arm", "right"): FEB,
            ("FE", "upper_arm", "right"): FE,
            ("FFEB", "forearm", "left"): FEB[:4],
            ("FE", "forearm", "left"): FE[:4],
        }
    )
    table = ricci2014.supported_ttest(axes).set_index("segment")
    expected = stats.ttest_rel(FEB, FE)
    row = table.loc["upper_arm_r"]
    assert (row["supported"], row["unsupported"], row["n"]) == ("FEB", "FE", 5)
    assert row["t"] == pytest.approx(expected.statistic) and row["p"] == pytest.approx(
        expected.pvalue
    )
    assert row["mean_difference"] == pytest.approx(np.mean(np.subtract(FEB, FE)))
    assert table.loc["forearm_l", "n"] == 4
    assert table.loc["forearm_l", "p_holm"] >= table.loc["forearm_l", "p"]
    assert row["published_mean_a"] == 0.63 and row["published_mean_b"] == 0.61


def test_lm_and_residual_tables():
    calibrations = pd.DataFrame(
        {
            "method": "ricci_lm",
            "segment": ["thorax", "thorax", "forearm"],
            "n_iterations": [4, 6, 7],
            "n_rejected": [0, 1, 2],
            "cost": [0.01, 0.02, 0.03],
            "optimum_distance_deg": [0.0, 0.001, 0.5],
            "fixed_n_iterations": [4, 5, 100],
            "fixed_cost": [0.01, 0.02, 0.05],
            "fixed_optimum_distance_deg": [0.0, 0.001, 3.0],
            "fixed_converged": [True, True, False],
            "converged": [True, True, False],
            "random_starts": 5,
            "random_starts_optimum": [5, 4, 5],
            "random_start_iterations_mean": [5.0, 6.0, 7.0],
            "random_start_iterations_max": [7, 9, 8],
        }
    )
    lm = ricci2014.lm_table(calibrations).set_index("segment")
    assert lm.loc["thorax", "mean"] == 5 and lm.loc["thorax", "published_mean"] == 6.34
    assert lm.loc["thorax", "random_starts_optimum_share"] == pytest.approx(0.9)
    assert lm.loc["forearm", "converged_share"] == 0
    assert lm.loc["thorax", "fixed_mean"] == 4.5 and lm.loc["forearm", "rejected_mean"] == 2
    assert lm.loc["forearm", "fixed_optimum_distance_deg_median"] == 3.0
    assert (
        lm.loc["forearm", "fixed_off_optimum_share"] == 1
        and lm.loc["thorax", "off_optimum_share"] == 0
    )
    assert lm.loc["forearm", "fixed_converged_share"] == 0
    axes = pd.DataFrame(
        {
            "subject": ["C1", "C2", "C1"],
            "segment": "thorax",
            "side": "center",
            "test": ["TR", "TR", "S"],
            "residual_before_deg": [80.0, 90.0, 10.0],
            "residual_after_deg": [5.0, 3.0, 1.0],
        }
    )
    residuals = ricci2014.residual_table(axes).set_index(["segment", "test"])
    assert (
        residuals.loc[("thorax", "TR"), "mean"] == 4
        and residuals.loc[("thorax", "TR"), "before_mean"] == 85
    )
    assert residuals.loc[("thorax", "TR"), "published_mean"] == 5.39
    # over the tests: one value per child (C1's two tests averaged), n counts children
    assert residuals.loc[("thorax", "all"), "n"] == 2
    assert residuals.loc[("thorax", "all"), "mean"] == 3


def test_a_perfectly_ranked_index_correlates_one_with_the_test_retest_angle():
    units = pd.DataFrame(
        {
            "test": ["T1"] * 4 + ["T6"] * 4,
            "segment": "chest",
            "rho": [0.9, 0.8, 0.7, 0.6, 0.5, 0.45, 0.4, 0.35],
            "planarity": [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08],
            "test_retest_deg": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8],
        }
    )
    table = conditioning.reliability_vs_retest(units).set_index(["index", "test"])
    assert table.loc[("rho_gyro", "all"), "spearman_r"] == pytest.approx(-1.0)
    assert table.loc[("planarity", "T1"), "spearman_r"] == pytest.approx(1.0)
    assert table.loc[("planarity", "all"), "n"] == 8
    layout = conditioning.kong_reliability_table(units).set_index(["index", "test", "segment"])
    assert layout.loc[("rho_gyro", "T1", "chest"), "mean"] == pytest.approx(0.75)


def test_methods_table_statistics_and_best_test():
    rng = np.random.default_rng(0)
    rows = []
    for method, test, error in [
        ("kong", "T3", 1.0),
        ("kong", "T6", 3.0),
        ("triad", "T3", 2.0),
        ("triad", "T6", 0.5),
    ]:
        for k, e in enumerate(error + rng.uniform(0, 0.1, 20)):
            rows.append(
                {
                    "subject": f"S{k}",
                    "sensor_set": "frontal",
                    "imu": "IMU2",
                    "segment": "chest",
                    "test": test,
                    "method": method,
                    "n_reps": 5,
                    "flag": "",
                    "error_deg": e,
                    "error_vertical_share": 0.5,
                }
            )
    rows.append(
        {**rows[0], "n_reps": 3, "error_deg": 99.0}
    )  # a subset: not the full-set calibration
    rows.append(
        {**rows[0], "subject": "S99", "flag": "not_planar", "error_deg": 99.0}
    )  # flagged: left out
    calibrations = pd.DataFrame(rows)
    table = methods_comparison.methods_table(calibrations).set_index(["test", "method"])
    kong_t3 = calibrations.query(
        "method == 'kong' and test == 'T3' and n_reps == 5 and flag == ''"
    )["error_deg"]
    assert table.loc[("T3", "kong"), "n"] == 20
    assert table.loc[("T3", "kong"), "median"] == pytest.approx(kong_t3.median())
    assert table.loc[("T3", "kong"), "p95"] == pytest.approx(np.percentile(kong_t3, 95))
    best = methods_comparison.best_tests(calibrations).set_index("method")
    assert best.loc["kong", "best_test"] == "T3" and best.loc["triad", "best_test"] == "T6"
    assert best.loc["kong", "kong_recommends"] == "T3"
    lines = methods_section.methods_section(
        {
            "methods": methods_comparison.methods_table(calibrations),
            "methods_best": methods_comparison.best_tests(calibrations),
        }
    )
    assert any("Kong recommends T3" in line and "agrees" in line for line in lines)


def test_a_flagged_calibration_from_all_repetitions_is_not_replaced_by_its_subsets():
    """When the calibration from all repetitions is flagged, the IMU drops out of the methods
    table's numbers: its unflagged subsets never stand in for it; the cell keeps its row with
    n = 0 of 1 and the flag (the price of the flags, issue 39)."""
    base = {"subject": "S1", "sensor_set": "a", "imu": "I", "segment": "shank", "test": "T6",
            "method": "kong", "error_vertical_share": 1.0}  # fmt: skip
    calibrations = pd.DataFrame(
        [{**base, "repetitions": "R1+R2+R3", "n_reps": 3, "flag": "not_planar", "error_deg": 30.0}]
        + [
            {**base, "repetitions": r, "n_reps": 2, "flag": "", "error_deg": 1.0}
            for r in ("R1+R2", "R1+R3", "R2+R3")
        ]  # fmt: skip
    )
    assert methods_comparison.full_set_errors(calibrations).empty
    table = methods_comparison.methods_table(calibrations)
    assert len(table) == 1 and table.loc[0, "n"] == 0 and table.loc[0, "n_calibrations"] == 1
    assert table.loc[0, "flags"] == "not_planar x1" and np.isnan(table.loc[0, "median"])


def _yaw(deg: float) -> list[float]:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return [c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0]


def test_every_methods_test_retest_and_the_peers_errors_and_reasons():
    """Each method's test-retest is the mean angle between its k-subset calibrations (here yaws
    of 0, 2 and 4 deg: pairs 2, 4, 2 -> 8/3 deg); a peer's calibration gets its error to the truth
    from aceval; a method that cannot calibrate at all stays in the table with its reason."""
    rows = []
    for method, yaws in (("kong", (0.0, 2.0, 4.0)), ("gaitmap_pca", (0.0, 1.0, 2.0))):
        rows.append({"repetitions": "R1+R2+R3+R4", "n_reps": 4, "yaw": 10.0, "method": method})
        for subset, yaw in zip(("R1+R2+R3", "R1+R2+R4", "R1+R3+R4"), yaws):
            rows.append({"repetitions": subset, "n_reps": 3, "yaw": yaw, "method": method})
    for subset in ("R1+R2+R3+R4", "R1+R2+R3"):
        rows.append({"repetitions": subset, "n_reps": len(subset.split("+")), "yaw": np.nan,
                     "method": "opensense_imuplacer", "flag": "not_applicable",
                     "note": "needs orientations"})  # fmt: skip
    calibrations = pd.DataFrame(
        [
            {
                "subject": "S1",
                "sensor_set": "a",
                "imu": "I",
                "segment": "thigh",
                "side": "right",
                "test": "T6",
                "flag": "",
                "note": "",
                **dict(
                    zip(
                        [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)],
                        _yaw(r["yaw"]) if np.isfinite(r["yaw"]) else [np.nan] * 9,
                    )
                ),
                **r,
            }
            for r in rows
        ]  # fmt: skip
    ).drop(columns="yaw")
    retest = methods_comparison.retest_table(calibrations, k=3).set_index("method")
    assert retest.loc["kong", "mean"] == pytest.approx(8 / 3)
    assert retest.loc["gaitmap_pca", "mean"] == pytest.approx(4 / 3)
    assert retest.loc["opensense_imuplacer", "n"] == 0
    assert retest.loc["opensense_imuplacer", "note"] == "needs orientations"
    truth = pd.DataFrame(
        [
            {
                "subject": "S1",
                "sensor_set": "a",
                "imu": "I",
                **dict(zip([f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)], _yaw(7.0))),
            }
        ]  # fmt: skip
    ).set_index(["subject", "sensor_set", "imu"])
    peers = methods_comparison.with_truth(calibrations[calibrations["method"] != "kong"], truth)
    full = peers[(peers["method"] == "gaitmap_pca") & (peers["n_reps"] == 4)]
    assert full["error_deg"].item() == pytest.approx(3.0)  # 10 deg vs 7 deg, about the vertical
    assert full["error_vertical_share"].item() == pytest.approx(1.0)
    assert peers.loc[peers["method"] == "opensense_imuplacer", "error_deg"].isna().all()


def test_registry_tables_render_and_unknown_names_are_refused():
    """A table is found in the registry by name (Kong's also by number), built from the tidy
    tables and rendered with its title; an unknown name is refused with the known ones."""
    axes = axes_table({("FEB", "upper_arm", "right"): FEB, ("FE", "upper_arm", "right"): FE})
    output = outputs.find("table", "ricci_ttest")
    table = output.build({"axes": axes, "paper_names": {}})
    text = output.markdown(table, output, "demo", True)
    assert "SIMULATED" in text and "FEB" in text and output.title in text
    assert outputs.find("table", "9") is outputs.find("table", "table9")
    with pytest.raises(ValueError, match="unknown table 'table99': one of table3"):
        outputs.find("table", "table99")


def test_every_output_has_a_builder_a_known_analysis_and_inputs():
    for output in outputs.OUTPUTS.values():
        assert output.analysis in outputs.ANALYSES and output.kind in ("table", "figure")
        assert output.build is not None and set(output.inputs) <= set(outputs.INPUT_KINDS)
        assert (output.markdown is not None) == (output.kind == "table")
    kong = [o.name for o in outputs.outputs_of(["kong"]) if o.kind == "table"]
    assert kong[:6] == ["table3", "table6", "table7", "table8", "table9", "table10"]


def test_conditioning_keeps_flagged_full_sets_and_says_when_the_heading_is_undetermined():
    base = {"subject": "S1", "sensor_set": "main", "segment": "thigh", "side": "right"}
    rows = [
        # one repetition (left out: not the full set), then all three: determined
        {**base, "imu": "a", "test": "T6", "n_reps": 1, "method": "kong", "normal_ratio": 0.9,
         "planarity": 0.02, "flag": ""},
        {**base, "imu": "a", "test": "T6", "n_reps": 3, "method": "kong", "normal_ratio": 0.3,
         "planarity": 0.02, "flag": ""},
        # a flagged full set stays, as undetermined; another method's row is not Kong's
        {**base, "imu": "b", "test": "T6", "n_reps": 3, "method": "kong", "normal_ratio": 0.7,
         "planarity": 0.06, "flag": "not_planar"},
        {**base, "imu": "b", "test": "T6", "n_reps": 3, "method": "triad", "normal_ratio": np.nan,
         "planarity": np.nan, "flag": ""},
    ]  # fmt: skip
    table = conditioning.conditioning_table(pd.DataFrame(rows))
    assert list(table["imu"]) == ["a", "b"] and list(table["n_reps"]) == [3, 3]
    assert list(table["heading"]) == ["determined", "undetermined"]
    assert list(table["flag"]) == ["", "not_planar"]
    lines = summary.conditioning_section({"conditioning": table})
    assert "| T6     | thigh     |   2 |                      1 |" in "\n".join(lines)


def test_truth_errors_measure_against_both_truths_and_carry_the_truths_flag():
    from scipy.spatial.transform import Rotation

    from aceval.data.contract import R_COLUMNS

    estimate = Rotation.from_euler("z", 10, degrees=True).as_matrix().ravel()
    marker_frame = Rotation.from_euler("z", 25, degrees=True).as_matrix().ravel()
    key = {"subject": "S1", "sensor_set": "main", "imu": "shank_r"}
    calibrations = pd.DataFrame(
        [
            {**key, "segment": "shank", "side": "right", "test": "T6", "n_reps": n,
             "method": "kong", "error_deg": 10.0 + n, "normal_ratio": 0.2, "planarity": 0.03,
             "flag": "", **dict(zip(R_COLUMNS, estimate))}
            for n in (1, 3)
        ]
    )  # fmt: skip
    sheet = pd.DataFrame(
        [
            {**key, "truth_uncertainty_deg": 7.0, "flag": "methods_differ;truth_unstable",
             "long_axis_check_deg": 0.5, "marker_frame_long_axis_check_deg": 4.0,
             "marker_frame_split_half_deg": 1.0, "methods_differ_deg": 25.0,
             "twist_mean_deg": 8.0, "lever_arm_m": 0.09, "pair_heading_deg": 6.0,
             **{f"marker_frame_{c}": v for c, v in zip(R_COLUMNS, marker_frame)}}
        ]
    )  # fmt: skip
    table = methods_comparison.truth_errors(calibrations, sheet)
    assert len(table) == 1  # the calibration of all repetitions only
    row = table.iloc[0]
    assert row["error_deg"] == 13.0 and row["error_marker_frame_deg"] == pytest.approx(15.0)
    assert row["truth_flag"] == "methods_differ;truth_unstable" and row["heading"] == "determined"
    text = "\n".join(summary.truth_section({"truth_errors": table}))
    assert (
        "13.0 deg (truth +- 7.0, long-axis check 0.5)" in text
        and "(its long-axis check 4.0)" in text
        and "truth flagged methods_differ;truth_unstable" in text
    )
    # issue 28: a marker-frame truth whose own vertical check fails is not used
    failing = methods_comparison.truth_errors(
        calibrations, sheet.assign(marker_frame_vertical_check_deg=12.0)
    ).iloc[0]
    assert np.isnan(failing["error_marker_frame_deg"]) and failing["error_deg"] == 13.0
    text = "\n".join(summary.truth_section({"truth_errors": pd.DataFrame([failing])}))
    assert "the marker-frame truth not used (its vertical check 12.0 deg > 5)" in text
    # issue 39: nor one whose long-axis check fails (NeuRA's left thigh asks for 14.4 deg)
    twisted = methods_comparison.truth_errors(
        calibrations, sheet.assign(marker_frame_long_axis_check_deg=14.0)
    ).iloc[0]
    assert np.isnan(twisted["error_marker_frame_deg"]) and twisted["error_deg"] == 13.0
    text = "\n".join(summary.truth_section({"truth_errors": pd.DataFrame([twisted])}))
    assert "the marker-frame truth not used (its long-axis check 14.0 deg > 5)" in text


def test_loose_reference_angles_between_right_axes_and_verticals():
    from scipy.spatial.transform import Rotation

    from aceval.data.contract import R_COLUMNS

    key = {"subject": "S1", "sensor_set": "main", "imu": "thigh_r"}
    # Kong's R maps sensor to body: turned 30 deg about the vertical from the identity
    turned = Rotation.from_euler("z", 30, degrees=True).as_matrix().ravel()
    calibrations = pd.DataFrame(
        [{**key, "segment": "thigh", "side": "right", "test": "T6", "n_reps": 3, "method": "kong",
          "flag": np.nan, **dict(zip(R_COLUMNS, turned))}]
    )  # fmt: skip
    # the reference: the sensor's y is the segment's right, the sensor's -z its up
    reference = pd.DataFrame(
        [{**key, "right_x": 0.0, "right_y": 1.0, "right_z": 0.0, "up_x": 0.0, "up_y": 0.0,
          "up_z": -1.0, "standing_up_angle_deg": 3.0}]
    )  # fmt: skip
    row = methods_comparison.loose_reference_angles(calibrations, reference).iloc[0]
    assert row["right_axis_angle_deg"] == pytest.approx(30.0)
    assert row["vertical_angle_deg"] == pytest.approx(0.0, abs=1e-6) and row["flag"] == ""
    text = "\n".join(summary.loose_reference_section({"loose_reference": pd.DataFrame([row])}))
    assert "NOT a ground truth" in text and "kong: median 30.0 deg over 1 calibrations" in text


def _subset_calibrations(rng, subjects=("S1", "S2", "S10"), methods=("kong", "triad", "qmt_hinge")):
    """Every subset of 5 repetitions for each subject, set, IMU, test and method: random
    rotations within about 10 deg of the truth (identity), some flagged, errors from them."""
    from scipy.spatial.transform import Rotation

    from aceval.calibrate.table import all_subsets, subset_label

    rows = []
    for subject, sensor_set, imu, test, method in itertools.product(
        subjects, ("front", "side"), ("I1", "I2"), ("T1", "T6"), methods
    ):
        for subset in all_subsets([1, 2, 3, 4, 5]):
            R = Rotation.from_rotvec(rng.normal(scale=0.1, size=3)).as_matrix()
            rows.append({
                "subject": subject, "sensor_set": sensor_set, "imu": imu, "segment": "thigh",
                "side": imu, "test": test, "repetitions": subset_label(subset),
                "n_reps": len(subset), "method": method,
                **dict(zip([f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)], R.ravel())),
                "flag": "" if rng.random() > 0.1 else "gyro_disagrees",
                "error_deg": np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))),
                "error_vertical_share": rng.random(),
            })  # fmt: skip
    return pd.DataFrame(rows)


def test_per_subject_angles_and_retest_units_give_the_tables_of_all_subjects_at_once(rng):
    """The workflow computes Kong's angles and every method's test-retest units per subject
    (calibrate --angles-out/--retest-out) and the results jobs hold only the calibrations from
    all repetitions: the angles, in all_angles' order, must be exactly those computed from every
    calibration at once (subject S10 sorts before S2), and the methods tables equal to the last
    bits (pandas' grouped mean of one unit can move by 1e-15 with the other units in the frame;
    the committed results are byte-identical)."""
    from aceval.calibrate.table import full_set_rows
    from aceval.evaluation.objectives import all_angles, in_angle_order

    calibrations = _subset_calibrations(rng)
    aceval_rows = calibrations[calibrations["method"] != "qmt_hinge"]
    peers = calibrations[calibrations["method"] == "qmt_hinge"]
    per_subject = [aceval_rows[aceval_rows["subject"] == s] for s in ("S1", "S2", "S10")]
    angles = in_angle_order(pd.concat([all_angles(p) for p in per_subject], ignore_index=True))
    pd.testing.assert_frame_equal(angles, all_angles(calibrations), check_exact=True)

    units = pd.concat(
        [methods_comparison.retest_units(p, 3) for p in per_subject], ignore_index=True
    )
    held = pd.concat([full_set_rows(aceval_rows), peers], ignore_index=True)
    every = pd.concat([aceval_rows, peers], ignore_index=True)  # as build_data joins the peers
    assert len(full_set_rows(aceval_rows)) == len(aceval_rows) // 31  # one of 31 subsets
    for build in (methods_comparison.retest_table, methods_comparison.methods_table):
        pd.testing.assert_frame_equal(
            build(held, 3, units).reset_index(drop=True),
            build(every, 3).reset_index(drop=True),
            rtol=1e-13,
        )
    assert set(methods_comparison.retest_table(held, 3, units)["method"]) == {
        "kong", "triad", "qmt_hinge"
    }  # fmt: skip


def test_truth_warning_reads_the_calibrations_from_all_repetitions(rng):
    """A transposed truth is named from the calibrations every method is judged on (all
    repetitions), whatever their subsets say; a truth near every calibration is not."""
    calibrations = _subset_calibrations(rng, subjects=("S1",))
    assert truth_warnings.truth_warning(calibrations) == ""
    full = calibrations["n_reps"] == 5
    far = calibrations.assign(error_deg=np.where(full, 150.0, 1.0))
    assert "transposed" in truth_warnings.truth_warning(far)
    near = calibrations.assign(error_deg=np.where(full, 1.0, 150.0))
    assert truth_warnings.truth_warning(near) == ""
