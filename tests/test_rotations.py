import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.rotations import (
    axis_vector,
    error_angle_deg,
    random_rotations,
    vector_angle_deg,
    vertical_share,
)


def test_error_angle_of_known_rotation():
    R1 = Rotation.from_euler("z", 7.5, degrees=True).as_matrix()
    assert error_angle_deg(R1, np.eye(3)) == pytest.approx(7.5)
    assert error_angle_deg(np.eye(3), R1) == pytest.approx(7.5)


def test_error_angle_is_the_angle_of_R1_R2T_on_stacks():
    R1 = random_rotations(20, seed=1)
    R2 = random_rotations(20, seed=2)
    expected = np.degrees(Rotation.from_matrix(R1 @ np.swapaxes(R2, 1, 2)).magnitude())
    np.testing.assert_allclose(error_angle_deg(R1, R2), expected)
    # broadcasting: one against many, and a (4, 5) stack
    assert error_angle_deg(R1[0], R2).shape == (20,)
    assert error_angle_deg(R1.reshape(4, 5, 3, 3), R2.reshape(4, 5, 3, 3)).shape == (4, 5)
    np.testing.assert_allclose(error_angle_deg(R1, R1), 0.0, atol=1e-6)


def test_error_angle_invariant_to_common_sensor_rotation():
    # the same sensor re-expressed in another sensor frame: R -> R Q^T for both; angle unchanged
    R1, R2 = random_rotations(2, seed=3)
    Q = random_rotations(1, seed=4)[0]
    assert error_angle_deg(R1 @ Q.T, R2 @ Q.T) == pytest.approx(error_angle_deg(R1, R2))


def test_vertical_share():
    about_z = Rotation.from_euler("z", 3, degrees=True).as_matrix()
    about_x = Rotation.from_euler("x", 3, degrees=True).as_matrix()
    assert vertical_share(about_z, np.eye(3)) == pytest.approx(1.0)
    assert vertical_share(about_x, np.eye(3)) == pytest.approx(0.0, abs=1e-12)
    assert np.isnan(vertical_share(np.eye(3), np.eye(3)))


def test_axis_vector():
    np.testing.assert_array_equal(axis_vector("-y"), [0, -1, 0])
    np.testing.assert_array_equal(axis_vector("x"), [1, 0, 0])
    with pytest.raises(ValueError, match="right_axis 'up'"):
        axis_vector("up")


def test_vector_angle_between_unit_vectors_and_their_lines():
    x, y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    tilted = np.array([np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0])
    assert vector_angle_deg(x, tilted) == pytest.approx(30.0)
    assert vector_angle_deg(x, -tilted) == pytest.approx(150.0)
    assert vector_angle_deg(x, -tilted, sign_free=True) == pytest.approx(30.0)
    assert vector_angle_deg(x, y) == pytest.approx(90.0)
    # stacks broadcast; a common rotation leaves the angle; a vector that is not finite gives NaN
    R = random_rotations(1, seed=3)[0]
    stack = vector_angle_deg(np.stack([x, x]) @ R.T, np.stack([tilted, y]) @ R.T)
    np.testing.assert_allclose(stack, [30.0, 90.0])
    assert np.isnan(vector_angle_deg(x, np.full(3, np.nan)))


def test_random_rotations_are_proper_and_reproducible_from_a_seed():
    R = random_rotations(50, seed=3)
    assert R.shape == (50, 3, 3) and np.allclose(np.linalg.det(R), 1.0)
    np.testing.assert_array_equal(R, random_rotations(50, seed=3))
    np.testing.assert_array_equal(R, Rotation.random(50, random_state=3).as_matrix())
    assert not np.allclose(R, random_rotations(50, seed=4))
