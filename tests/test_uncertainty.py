"""The combined heading, the bootstrap cone and the recommendation (beyond the papers)."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.evaluation.methods_comparison import uncertainty_table
from aceval.methods.combined import (
    combined_rotation,
    gyro_weight,
    horizontal_right,
    kong_weight,
)
from aceval.methods.kong import kong_from_scatters
from aceval.methods.sufficient import Units
from aceval.methods.uncertainty import bootstrap_cones, cones, resample_weights
from aceval.report import summary

R_TRUE = Rotation.from_euler("zyx", [40, -25, 70], degrees=True).as_matrix()  # sensor -> body


def _in_sensor(body_vector):
    return R_TRUE.T @ np.asarray(body_vector, float)


def _body_heading(yaw_deg):
    """The body's right axis turned by ``yaw_deg`` about the body vertical, in the sensor frame."""
    yaw = np.radians(yaw_deg)
    return _in_sensor([-np.sin(yaw), np.cos(yaw), 0.0])


def test_combined_heading_is_the_weighted_mean_of_the_two_horizontal_axes():
    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])
    y_kong, y_gyro = _body_heading(10.0), _body_heading(-10.0)
    # a weight of 0 gives the other estimate exactly; equal weights the bisector, the truth here
    only_gyro = combined_rotation(z0, y_kong, y_gyro, 0.0, 0.7)
    assert error_angle_deg(only_gyro, R_TRUE) == pytest.approx(10.0, abs=1e-9)
    assert np.allclose(only_gyro @ y_gyro, [0, 1, 0])
    for unusable in (y_gyro, np.full(3, np.nan)):  # an unusable gyroscope: Kong's heading alone
        only_kong = combined_rotation(z0, y_kong, unusable, 0.6, 0.0)
        assert np.allclose(only_kong @ y_kong, [0, 1, 0])
    assert np.allclose(combined_rotation(z0, np.full(3, np.nan), y_gyro, 0.0, 0.7), only_gyro)
    both = combined_rotation(z0, y_kong, y_gyro, 0.5, 0.5)
    assert error_angle_deg(both, R_TRUE) == pytest.approx(0.0, abs=1e-6)
    assert np.allclose(both @ both.T, np.eye(3)) and np.linalg.det(both) == pytest.approx(1.0)
    # weights 3:1 turn the heading a quarter of the way from Kong's estimate to the gyroscope's
    assert error_angle_deg(combined_rotation(z0, y_kong, y_gyro, 0.75, 0.25), R_TRUE) == (
        pytest.approx(5.0, abs=0.2)
    )
    assert np.isnan(combined_rotation(z0, y_kong, y_gyro, 0.0, 0.0)).all()
    # a gyroscope axis off the horizontal, or pointing left, is projected and turned right
    tilted = -(y_gyro + 0.3 * z0)
    assert np.allclose(horizontal_right(tilted, z0, right), y_gyro)


def test_combined_heading_rotates_with_the_sensor():
    z0, y_kong, y_gyro = _in_sensor([0, 0, 1]), _body_heading(6.0), _body_heading(-2.0)
    base = combined_rotation(z0, y_kong, y_gyro, 0.3, 0.9)
    Q = Rotation.from_euler("xyz", [10, 80, -35], degrees=True).as_matrix()  # a remounted sensor
    turned = combined_rotation(Q @ z0, Q @ y_kong, Q @ y_gyro, 0.3, 0.9)
    assert np.allclose(turned, base @ Q.T)


def test_weights_are_zero_at_the_flag_limits_and_one_when_perfect():
    assert kong_weight([0.0, 0.25, 0.5, 0.7], [0.01] * 4, 0.5, 0.1) == pytest.approx(
        [1.0, 0.5, 0.0, 0.0]
    )
    assert kong_weight(0.1, 0.2, 0.5, 0.1) == 0.0  # not planar
    assert gyro_weight([1.0, 0.7, 0.4, 0.35], 0.4) == pytest.approx([1.0, 0.5, 0.0, 0.0])


def _scatters(headings_deg, n=500, seed=0):
    """Per repetition: the scatter of sagittal accelerations (gravity and a fore-aft swing) of
    a sensor whose plane is turned by ``headings_deg`` about the vertical."""
    rng = np.random.default_rng(seed)
    scatters = []
    for heading in headings_deg:
        yaw = np.radians(heading)
        forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        t = rng.uniform(-1, 1, n)
        body = -9.81 * np.array([0, 0, 1.0]) + 3.0 * t[:, None] * forward
        body += 0.05 * rng.standard_normal((n, 3))
        sensor = body @ R_TRUE  # d_sensor = R^T d_body, row-wise
        scatters.append(sensor.T @ sensor)
    return np.array(scatters), np.full(len(headings_deg), float(n))


def test_weights_instead_of_subsets_give_the_same_calibrations():
    scatters, counts = _scatters([0, 3, -2, 1, 4])
    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])
    subsets = [[0, 1, 2], [1, 3], [0, 1, 2, 3, 4]]
    weights = np.zeros((3, 5))
    for row, subset in enumerate(subsets):
        weights[row, subset] = 1.0
    by_subsets = kong_from_scatters(scatters, counts, z0, right, subsets)
    by_weights = kong_from_scatters(scatters, counts, z0, right, weights=weights)
    assert np.allclose(by_subsets.R, by_weights.R)


def _cones(scatters, counts, unit_scatters, R_full, seed, rho_static=1.0):
    """bootstrap_cones of one unit (its right axis and z0 the true ones)."""
    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])
    units = Units.of_repetitions(z0, right, scatters, counts, unit_scatters, rho_static)
    found = bootstrap_cones(units, np.array([seed]), {m: R[None] for m, R in R_full.items()})
    return {method: (float(c[0]), float(s[0])) for method, (c, s) in found.items()}


def test_the_cone_grows_with_the_repetitions_spread_and_is_about_the_vertical():
    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])
    unit = np.repeat((np.outer(right, right) * 100.0)[None], 5, axis=0)  # a pure hinge about y

    def cones_of(headings):
        scatters, counts = _scatters(headings)
        R = kong_from_scatters(scatters, counts, z0, right).R[0]
        return _cones(scatters, counts, unit, {"kong": R, "combined": R}, seed=3), R

    tight, _ = cones_of([0, 0, 0, 0, 0])
    wide, R = cones_of([0, 6, -6, 3, -3])
    assert tight["kong"][0] < 0.5
    assert wide["kong"][0] > 2.0 * tight["kong"][0] + 1.0
    assert wide["kong"][1] == pytest.approx(1.0, abs=1e-6)  # z0 is held: all about the vertical
    # reproducible: the same seed gives the same cone
    assert cones_of([0, 6, -6, 3, -3])[0] == wide


def test_resample_weights_draw_n_repetitions_each_time():
    weights = resample_weights(5, 200, seed=1)
    assert weights.shape == (200, 5) and (weights.sum(axis=1) == 5).all()
    # every resample flagged: the calibration is undetermined, the cone 180 deg (not dropped)
    assert cones(np.full((1, 10, 3, 3), np.nan), np.eye(3)[None])[0][0] == 180.0
    one_flagged = np.repeat(np.eye(3)[None, None], 40, axis=1)
    one_flagged[0, :3] = np.nan  # 3 of 40 (7.5 %) flagged: beyond the 95th percentile
    assert cones(one_flagged, np.eye(3)[None])[0][0] == 180.0
    assert np.isnan(cones(one_flagged, np.full((1, 3, 3), np.nan))[0]).all()


def _calibrations(errors, cones, spreads, flags=None):
    n = len(errors)
    return pd.DataFrame(
        {
            "subject": [f"S{i}" for i in range(n)],
            "sensor_set": "frontal",
            "imu": "IMU1",
            "segment": "thigh",
            "test": "T6",
            "method": "kong",
            "repetitions": "R1+R2+R3+R4+R5",
            "n_reps": 5,
            "flag": flags or [""] * n,
            "error_deg": errors,
            "error_vertical_share": 1.0,
            "cone_deg": cones,
            "spread95_deg": spreads,
        }
    )


def test_coverage_counts_errors_inside_their_cone_beside_the_spread_alone():
    table = uncertainty_table(
        _calibrations([1.0, 3.0, 2.0, 9.0], [2.0, 2.0, 2.0, 1.0], [0.5, 0.5, 2.0, 0.5])
    )
    cell, pooled = table.iloc[0], table.iloc[-1]
    assert cell["n"] == 4 and pooled["segment"] == "all" and pooled["n"] == 4
    assert cell["coverage"] == pytest.approx(0.5)  # 1 <= 2 and 2 <= 2
    assert cell["spread_coverage"] == pytest.approx(0.25)  # only 2 <= 2
    # 4 subjects: too few to resample, a binomial interval around 2 of 4
    assert cell["interval"] == "binomial" and cell["coverage_low"] < 0.5 < cell["coverage_high"]
    flagged = uncertainty_table(
        _calibrations([1.0, 3.0], [2.0, 2.0], [1.0, 1.0], ["", "not_planar"])
    )
    assert flagged.iloc[0]["n"] == 1
    # with a measured truth, its own uncertainty is allowed for
    sheet = pd.DataFrame({"subject": ["S0", "S1", "S2", "S3"], "sensor_set": "frontal",
                          "imu": "IMU1", "truth_uncertainty_deg": [0.0, 1.5, 0.0, 0.0]})  # fmt: skip
    with_truth = uncertainty_table(
        _calibrations([1.0, 3.0, 2.0, 9.0], [2.0, 2.0, 2.0, 1.0], [0.5] * 4), sheet
    ).iloc[0]
    assert with_truth["coverage_with_truth"] == pytest.approx(0.75)  # 3 - 1.5 <= 2 as well


def test_a_cone_is_not_called_95_percent_where_no_cell_could_be_judged():
    pooled = pd.Series({"coverage": 0.95, "cone_median_deg": 4.0, "error_median_deg": 2.0})
    assert summary._cone_verdict(pooled, 0.85) == "A 95 % cone here."
    assert "a cell at 70%" in summary._cone_verdict(pooled, 0.70)
    unjudged = summary._cone_verdict(pooled, np.nan)  # e.g. one real subject: cells of 1-2
    assert unjudged.startswith("Not a validated") and "no test x segment cell" in unjudged


def test_the_cone_adds_what_the_recording_shows_with_the_models_constants():
    """model_cones is the documented formula: spread, datasheet tilt, the foot's plane, the
    scaled disagreements and conditioning, times the method's q; a missing disagreement counts 0,
    a missing spread leaves no cone, and 180 deg is the most a cone can be."""
    from aceval.methods.uncertainty import (
        SEGMENT_PLANE_DEG,
        TILT_SD_DEG,
        Z95,
        ConeModel,
        model_cones,
    )

    model = ConeModel(signals=0.5, tests=0.25, conditioning=0.2, q={"kong": 2.0}, q_other=3.0)
    cone = model_cones([3.92, 3.92, np.nan, 1.0], [4.0, np.nan, 4.0, 400.0], [8.0, 8.0, 8.0, 0.0],
                       [10.0, 10.0, 10.0, 0.0], ["thigh", "foot", "thigh", "thigh"],
                       ["kong", "triad", "kong", "kong"], model)  # fmt: skip
    base = (3.92 / Z95) ** 2 + TILT_SD_DEG**2 + 2.0**2 + 2.0**2  # tests 0.25 x 8, cond. 0.2 x 10
    assert cone[0] == pytest.approx(2.0 * np.sqrt(base + 2.0**2))  # signals 0.5 x 4
    assert cone[1] == pytest.approx(3.0 * np.sqrt(base + SEGMENT_PLANE_DEG["foot"] ** 2))
    assert np.isnan(cone[2]) and cone[3] == 180.0


def test_heading_terms_measure_the_other_estimates_and_the_conditioning():
    """Two units of one IMU (two tests) and one of another: Kong 4 deg from the gyroscope's
    axis in the first, the same method 6 deg apart between the IMU's tests; no other estimate,
    no disagreement (NaN); the conditioning is atan(sqrt(ratio))."""
    from aceval.methods.uncertainty import heading_terms

    def turned(deg):
        return Rotation.from_euler("z", deg, degrees=True).as_matrix() @ R_TRUE

    R_full = {
        "kong": np.stack([turned(0.0), turned(6.0), turned(1.0)]),
        "ricci_lm": np.stack([turned(4.0), turned(6.0), np.full((3, 3), np.nan)]),
        "combined": np.stack([turned(2.0), turned(6.0), turned(1.0)]),
    }
    terms = heading_terms(R_full, np.array(["a", "a", "b"]), np.array([0.25, 0.0, np.nan]))
    assert terms["kong_signals"][:2] == pytest.approx([4.0, 0.0], abs=1e-6)
    assert np.isnan(terms["kong_signals"][2])  # its gyroscope axis undetermined there
    assert terms["combined_signals"][0] == pytest.approx(2.0, abs=1e-6)  # median of 2 and 2
    assert terms["kong_tests"][:2] == pytest.approx([6.0, 6.0], abs=1e-6)
    assert np.isnan(terms["kong_tests"][2])  # IMU b has one test
    assert terms["conditioning"][0] == pytest.approx(np.degrees(np.arctan(0.5)))
    assert terms["conditioning"][1] == 0.0 and np.isnan(terms["conditioning"][2])


def test_an_undetermined_heading_is_a_flag_never_a_covered_cone():
    from aceval.methods.uncertainty import UNDETERMINED_CONE_DEG, undetermined

    assert undetermined(
        [10.0, UNDETERMINED_CONE_DEG + 1, 179.0, 5.0], [1, 1, 1, np.nan]
    ).tolist() == [
        False,
        True,
        True,
        True,
    ]
    # a calibration flagged heading_undetermined whose error is inside its 160-deg cone is left
    # out of the coverage (counted apart), never counted covered
    rows = _calibrations([1.0, 3.0, 20.0], [2.0, 2.0, 160.0], [0.5, 0.5, 180.0],
                         ["", "", "heading_undetermined"])  # fmt: skip
    table = uncertainty_table(rows)
    pooled = table[table["segment"] == "all"].iloc[0]
    assert pooled["n"] == 2 and pooled["n_undetermined"] == 1
    assert pooled["coverage"] == pytest.approx(0.5)


def test_repetitions_in_different_planes_or_one_repetition_leave_the_heading_undetermined():
    """Repetitions whose planes turn far apart: more than 5 % of the resamples flagged, a spread
    of 180 deg (undetermined, whatever the cone's factor, below 1, makes of it); one repetition:
    no spread to resample, no cone (undetermined); consistent repetitions: a narrow cone. (The
    flag itself on the rows: tests/test_coverage.py, on the regenerated real data.)"""
    from aceval.methods.uncertainty import calibration_cones, undetermined

    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])

    def cone_of(headings):
        scatters, counts = _scatters(headings)
        hinge = np.repeat((np.outer(right, right) * 100.0)[None], len(headings), axis=0)
        units = Units.of_repetitions(z0, right, scatters, counts, hinge, 1.0)
        R = kong_from_scatters(scatters, counts, z0, right).R[0]
        found = calibration_cones(units, np.array([1]), {"kong": R[None]}, np.array(["a"]),
                                  np.array([0.01]))["kong"]  # fmt: skip
        return found["cone_deg"][0], found["spread95_deg"][0]

    narrow, apart, single = cone_of([0, 1, -1, 2, 0]), cone_of([0, 85, -85, 60, -60]), cone_of([0])
    assert narrow[0] < 10.0 and not undetermined(*narrow)
    assert apart[1] == 180.0 and undetermined(*apart)
    assert undetermined(89.0, 91.0) and undetermined(91.0, 1.0) and not undetermined(89.0, 89.0)
    assert np.isnan(single[1]) and undetermined(*single)


def test_an_undetermined_calibration_has_no_error_to_the_truth_rather_than_a_crash():
    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.methods_comparison import with_truth

    both_flagged = combined_rotation(
        _in_sensor([0, 0, 1]), _body_heading(3.0), _body_heading(-3.0), 0.0, 0.0
    )
    key = {"subject": "S1", "sensor_set": "s", "imu": "IMU1"}
    rows = pd.DataFrame(
        [key | dict(zip(R_COLUMNS, R.ravel())) for R in (both_flagged, R_TRUE)]
    ).assign(error_deg=np.nan, error_vertical_share=np.nan)
    truth = pd.DataFrame([key | dict(zip(R_COLUMNS, R_TRUE.ravel()))]).set_index(
        ["subject", "sensor_set", "imu"]
    )
    errors = with_truth(rows, truth)
    assert np.isnan(errors["error_deg"][0]) and np.isnan(errors["error_vertical_share"][0])
    assert errors["error_deg"][1] == pytest.approx(0.0, abs=1e-6)


def test_the_axis_methods_cones_follow_the_spread_of_the_repetitions_gyroscope_axes():
    from aceval.methods.sagittal import sagittal_fits
    from aceval.methods.sufficient import gyroscope_axis

    z0, right = _in_sensor([0, 0, 1]), _in_sensor([0, 1, 0])
    scatters, counts = _scatters([0, 0, 0, 0, 0])

    def unit(headings_deg):  # each repetition's hinge axis turned about the vertical
        return np.array([np.outer(a, a) * 100.0 for a in map(_body_heading, headings_deg)])

    def axis_cones(headings_deg):
        units = unit(headings_deg)
        axis, rho = gyroscope_axis(
            np.zeros((1, 3)), units.sum(axis=0)[None], np.array([500.0]), right[None]
        )
        fits = sagittal_fits(z0, 1.0, axis[0], float(rho[0]))
        R_full = {m: fits[m]["R"] for m in ("ricci_lm", "align_vectors", "triad")}
        R_full["kong"] = kong_from_scatters(scatters, counts, z0, right).R[0]
        return _cones(scatters, counts, units, R_full, seed=5)

    still, spread = axis_cones([0, 0, 0, 0, 0]), axis_cones([0, 8, -8, 4, -4])
    for method in ("ricci_lm", "align_vectors", "triad"):
        assert still[method][0] < 0.01
        assert spread[method][0] > 2.0
    # the LM reaches the same optimum: the same resamples, measured from its own R
    assert spread["ricci_lm"] == pytest.approx(spread["align_vectors"], abs=1e-6)


def test_the_batched_wahba_and_triad_equal_the_single_calls():
    from aceval.methods.align_vectors import wahba_batch, wahba_fit
    from aceval.methods.functional import triad_pair
    from aceval.methods.triad import triad, triad_batch

    rng = np.random.default_rng(7)
    z0 = _in_sensor([0, 0, 1])
    axes = np.array([_body_heading(h) for h in rng.uniform(-20, 20, 12)])
    axes = axes + 0.2 * rng.standard_normal(axes.shape)  # off the horizontal too
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rho = rng.uniform(0.5, 1.0, 12)
    rho_static = 0.8  # some resamples' axes are more reliable than z0: TRIAD keeps them exact
    v_ref = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    v_est = np.stack([np.broadcast_to(z0, axes.shape), axes], axis=1)
    weights = np.column_stack([np.full(12, rho_static), rho])
    batched, triads = wahba_batch(v_ref, v_est, weights), triad_batch(z0, axes, rho_static, rho)
    for k in range(12):
        assert np.allclose(batched[k], wahba_fit(v_ref, v_est[k], weights[k]).as_matrix())
        pair = list(triad_pair(v_ref, weights[k]))
        assert np.allclose(triads[k], triad(v_ref[pair], v_est[k][pair]))


def test_a_unit_whose_subsets_use_different_estimates_is_flagged_weight_switch():
    """Issue 28: unit 0 uses the gyroscope in one calibration and not in the other (every row of
    it flagged); unit 1 always uses both, unit 2 never Kong's: neither switches."""
    from aceval.methods.combined import _weight_switches

    unit = np.array([0, 0, 1, 1, 2, 2])
    w_kong = np.array([0.5, 0.4, 0.5, 0.6, 0.0, 0.0])
    w_gyro = np.array([0.3, 0.0, 0.2, 0.1, 0.9, 0.8])
    switched = [True, True, False, False, False, False]
    assert _weight_switches(unit, w_kong, w_gyro).tolist() == switched
    assert _weight_switches(unit, w_gyro, w_kong).tolist() == switched
    assert _weight_switches(np.array([], int), np.array([]), np.array([])).tolist() == []


def test_cones_are_each_units_own_95th_percentile():
    """Two units, their resamples 1..20 deg and 21..40 deg about the vertical from R: each cone
    is its own unit's 95th percentile (a flagged resample counts 180 deg)."""
    from aceval.methods.uncertainty import cones

    R = np.stack([np.eye(3), R_TRUE])
    angles = np.stack([np.arange(1.0, 21.0), np.arange(21.0, 41.0)])
    turns = Rotation.from_rotvec(np.radians(angles)[..., None] * [0, 0, 1]).as_matrix()
    resampled = turns @ R[:, None]
    cone95, share = cones(resampled, R)
    np.testing.assert_allclose(cone95, np.percentile(angles, 95, axis=1))
    np.testing.assert_allclose(share, 1.0)
    resampled[1, 0] = np.nan  # one undetermined resample of the second unit: 180 deg
    with_flag = np.where(np.arange(20) == 0, 180.0, angles[1])
    assert cones(resampled, R)[0][1] == pytest.approx(np.percentile(with_flag, 95))
