"""Every calibration method under a known sensor rotation (issue 44): rotating a sensor's
recordings by Q (``d_sensor' = Q d_sensor``) must turn its calibration R (sensor -> body,
``d_body = R d_sensor``) into ``R Q^T``, for every method of the registry, its bootstrap
resamples, and the peers (run in their own environments). A method that mixed up R and R^T, or
read a sensor axis where it should read a body one, fails this whatever the data.

The methods are reached through one adapter, :func:`calibrations` (the registry's classes,
fitted in their order), and the units are built and turned by :func:`sensor_unit` and
:func:`turned`: samples reduced by every statistic the registry declares, by its own ``reduce``
(a new method's statistic reaches this test with no edit here)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.methods import registry
from aceval.methods.sufficient import Units, pool

from .synthetic import G

# --- the adapter: a unit's repetitions in, each method's rotation out ---------------------------


def calibrations(units: Units, weights, resample: bool = False) -> dict[str, tuple]:
    """``{method: (R (B, 3, 3), flag (B,))}`` of every method of the registry (each after the ones
    it needs) on the rows ``weights`` (B, R) of the single unit ``units``; with ``resample``, the
    bootstrap resamples of the methods that have them."""
    weights = np.atleast_2d(np.asarray(weights, float))
    pooled = pool(units, np.zeros(len(weights), int), weights, subsets=not resample)
    classes = registry.classes()
    fitted = {}
    for name in registry.fit_order(classes):
        method = classes[name]()
        if resample and not classes[name].has_resample():
            continue
        fitted[name] = (method.resample if resample else method.fit)(pooled, fitted)
    return {name: (fit.rotation_, fit.flag_) for name, fit in fitted.items()}


def expected_methods(resample: bool) -> set[str]:
    return {n for n, c in registry.classes().items() if c.has_resample() or not resample}


# --- a walking unit known in the body frame ---------------------------------------------------

#: the samples' rate (Hz)
FS = 100.0


def walking_leg(n: int, step_hz: float, phase: float, rng=None) -> tuple[np.ndarray, np.ndarray]:
    """One repetition of a leg walking, in the body frame (x forward, y right, z down): the
    specific force (m/s^2) of a segment swinging about y at the stride frequency with a forward
    surge and a vertical bounce at the step frequency, and its angular velocity (rad/s) about y;
    with ``rng``, a sideways sway and noise on both (out-of-plane motion, a spread axis)."""
    t = np.arange(n) / FS
    stride, step = 2 * np.pi * step_hz / 2, 2 * np.pi * step_hz
    theta = 0.5 * np.sin(stride * t + phase)
    acc = np.column_stack(
        [
            G * np.sin(theta) + 2.0 * np.sin(step * t),
            np.zeros(n),
            -G * np.cos(theta) + 1.5 * np.sin(step * t),
        ]
    )
    gyr = np.column_stack([np.zeros(n), 0.5 * stride * np.cos(stride * t + phase), np.zeros(n)])
    if rng is not None:
        acc[:, 1] += 0.4 * np.cos(stride * t + phase)  # in quadrature with the swing
        acc += rng.normal(0, 0.3, (n, 3))
        gyr += rng.normal(0, 0.3, (n, 3))
    return acc, gyr


def body_unit(seed: int, n_reps: int = 3, step_hz=(1.8, 1.85, 1.78)):
    """Per repetition, in the body frame: the samples of :func:`walking_leg` (one step frequency
    per repetition), perturbed by ``seed`` (None: noise-free) so that no method's answer is
    exactly the mounting; the downward vertical and a declared right axis, roughly right."""
    rng = None if seed is None else np.random.default_rng(seed)
    samples = [walking_leg(400 + 37 * rep, step_hz[rep], 0.3 * rep, rng) for rep in range(n_reps)]
    if rng is None:
        return np.array([0.0, 0.0, 1.0]), np.array([0.1, 1.0, 0.0]), samples
    down = np.array([0.0, 0.0, 1.0]) + rng.normal(0, 0.02, 3)
    right = np.array([0.0, 1.0, 0.0]) + rng.normal(0, 0.2, 3)  # a declared axis, roughly right
    return down / np.linalg.norm(down), right, samples


def sensor_unit(body, mounting: np.ndarray) -> Units:
    """The body-frame unit seen by a sensor mounted with ``mounting`` (sensor -> body) in a walking
    test, reduced by every statistic the registry's methods declare (their own ``reduce``)."""
    down, right, samples = body
    M = mounting
    return Units.of_samples(
        M.T @ down,
        M.T @ right,
        [(acc @ M, gyr @ M) for acc, gyr in samples],
        FS,
        registry.statistics(),
        rho_static=0.95,
        first_phase="gait",
        segment="thigh",
    )


def turned(body, mounting: np.ndarray, Q: np.ndarray) -> Units:
    """The same unit after turning the sensor by Q (``d_sensor' = Q d_sensor``: the mounting
    becomes ``M Q^T``), its samples reduced again."""
    return sensor_unit(body, mounting @ Q.T)


#: every row kind a method sees: all repetitions, single repetitions, a pair
ROWS = [[1, 1, 1], [1, 0, 0], [0, 1, 0], [0, 1, 1]]
#: bootstrap resamples of the three repetitions (counts)
RESAMPLES = [[2, 1, 0], [0, 0, 3], [1, 1, 1]]
#: how close R' and R Q^T must be (deg): the closed forms to rounding; Ricci's LM stops at its
#: own tolerance, from a start that does not turn with the sensor (at most 6e-5 deg in 150 cases)
TOLERANCE_DEG = {"ricci_lm": 1e-3}

quaternions = st.tuples(*[st.floats(-1, 1) for _ in range(4)]).filter(
    lambda q: np.linalg.norm(q) > 0.1
)


def assert_equivariant(before: dict, after: dict, Q: np.ndarray) -> None:
    assert set(before) in (expected_methods(False), expected_methods(True))
    for name, (R, flag) in before.items():
        R_after, flag_after = after[name]
        assert flag.tolist() == flag_after.tolist(), name
        finite = np.isfinite(R).all(axis=(1, 2))
        assert (finite == np.isfinite(R_after).all(axis=(1, 2))).all(), name
        assert finite.any(), f"{name} calibrated nothing: the case tests nothing"
        angle = error_angle_deg(R_after[finite], R[finite] @ Q.T)
        assert angle.max() < TOLERANCE_DEG.get(name, 1e-7), (name, angle.max())


def test_the_adapter_reaches_every_method_and_each_recovers_a_known_mounting():
    """Noise-free samples of a known mounting: every method gives it back (a check of the
    adapter and of the case; the equivariance below is the test)."""
    mounting = Rotation.from_euler("zyx", [30, -20, 110], degrees=True).as_matrix()
    found = calibrations(sensor_unit(body_unit(None), mounting), ROWS)
    assert set(found) == set(registry.own())
    for name, (R, flag) in found.items():
        assert (flag == "").all(), (name, flag)
        assert error_angle_deg(R, mounting).max() < 1e-6, name


@settings(max_examples=25, deadline=None)
@given(mounting=quaternions, turn=quaternions, seed=st.integers(0, 2**16))
def test_every_method_turns_with_the_sensor(mounting, turn, seed):
    turned_by(mounting, turn, seed, ROWS, resample=False)


def turned_by(mounting, turn, seed, rows, resample: bool) -> None:
    """A unit of mounting and noise ``seed`` before and after the turn: R' = R Q^T."""
    Q = Rotation.from_quat(turn).as_matrix()
    body, M = body_unit(seed), Rotation.from_quat(mounting).as_matrix()
    before = calibrations(sensor_unit(body, M), rows, resample=resample)
    assert_equivariant(before, calibrations(turned(body, M, Q), rows, resample=resample), Q)


@settings(max_examples=10, deadline=None)
@given(mounting=quaternions, turn=quaternions, seed=st.integers(0, 2**16))
def test_every_methods_resamples_turn_with_the_sensor(mounting, turn, seed):
    """The bootstrap resamples behind the uncertainty: the same draws, rotated."""
    turned_by(mounting, turn, seed, RESAMPLES, resample=True)


def test_a_method_reading_r_transposed_would_fail_this():
    """The property has teeth: R^T instead of R (a classic slip) breaks it for a generic turn."""
    M = Rotation.from_euler("zyx", [40, 10, -70], degrees=True).as_matrix()
    Q = Rotation.from_euler("xyz", [25, -60, 15], degrees=True).as_matrix()
    body = body_unit(3)
    R = calibrations(sensor_unit(body, M), ROWS)["kong"][0]
    R_after = calibrations(turned(body, M, Q), ROWS)["kong"][0]
    assert error_angle_deg(R_after, R @ Q.T).max() < 1e-7
    assert error_angle_deg(np.swapaxes(R_after, 1, 2), np.swapaxes(R, 1, 2) @ Q.T).min() > 1.0
    assert error_angle_deg(R_after, Q @ R).min() > 1.0


def test_the_combined_heading_lies_between_kongs_and_the_gyroscopes():
    """The gyroscope spins about an axis turned 15 deg about the vertical from the plane's normal:
    TRIAD (z0, then the gyroscope axis) and Kong disagree by 15 deg of heading, and the combined
    heading, a weighted mean of the two, lies strictly between them on the same great circle."""
    turn = Rotation.from_euler("z", 15, degrees=True).as_matrix()
    down, right, samples = body_unit(11)
    body = (down, right, [(acc, gyr @ turn.T) for acc, gyr in samples])
    found = calibrations(sensor_unit(body, np.eye(3)), ROWS[:1])
    kong, triad, combined = (found[name][0][0] for name in ("kong", "triad", "combined"))
    apart = float(error_angle_deg(kong, triad))
    to_kong, to_triad = (
        float(error_angle_deg(combined, kong)),
        float(error_angle_deg(combined, triad)),
    )
    assert 12.0 < apart < 18.0 and min(to_kong, to_triad) > 1.0
    assert to_kong + to_triad == pytest.approx(apart, abs=0.5)


def test_a_resample_of_every_repetition_once_is_the_calibration_itself():
    """The bootstrap's resamples are calibrated as the method calibrates: weights 1, 1, 1 give
    each method's own calibration from all repetitions (Ricci's resamples are the closed-form
    optimum its LM reaches to within 0.01 deg)."""
    units = sensor_unit(body_unit(7), Rotation.random(random_state=7).as_matrix())
    fitted = calibrations(units, ROWS[:1])
    resampled = calibrations(units, [[1, 1, 1]], resample=True)
    assert set(resampled) == set(fitted)
    for name, (R, _) in resampled.items():
        tolerance = 0.01 if name == "ricci_lm" else 1e-9
        assert error_angle_deg(R[0], fitted[name][0][0]) < tolerance, name


def test_a_flagged_kong_plane_leaves_the_combined_heading_to_the_gyroscope():
    """Accelerations in no plane (Kong flags not_planar): the combined heading is the
    gyroscope's alone, TRIAD's with z0 kept."""
    down, right, samples = body_unit(2)
    rng = np.random.default_rng(2)
    shaken = [(rng.normal(0, 5.0, acc.shape), gyr) for acc, gyr in samples]  # in no plane
    body = (down, right, shaken)
    found = calibrations(sensor_unit(body, np.eye(3)), ROWS[:1])
    assert found["kong"][1][0] != ""
    assert error_angle_deg(found["combined"][0][0], found["triad"][0][0]) < 1e-9


def test_the_step_harmonic_heading_says_when_the_recordings_disagree_on_the_step():
    """One repetition walked at another step frequency (2.9 Hz against 1.8): outside the pass
    band of the test's, its recordings disagree on the step."""
    units = sensor_unit(body_unit(4, step_hz=(1.8, 1.82, 2.9)), np.eye(3))
    flag = calibrations(units, ROWS[:1])["step_harmonic"][1][0]
    assert "step_frequency_disagrees" in flag.split(";")
