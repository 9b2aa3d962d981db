"""Axis moments, first-phase signs, the axis methods (Ricci LM, align_vectors, TRIAD) and Ricci's
functional design, each on a hand-made case with a known answer."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.calibrate.pipeline import calibrate
from aceval.data.dataset import load_dataset, validate
from aceval.data.rotations import error_angle_deg
from aceval.evaluation.methods_comparison import with_truth
from aceval.methods.functional import axis_of_recordings, fit_axes, triad_pair
from aceval.methods.moments import (
    MOMENT_COLUMNS,
    first_phase_sign,
    functional_axis,
    recording_moments,
)
from aceval.methods.registry import functional_design
from aceval.methods.sagittal import sagittal_fits
from aceval.methods.sufficient import gyroscope_axis
from aceval.signals.reduction import summarise_recordings
from aceval.simulate import SimOptions
from aceval.simulate.ricci_dataset import simulate_ricci

TRUE = Rotation.from_euler("xyz", [25, -40, 110], degrees=True).as_matrix()  # sensor -> body


def test_pooled_moments_equal_the_axis_of_the_joined_samples():
    rng = np.random.default_rng(0)
    first, second = rng.normal(size=(300, 3)) + [3, 0, 0], rng.normal(size=(200, 3)) + [2, 1, 0]
    rows = pd.DataFrame([recording_moments(x, 100.0, motion=False) for x in (first, second)])
    pooled = axis_of_recordings(rows)
    joined = functional_axis(np.vstack([first, second]))
    assert pooled.rho == pytest.approx(joined.rho, abs=1e-12)
    np.testing.assert_allclose(pooled.axis, joined.axis, atol=1e-12)
    summed = np.array([[1, 0], [0, 1], [1, 1]]) @ np.nan_to_num(rows[MOMENT_COLUMNS].to_numpy())
    axes, rho = gyroscope_axis(
        summed[:, 0:3],
        summed[:, 3:12].reshape(-1, 3, 3),
        summed[:, 12],
        np.tile(joined.axis, (3, 1)),
    )
    assert rho[2] == pytest.approx(joined.rho, abs=1e-12)
    np.testing.assert_allclose(axes[2], joined.axis, atol=1e-12)
    assert rho[0] == pytest.approx(functional_axis(first).rho, abs=1e-12)


def test_rho_of_a_rotated_recording_is_unchanged_and_its_axis_rotates():
    rng = np.random.default_rng(1)
    samples = np.outer(np.sin(np.linspace(0, 9, 500)), [0.2, 0.9, 0.1]) + rng.normal(
        0, 0.05, (500, 3)
    )
    Q = Rotation.from_rotvec([0.3, -1.2, 0.5]).as_matrix()
    plain, rotated = functional_axis(samples), functional_axis(samples @ Q.T)
    assert rotated.rho == pytest.approx(plain.rho, abs=1e-12)
    assert abs(rotated.axis @ (Q @ plain.axis)) == pytest.approx(1.0, abs=1e-12)


def test_first_phase_sign_follows_the_first_movement_direction():
    t = np.linspace(0, 2, 200)
    speed = np.sin(2 * np.pi * t / 2)  # out (positive) then back (negative): one repetition
    axis = np.array([0.0, 1.0, 0.0])
    assert first_phase_sign(np.outer(speed, axis), axis, 100.0) == 1.0
    assert first_phase_sign(np.outer(-speed, axis), axis, 100.0) == -1.0
    assert first_phase_sign(np.outer(speed, axis), -axis, 100.0) == -1.0
    assert first_phase_sign(np.zeros((10, 3)), axis, 100.0) == 0.0
    row = recording_moments(np.outer(-speed, axis) + 1e-3, 100.0, motion=True)
    assert row["phase_y"] == pytest.approx(-1.0, abs=1e-3)


def test_every_method_fed_the_true_axes_has_zero_error():
    z0, y = TRUE.T @ [0, 0, 1], TRUE.T @ [0, 1, 0]  # the body axes seen in the sensor frame
    for fits in (
        sagittal_fits(z0, 0.99, y, 0.6),
        fit_axes(np.eye(3), np.eye(3) @ TRUE, np.array([0.9, 0.5, 0.7]), (0, 1), random_starts=3),
    ):
        for method in functional_design():
            assert error_angle_deg(fits[method]["R"], TRUE) == pytest.approx(0.0, abs=1e-5), method
    lm = fits["ricci_lm"]
    assert lm["converged"] and lm["random_starts_optimum"] == 3
    np.testing.assert_allclose(lm["residual_after_deg"], 0.0, atol=1e-4)


def test_a_rotated_sensor_gives_a_correspondingly_rotated_calibration():
    rng = np.random.default_rng(2)
    z0 = TRUE.T @ [0, 0, 1] + rng.normal(0, 0.02, 3)
    y = TRUE.T @ [0, 1, 0] + rng.normal(0, 0.05, 3)
    Q = Rotation.from_rotvec([0.4, 0.1, -0.9]).as_matrix()  # the sensor turned on its segment
    plain, turned = sagittal_fits(z0, 0.99, y, 0.6), sagittal_fits(Q @ z0, 0.99, Q @ y, 0.6)
    for method in functional_design():
        np.testing.assert_allclose(turned[method]["R"], plain[method]["R"] @ Q.T, atol=1e-6)


def test_triad_keeps_z0_and_weights_pull_the_lm_towards_the_reliable_axis():
    z0 = TRUE.T @ [0, 0, 1]
    y = Rotation.from_rotvec(np.radians(4) * TRUE.T @ [1, 0, 0]).as_matrix() @ (
        TRUE.T @ [0, 1, 0]
    )  # 4 deg off
    fits = sagittal_fits(z0, 0.99, y, 0.6)
    np.testing.assert_allclose(fits["triad"]["R"] @ z0, [0, 0, 1], atol=1e-12)
    z_error = np.degrees(np.arccos(np.clip(fits["ricci_lm"]["R"] @ z0 @ [0, 0, 1], -1, 1)))
    assert 0.0 < z_error < 2.0  # the more reliable z0 moves less than half of the 4 deg
    # Ricci's stop rule (relative cost change < 1e-4) ends near, not at, the closed-form optimum
    assert error_angle_deg(fits["ricci_lm"]["R"], fits["align_vectors"]["R"]) < 0.01


def test_triad_pair_skips_a_reference_parallel_to_the_primary():
    v_ref = np.array([[0, 1, 0], [0, 1, 0], [0, 0, 1.0]])  # forearm: supine and FFEB both along y
    assert triad_pair(v_ref, np.array([0.98, 0.74, 0.83])) == (0, 2)
    assert triad_pair(v_ref, np.array([0.5, 0.9, 0.6])) == (1, 2)


def test_aligned_axes_are_flagged_not_raised():
    fits = sagittal_fits(np.array([0, 0, 1.0]), 0.99, np.array([0, 0.01, 1.0]), 0.6)
    assert fits["triad"]["R"] is None and fits["triad"]["flag"] == "aligned_axes"


@pytest.fixture(scope="module")
def ricci_child(clean):
    """One simulated child, ideal sensors and no wobble: only the off-axis movement remains."""
    options = SimOptions(noise=False, wobble=0.0)
    return clean.shared("child", lambda at: simulate_ricci(at, 4, 1, options=options))


def test_functional_design_signs_axes_and_recovers_the_mountings(ricci_child):
    dataset = load_dataset(ricci_child)
    calibrations, axes = calibrate(dataset, summarise_recordings(dataset))
    calibrations = with_truth(calibrations, dataset.ground_truth)
    assert set(calibrations["method"]) == set(functional_design())
    assert len(calibrations) == 5 * len(functional_design())
    assert calibrations["error_deg"].max() < 3.0, calibrations[["imu", "method", "error_deg"]]
    used = axes[axes["reference"].fillna("") != ""]
    assert (
        len(used) == 3 + 4 * 2 + 3 * 2
    )  # thorax S TR TFE; upper arms S AA FE FEB; forearms S PS FFEB
    assert (used["residual_after_deg"] < 10).all()  # a wrong sign would leave ~180 deg
    lm = calibrations[calibrations["method"] == "ricci_lm"]
    assert lm["converged"].all() and (lm["random_starts_optimum"] == lm["random_starts"]).all()
    static = axes[axes["kind"] == "static"]
    assert static["rho"].between(0.95, 1.0).all()


def test_functional_axes_sheet_is_validated(ricci_child, tmp_path):
    import shutil

    root = tmp_path / "bad"
    shutil.copytree(ricci_child, root)
    sheet = root / "functional_axes.tsv"
    sheet.write_text(sheet.read_text() + "TR\tthorax\tz\nXX\tthorax\t+x\nFE\tpelvis\t+y\n")
    _, report = validate(root, check_files=False)
    text = report.format()
    assert "axis 'z' must be a signed axis" in text
    assert "test 'XX' is not defined" in text
    assert "segment 'pelvis'" in text
    assert "given twice" in text


def test_the_axis_methods_fit_many_rows_as_the_single_problem_fits():
    """The registry's axis methods fit every calibration of a job at once: the same rotations and
    steps as lm_fit, wahba_fit and TRIAD one problem at a time, the axes within TRIAD's 5 deg of
    z0 fitted alone (TRIAD refuses: aligned_axes), and the flags beyond AxisLimits (low rho, near
    vertical, disagreeing repetitions), in that order of precedence."""
    from aceval.methods.align_vectors import wahba_fit
    from aceval.methods.registry import classes
    from aceval.methods.ricci import lm_fit
    from aceval.methods.sagittal import SAGITTAL_REFERENCE, AxisLimits
    from aceval.methods.sufficient import Pooled
    from aceval.methods.triad import triad

    rng = np.random.default_rng(11)
    z0 = np.array([0.1, -0.05, 1.0])
    z0 /= np.linalg.norm(z0)
    axes = rng.standard_normal((40, 3)) * [0.2, 1.0, 0.2]
    axes[3] = z0 + [0.0, 0.02, 0.0]  # 1 deg from z0: TRIAD refuses
    axes[4] = z0 + [0.0, 0.5, 0.0]  # near vertical: flagged
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rho = rng.uniform(0.3, 0.9, 40)  # some below min_rho: flagged low_rho
    spread = rng.uniform(0.0, 50.0, 40)  # some above max_spread_deg: flagged axes_disagree
    rows = [Pooled.of_axes(z0, 0.95, axes[k], rho[k], spread[k]) for k in range(40)]
    pooled = Pooled.concat(rows)
    fits = {
        name: cls().fit(pooled, {}).result for name, cls in classes(functional_design()).items()
    }
    limits = AxisLimits()
    flags = set()
    for k in range(40):
        v_est, w = np.array([z0, axes[k]]), np.array([0.95, rho[k]])
        vertical = np.degrees(np.arccos(min(1.0, abs(z0 @ axes[k]))))
        expected = (
            "low_rho"
            if rho[k] < limits.min_rho
            else "axis_near_vertical"
            if vertical < limits.min_vertical_angle_deg
            else "axes_disagree"
            if spread[k] > limits.max_spread_deg
            else ""
        )
        single = lm_fit(SAGITTAL_REFERENCE, v_est, w)
        np.testing.assert_allclose(fits["ricci_lm"].R[k], single.R, atol=1e-9)
        assert fits["ricci_lm"].columns["n_iterations"][k] == single.n_iterations
        assert fits["ricci_lm"].columns["converged"][k] == single.converged
        optimum = wahba_fit(SAGITTAL_REFERENCE, v_est, w).as_matrix()
        np.testing.assert_allclose(fits["align_vectors"].R[k], optimum, atol=1e-9)
        for name in ("ricci_lm", "align_vectors"):
            assert fits[name].flag[k] == expected
        if vertical < 5.0:
            assert fits["triad"].flag[k] == "aligned_axes" and np.isnan(fits["triad"].R[k]).all()
        else:
            np.testing.assert_allclose(
                fits["triad"].R[k], triad(SAGITTAL_REFERENCE, v_est), atol=1e-9
            )
            assert fits["triad"].flag[k] == expected
        flags.add(expected)
    assert {"", "low_rho", "axis_near_vertical", "axes_disagree"} <= flags


def test_the_lm_diagnostics_are_the_fixed_and_adaptive_fits_own():
    """Ricci's table of the LM (published: steps, cost and distance to the optimum of both the
    adaptive and the fixed-damping LM) reads these entries: each is that fit's own number."""
    from aceval.methods.align_vectors import wahba_fit
    from aceval.methods.ricci import lm_fit

    rng = np.random.default_rng(5)
    v_ref = np.eye(3)
    v_est = (TRUE.T @ v_ref.T).T + rng.normal(0, 0.05, (3, 3))
    v_est /= np.linalg.norm(v_est, axis=1, keepdims=True)
    rho = np.array([0.9, 0.5, 0.7])
    lm = fit_axes(v_ref, v_est, rho, (0, 1))["ricci_lm"]
    adaptive, fixed = lm_fit(v_ref, v_est, rho), lm_fit(v_ref, v_est, rho, adaptive=False)
    optimum = wahba_fit(v_ref, v_est, rho).as_matrix()
    assert (lm["n_iterations"], lm["cost"]) == (adaptive.n_iterations, adaptive.cost)
    assert (lm["fixed_n_iterations"], lm["fixed_cost"]) == (fixed.n_iterations, fixed.cost)
    assert lm["fixed_converged"] == fixed.converged and lm["n_rejected"] == adaptive.n_rejected
    assert lm["fixed_optimum_distance_deg"] == pytest.approx(error_angle_deg(fixed.R, optimum))
    assert lm["optimum_distance_deg"] == pytest.approx(error_angle_deg(adaptive.R, optimum))
    assert "fixed_cost" not in fit_axes(v_ref, v_est, rho, (0, 1), diagnostics=False)["ricci_lm"]
    # the same through Kong's protocol: the fixed LM only for a calibration from all repetitions
    z0, y = v_est[2], v_est[1]
    assert "fixed_cost" in sagittal_fits(z0, 0.99, y, 0.6)["ricci_lm"]
    assert "fixed_cost" not in sagittal_fits(z0, 0.99, y, 0.6, diagnostics=False)["ricci_lm"]
    assert sagittal_fits(z0, 0.99, y, 0.6)["ricci_lm"]["fixed_cost"] > 0


def test_a_failed_lm_is_an_entry_with_its_flag():
    fits = fit_axes(np.eye(3)[:1], np.eye(3)[:1], np.array([0.9]), (0, 0))
    assert set(fits) == set(functional_design())
    assert fits["ricci_lm"]["R"] is None and fits["ricci_lm"]["flag"]


def test_functional_fits_flag_too_few_reliable_or_inconsistent_axes():
    axes = pd.DataFrame(
        {
            "reference": ["+x", "+y", "+z"],
            "axis_x": [1.0, 0.0, 0.0],
            "axis_y": [0.0, 1.0, 0.0],
            "axis_z": [0.0, 0.0, 1.0],
            "rho": [0.9, 0.8, 0.7],
        }
    )
    from aceval.methods.functional import functional_fits

    assert not any(fit.get("flag") for fit in functional_fits(axes, random_starts=0).values())
    low = functional_fits(axes.assign(rho=[0.9, 0.2, 0.1]), random_starts=0)
    assert {fit["flag"] for fit in low.values()} == {"low_rho"}
    assert "(0.90, 0.20, 0.10)" in low["triad"]["message"]
    mirrored = functional_fits(axes.assign(axis_z=[0.0, 0.0, -1.0]), random_starts=0)
    assert {fit["flag"] for fit in mirrored.values()} == {"axes_inconsistent"}
