import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aceval.data.errors import (
    NonFiniteError,
    NormalParallelToVerticalError,
    NotPlanarError,
    TooFewSamplesError,
    ZeroGravityError,
)
from aceval.data.rotations import error_angle_deg
from aceval.methods import kong_calibrate, kong_from_scatters, scatter, vertical_axis

from .synthetic import G, pitch_motion, right_axis_of

REST_BODY = np.array([0.0, 0.0, -G])  # specific force at rest, body frame (z down)


def to_sensor(R_mount, body):
    """Body-frame vectors -> sensor frame, for a mounting R (d_body = R d_sensor)."""
    return np.asarray(body) @ R_mount  # row-wise R^T d


def static_samples(R_mount, n=200, rng=None):
    body = np.tile(REST_BODY, (n, 1))
    if rng is not None:
        body = body + rng.normal(0, 0.02, body.shape)
    return to_sensor(R_mount, body)


quaternions = st.tuples(*[st.floats(-1, 1) for _ in range(4)]).filter(
    lambda q: np.linalg.norm(q) > 0.1
)


@settings(max_examples=200, deadline=None)
@given(q=quaternions)
def test_known_mounting_comes_back(q):
    R_mount = Rotation.from_quat(q).as_matrix()
    result = kong_calibrate(
        static_samples(R_mount), to_sensor(R_mount, pitch_motion()), right_axis_of(R_mount)
    )
    assert error_angle_deg(result.R, R_mount) < 0.01
    assert result.n_samples == 400
    assert result.normal_vertical_angle_deg == pytest.approx(90.0, abs=1e-6)
    assert result.planarity < 1e-12  # exactly planar, noise-free


def test_repetitions_of_different_lengths_are_joined():
    """A list of repetitions (each its own length, as recorded) is one calibration of them all."""
    R_mount = Rotation.from_euler("zyx", [30, -20, 110], degrees=True).as_matrix()
    motion = to_sensor(R_mount, pitch_motion())
    parts = [motion[:150], motion[150:390], motion[390:]]
    joined = kong_calibrate(static_samples(R_mount), motion, right_axis_of(R_mount))
    by_parts = kong_calibrate(static_samples(R_mount), parts, right_axis_of(R_mount))
    assert np.allclose(by_parts.R, joined.R) and by_parts.n_samples == joined.n_samples


def test_R_maps_sensor_to_body():
    R_mount = Rotation.from_euler("zyx", [30, -20, 110], degrees=True).as_matrix()
    motion_body = pitch_motion()
    result = kong_calibrate(
        static_samples(R_mount), to_sensor(R_mount, motion_body), right_axis_of(R_mount)
    )
    # d_body = R d_sensor (Kong Eq. 6): the calibrated data are the body-frame data
    np.testing.assert_allclose(to_sensor(R_mount, motion_body) @ result.R.T, motion_body, atol=1e-9)
    # and at rest the body-frame specific force points up (-z)
    np.testing.assert_allclose(result.R @ static_samples(R_mount)[0], REST_BODY, atol=1e-9)


def test_equivariance_under_sensor_rotation():
    """Rotating the sensor data by Q changes R to R Q^T (noisy motion, noise-free stance)."""
    rng = np.random.default_rng(7)
    R_mount = Rotation.random(random_state=8).as_matrix()
    static = static_samples(R_mount)
    motion = to_sensor(R_mount, pitch_motion()) + rng.normal(0, 0.1, (400, 3))
    right = R_mount[1]  # any vector pointing roughly right works as the sign hint
    base = kong_from_scatters(scatter(motion)[None], [len(motion)], vertical_axis(static), right)
    for seed in range(10):
        Q = Rotation.random(random_state=100 + seed).as_matrix()
        rotated = kong_from_scatters(
            scatter(motion @ Q.T)[None], [len(motion)], vertical_axis(static @ Q.T), Q @ right
        )
        np.testing.assert_allclose(rotated.R, base.R @ Q.T, atol=1e-10)


def test_median_of_noisy_stance_is_only_nearly_equivariant():
    """Kong Eq. 2 takes a per-axis median, which is not rotation-equivariant: with noisy quiet
    stance, z0 of rotated data differs from the rotated z0 by a fraction of the noise angle."""
    rng = np.random.default_rng(7)
    static = static_samples(np.eye(3), rng=rng)  # 0.02 m/s^2 noise = 0.12 deg per sample
    z0 = vertical_axis(static)
    for seed in range(10):
        Q = Rotation.random(random_state=100 + seed).as_matrix()
        cos = np.clip(vertical_axis(static @ Q.T) @ (Q @ z0), -1, 1)
        assert np.degrees(np.arccos(cos)) < 0.05


def test_origin_symmetric_data_matter():
    """Kong Fig. 2: a short arc of accelerations plus lateral scatter. Fitting the plane around the
    data mean (no negatives) picks the arc's thin direction; the plane through the origin (with
    the negatives) finds the true normal y."""
    rng = np.random.default_rng(3)
    theta = np.radians(rng.uniform(-30, 30, 2000))
    body = np.column_stack([G * np.sin(theta), rng.normal(0, 0.5, theta.size), -G * np.cos(theta)])
    centred_normal = np.linalg.eigh(np.cov(body.T))[1][:, 0]
    origin_normal = np.linalg.eigh(scatter(np.vstack([body, -body])))[1][:, 0]
    assert np.degrees(np.arccos(abs(centred_normal[1]))) > 45  # without negatives: wrong
    assert np.degrees(np.arccos(abs(origin_normal[1]))) < 2  # with negatives: right
    result = kong_calibrate(static_samples(np.eye(3)), body, "+y")
    assert error_angle_deg(result.R, np.eye(3)) < 2


def test_y0_sign_follows_right_axis():
    R_mount = Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix()
    static, motion = static_samples(R_mount), to_sensor(R_mount, pitch_motion())
    right = right_axis_of(R_mount)
    flipped = ("-" if right[0] == "+" else "+") + right[1]
    a = kong_calibrate(static, motion, right).R
    b = kong_calibrate(static, motion, flipped).R
    np.testing.assert_allclose(b[0], -a[0], atol=1e-12)  # x0 flips
    np.testing.assert_allclose(b[1], -a[1], atol=1e-12)  # y0 flips
    np.testing.assert_allclose(b[2], a[2], atol=1e-12)  # z0 never
    assert np.linalg.det(b) == pytest.approx(1.0)  # still a proper rotation


def test_subset_form_equals_recomputing_from_samples():
    rng = np.random.default_rng(11)
    R_mount = Rotation.random(random_state=12).as_matrix()
    static = static_samples(R_mount, rng=rng)
    reps = [
        to_sensor(R_mount, pitch_motion(n=200 + 37 * k, amplitude_deg=25 + 5 * k, seed=k))
        + rng.normal(0, 0.3, (200 + 37 * k, 3))
        for k in range(5)
    ]
    right = right_axis_of(R_mount)
    subsets = [c for k in range(1, 6) for c in itertools.combinations(range(5), k)]
    assert len(subsets) == 31
    fast = kong_from_scatters(
        np.stack([scatter(r) for r in reps]),
        [len(r) for r in reps],
        vertical_axis(static),
        right,
        subsets,
    )
    for i, subset in enumerate(subsets):
        slow = kong_calibrate(static, np.vstack([reps[k] for k in subset]), right)
        np.testing.assert_allclose(fast.R[i], slow.R, atol=1e-12)
        np.testing.assert_allclose(fast.eigenvalues[i], slow.eigenvalues, rtol=1e-10)
        assert fast.n_samples[i] == slow.n_samples


def test_subset_form_vectorised_over_imus():
    R_mounts = Rotation.random(4, random_state=5).as_matrix()
    scatters = np.stack(
        [[scatter(to_sensor(R, pitch_motion(seed=k))) for k in range(3)] for R in R_mounts]
    )
    z0 = np.stack([vertical_axis(static_samples(R)) for R in R_mounts])
    rights = np.array([right_axis_of(R) for R in R_mounts])
    result = kong_from_scatters(
        scatters, np.full((4, 3), 400), z0, rights, [[0], [1, 2], [0, 1, 2]]
    )
    assert result.R.shape == (4, 3, 3, 3)
    np.testing.assert_array_less(error_angle_deg(result.R, R_mounts[:, None]), 1e-6)


# --- bad input -----------------------------------------------------------------------------


def test_too_few_samples():
    with pytest.raises(TooFewSamplesError, match="3 samples"):
        vertical_axis(np.tile(REST_BODY, (3, 1)))
    with pytest.raises(TooFewSamplesError, match="5 motion samples"):
        kong_calibrate(static_samples(np.eye(3)), pitch_motion(n=5), "+y")


def test_non_finite():
    motion = pitch_motion()
    motion[10, 2] = np.inf
    with pytest.raises(NonFiniteError, match="NaN or inf"):
        kong_calibrate(static_samples(np.eye(3)), motion, "+y")


def test_zero_gravity():
    with pytest.raises(ZeroGravityError, match="no gravity direction"):
        vertical_axis(np.zeros((100, 3)))


def test_not_planar():
    rng = np.random.default_rng(0)
    with pytest.raises(NotPlanarError, match="not planar"):
        kong_calibrate(static_samples(np.eye(3)), rng.normal(0, 5, (500, 3)), "+y")


def test_static_motion_has_undetermined_normal():
    rng = np.random.default_rng(0)
    with pytest.raises(NotPlanarError, match="normal undetermined"):
        kong_calibrate(static_samples(np.eye(3)), static_samples(np.eye(3), rng=rng), "+y")


def test_normal_parallel_to_vertical():
    # a motion in the horizontal plane (e.g. a turn): its normal is the vertical
    theta = np.linspace(0, 2 * np.pi, 300)
    horizontal = np.column_stack([np.cos(theta), np.sin(theta), 0.01 * np.sin(3 * theta)])
    with pytest.raises(NormalParallelToVerticalError, match="from the vertical"):
        kong_calibrate(static_samples(np.eye(3)), horizontal, "+y")


def test_flagged_instead_of_raised():
    rng = np.random.default_rng(0)
    good = scatter(pitch_motion())
    bad = scatter(rng.normal(0, 5, (500, 3)))
    result = kong_from_scatters(
        np.stack([[good], [bad]]), [[400], [500]], [[0, 0, 1], [0, 0, 1]], "+y", strict=False
    )
    assert list(result.flag[:, 0]) == ["", "not_planar"]
    assert list(result.valid[:, 0]) == [True, False]
    assert "not_planar" in result.messages[0]
