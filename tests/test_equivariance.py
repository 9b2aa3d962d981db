"""Every calibration method under a known sensor rotation (issue 44): rotating a sensor's
recordings by Q (``d_sensor' = Q d_sensor``) must turn its calibration R (sensor -> body,
``d_body = R d_sensor``) into ``R Q^T``, for every method of the registry, its bootstrap
resamples, and the peers (run in their own environments). A method that mixed up R and R^T, or
read a sensor axis where it should read a body one, fails this whatever the data.

The methods are reached through one adapter, :func:`calibrations` (the registry's classes,
fitted in their order), and the units are built and turned by :func:`sensor_unit` and
:func:`rotated` (the sufficient statistics as :mod:`aceval.methods.sufficient` declares them)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.methods import registry
from aceval.methods.step_harmonic import STEP_SCATTER
from aceval.methods.sufficient import Units, pool

from .synthetic import pitch_motion

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


def body_unit(seed: int, n_reps: int = 3):
    """Per repetition, in the body frame (x forward, y right, z down): Kong's acceleration scatter
    of a sagittal movement with some out-of-plane motion, the unit gyroscope scatter about y with
    some spread, and the step-band scatter mostly forward; all perturbed by ``seed`` so that no
    method's answer is exactly the mounting."""
    rng = np.random.default_rng(seed)
    scatters, unit_scatters, steps = [], [], []
    for rep in range(n_reps):
        acc = pitch_motion(n=300, seed=seed + rep) + rng.normal(0, 0.3, (300, 3))
        scatters.append(acc.T @ acc)
        spin = rng.normal(0, 0.25, (200, 3)) + [0.0, 1.0, 0.0]
        spin *= rng.choice([-1.0, 1.0], (200, 1))
        spin /= np.linalg.norm(spin, axis=1, keepdims=True)
        unit_scatters.append(spin.T @ spin)
        band = rng.normal(0, 1, (200, 3)) * [1.0, 0.35, 0.3]
        steps.append(band.T @ band)
    down = np.array([0.0, 0.0, 1.0]) + rng.normal(0, 0.02, 3)
    right = np.array([0.0, 1.0, 0.0]) + rng.normal(0, 0.2, 3)  # a declared axis, roughly right
    return down / np.linalg.norm(down), right, scatters, unit_scatters, steps


def sensor_unit(body, mounting: np.ndarray, step_disagrees: bool = False) -> Units:
    """The body-frame unit seen by a sensor mounted with ``mounting`` (sensor -> body), a walking
    test (its step-band scatters too, at a step frequency of 1.8 Hz)."""
    down, right, scatters, unit_scatters, steps = body
    M = mounting
    units = Units.of_repetitions(
        M.T @ down,
        M.T @ right,
        [M.T @ S @ M for S in scatters],
        [300] * len(scatters),
        [M.T @ U @ M for U in unit_scatters],
        rho_static=0.95,
        first_phase="gait",
        segment="thigh",
    )
    n = len(steps)
    walking = {
        "steps": np.stack([M.T @ H @ M for H in steps])[None],
        "step_hz": np.full((1, n), 1.8),
        "step_disagrees": np.full((1, n), float(step_disagrees)),
    }
    statistics = (*units.statistics, STEP_SCATTER)
    return Units(**{**units.__dict__, "statistics": statistics, "values": units.values | walking})


def rotated(units: Units, Q: np.ndarray) -> Units:
    """The same unit after turning the sensor by Q: every sensor-frame statistic rotated (each
    part by its declared shape: a vector Q v, a 3x3 scatter Q S Q^T)."""
    shapes = {name: part.shape for s in units.statistics for name, part in s.parts.items()}
    turn = {(3,): lambda v: v @ Q.T, (3, 3): lambda S: Q @ S @ Q.T}
    values = {k: turn.get(shapes.get(k), lambda x: x)(v) for k, v in units.values.items()}
    return Units(
        **{**units.__dict__, "z0": units.z0 @ Q.T, "right": units.right @ Q.T, "values": values}
    )


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
    """Noise-free statistics of a known mounting: every method gives it back (a check of the
    adapter and of the case; the equivariance below is the test)."""
    mounting = Rotation.from_euler("zyx", [30, -20, 110], degrees=True).as_matrix()
    rng = np.random.default_rng(0)
    spin = np.tile([0.0, 1.0, 0.0], (50, 1)) * rng.choice([-1.0, 1.0], (50, 1))
    acc = pitch_motion(n=300)
    body = (
        np.array([0.0, 0.0, 1.0]),
        np.array([0.1, 1.0, 0.0]),
        [acc.T @ acc] * 3,
        [spin.T @ spin + 1e-3 * np.eye(3)] * 3,
        [np.diag([1.0, 0.1, 0.0])] * 3,
    )
    found = calibrations(sensor_unit(body, mounting), ROWS)
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
    units = sensor_unit(body_unit(seed), Rotation.from_quat(mounting).as_matrix())
    before = calibrations(units, rows, resample=resample)
    assert_equivariant(before, calibrations(rotated(units, Q), rows, resample=resample), Q)


@settings(max_examples=10, deadline=None)
@given(mounting=quaternions, turn=quaternions, seed=st.integers(0, 2**16))
def test_every_methods_resamples_turn_with_the_sensor(mounting, turn, seed):
    """The bootstrap resamples behind the uncertainty: the same draws, rotated."""
    turned_by(mounting, turn, seed, RESAMPLES, resample=True)


def test_a_method_reading_r_transposed_would_fail_this():
    """The property has teeth: R^T instead of R (a classic slip) breaks it for a generic turn."""
    M = Rotation.from_euler("zyx", [40, 10, -70], degrees=True).as_matrix()
    Q = Rotation.from_euler("xyz", [25, -60, 15], degrees=True).as_matrix()
    units = sensor_unit(body_unit(3), M)
    R = calibrations(units, ROWS)["kong"][0]
    R_after = calibrations(rotated(units, Q), ROWS)["kong"][0]
    assert error_angle_deg(R_after, R @ Q.T).max() < 1e-7
    assert error_angle_deg(np.swapaxes(R_after, 1, 2), np.swapaxes(R, 1, 2) @ Q.T).min() > 1.0
    assert error_angle_deg(R_after, Q @ R).min() > 1.0


def test_the_combined_heading_lies_between_kongs_and_the_gyroscopes():
    """The gyroscope spins about an axis turned 15 deg about the vertical from the plane's normal:
    TRIAD (z0, then the gyroscope axis) and Kong disagree by 15 deg of heading, and the combined
    heading, a weighted mean of the two, lies strictly between them on the same great circle."""
    turn = Rotation.from_euler("z", 15, degrees=True).as_matrix()
    down, right, scatters, unit_scatters, steps = body_unit(11)
    body = (down, right, scatters, [turn @ U @ turn.T for U in unit_scatters], steps)
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
    down, right, scatters, unit_scatters, steps = body_unit(2)
    body = (down, right, [np.eye(3) * np.trace(S) / 3 for S in scatters], unit_scatters, steps)
    found = calibrations(sensor_unit(body, np.eye(3)), ROWS[:1])
    assert found["kong"][1][0] != ""
    assert error_angle_deg(found["combined"][0][0], found["triad"][0][0]) < 1e-9


def test_the_step_harmonic_heading_says_when_the_recordings_disagree_on_the_step():
    units = sensor_unit(body_unit(4), np.eye(3), step_disagrees=True)
    flag = calibrations(units, ROWS[:1])["step_harmonic"][1][0]
    assert "step_frequency_disagrees" in flag.split(";")
