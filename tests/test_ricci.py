import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.errors import AlignedAxesError, NonFiniteError, TooFewAxesError, TooFewSamplesError
from aceval.methods import functional_axis, lm_fit, wahba_fit
from aceval.methods.ricci import _residual_jacobian, quaternion_matrix
from aceval.methods.triad import triad


def angle_between(r1: Rotation, r2: Rotation) -> float:
    return float((r1 * r2.inv()).magnitude())


def test_quaternion_matrix_is_eq8_and_matches_scipy():
    for seed in range(5):
        rotation = Rotation.random(random_state=seed)
        q = rotation.as_quat(scalar_first=True)
        np.testing.assert_allclose(quaternion_matrix(q), rotation.as_matrix(), atol=1e-12)


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(0)
    v_est = rng.normal(size=(3, 3))
    q = rng.normal(size=4)  # not unit: the LM differentiates the quadratic form of Eq. 8

    def residual(q):
        return (-(v_est @ quaternion_matrix(q).T)).ravel()

    h = 1e-6
    numeric = np.column_stack(
        [(residual(q + h * e) - residual(q - h * e)) / (2 * h) for e in np.eye(4)]
    )
    np.testing.assert_allclose(_residual_jacobian(q, v_est), numeric, atol=1e-7)


def test_rho_is_one_for_perfect_single_axis_rotation():
    axis = np.array([0.3, -0.5, 0.81])
    axis /= np.linalg.norm(axis)
    t = np.linspace(0, 4 * np.pi, 500)
    gyr = np.outer(2.0 * np.sin(t) + 0.01, axis)  # back and forth about one axis
    estimate = functional_axis(gyr)
    assert estimate.rho == pytest.approx(1.0, abs=1e-9)
    assert abs(estimate.axis @ axis) == pytest.approx(1.0, abs=1e-12)


def test_rho_tends_to_one_third_for_isotropic_data():
    rng = np.random.default_rng(0)
    assert functional_axis(rng.normal(size=(200_000, 3))).rho == pytest.approx(1 / 3, abs=0.005)


def test_axis_sign_is_deterministic():
    # static posture: the axis points along the measured vector
    rng = np.random.default_rng(1)
    g = np.array([0.2, -9.7, 1.0])
    samples = g + rng.normal(0, 0.05, (100, 3))
    estimate = functional_axis(samples)
    assert estimate.axis @ g > 0
    # and it is the same for the negated data's negation: the sign rule depends on data, not on SVD
    assert np.allclose(functional_axis(-samples).axis, -estimate.axis)


def test_functional_axis_bad_input():
    with pytest.raises(TooFewSamplesError):
        functional_axis(np.zeros((50, 3)))  # all samples zero-length: nothing to normalise
    bad = np.ones((10, 3))
    bad[3, 0] = np.nan
    with pytest.raises(NonFiniteError):
        functional_axis(bad)


def test_lm_recovers_exact_rotation_from_identity_and_random_starts():
    v_ref = np.eye(3)
    for seed in range(50):
        truth = Rotation.random(random_state=seed)
        v_est = truth.inv().apply(v_ref)  # the body axes seen in the sensor frame
        for q0 in [
            (1, 0, 0, 0),
            Rotation.random(random_state=1000 + seed).as_quat(scalar_first=True),
        ]:
            result = lm_fit(v_ref, v_est, [0.98, 0.79, 0.78], q0_wxyz=q0)
            assert result.converged
            assert angle_between(result.rotation, truth) < 1e-6
            assert (
                angle_between(result.rotation, wahba_fit(v_ref, v_est, [0.98, 0.79, 0.78])) < 1e-6
            )
            np.testing.assert_array_less(result.residual_angle_after_deg, 1e-4)


def test_lm_matches_align_vectors_on_noisy_axes():
    """With inconsistent (noisy) axes Eq. 9-10 take an unconstrained Gauss-Newton step and then
    renormalise; its fixed point is close to, not exactly at, the constrained optimum. Measured:
    <= 3e-7 rad at 0.03 noise with a tight stop; the paper's stop (1e-4) leaves <= 2e-5 rad."""
    rng = np.random.default_rng(0)
    for seed in range(50):
        truth = Rotation.random(random_state=seed)
        v_est = truth.inv().apply(np.eye(3)) + 0.03 * rng.normal(size=(3, 3))
        weights = rng.uniform(0.5, 1.0, 3)
        q0 = (
            (1, 0, 0, 0)
            if seed % 2
            else Rotation.random(random_state=99 + seed).as_quat(scalar_first=True)
        )
        closed_form = wahba_fit(np.eye(3), v_est, weights)
        tight = lm_fit(np.eye(3), v_est, weights, q0_wxyz=q0, rel_tol=1e-12, max_iter=500)
        assert angle_between(tight.rotation, closed_form) < 1e-6
        default = lm_fit(np.eye(3), v_est, weights, q0_wxyz=q0)
        assert angle_between(default.rotation, closed_form) < 1e-4


def test_lm_weights_pull_towards_reliable_axes():
    # two conflicting estimates of the same reference axis: the heavier one wins
    # (the third axis, z, is the tilt's own axis, so it takes neither side)
    v_ref = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 0, 1.0]])
    tilt = Rotation.from_euler("z", 10, degrees=True)
    v_est = np.array([[1.0, 0, 0], tilt.apply([1.0, 0, 0]), [0, 0, 1.0]])
    a = lm_fit(v_ref, v_est, [1.0, 0.1, 1.0])
    b = lm_fit(v_ref, v_est, [0.1, 1.0, 1.0])
    assert a.residual_angle_after_deg[0] < a.residual_angle_after_deg[1]
    assert b.residual_angle_after_deg[1] < b.residual_angle_after_deg[0]
    # the weighted optimum splits the 10 deg in inverse proportion to the weights (small angles)
    assert a.residual_angle_after_deg[0] == pytest.approx(10 * 0.1 / 1.1, abs=0.05)


def test_lm_reports_history():
    truth = Rotation.from_euler("xyz", [20, -40, 70], degrees=True)
    result = lm_fit(np.eye(3), truth.inv().apply(np.eye(3)))
    assert len(result.cost_history) == result.n_iterations + 1
    assert result.quaternion_history.shape == (result.n_iterations + 1, 4)
    np.testing.assert_allclose(result.quaternion_history[0], [1, 0, 0, 0])
    assert result.cost_history[-1] < result.cost_history[0]
    np.testing.assert_array_less(0, result.residual_angle_before_deg)


def test_lm_needs_two_axes():
    with pytest.raises(TooFewAxesError, match="at least 2"):
        lm_fit([[1, 0, 0]], [[0, 1, 0]])


def test_triad_keeps_primary_exactly_and_recovers_rotation():
    for seed in range(20):
        truth = Rotation.random(random_state=seed).as_matrix()
        v_ref = np.array([[0, 0, 1.0], [0, 1.0, 0]])
        v_est = v_ref @ truth  # row-wise truth^T v: body axes in the sensor frame
        R = triad(v_ref, v_est)
        np.testing.assert_allclose(R, truth, atol=1e-12)
    # with a noisy secondary axis the primary stays exact
    v_est_noisy = v_est + [[0, 0, 0], [0.1, -0.05, 0.02]]
    R = triad(v_ref, v_est_noisy)
    np.testing.assert_allclose(R @ v_est_noisy[0], v_ref[0], atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_triad_bad_input():
    with pytest.raises(TooFewAxesError):
        triad([[0, 0, 1.0]], [[0, 0, 1.0]])
    with pytest.raises(AlignedAxesError, match="deg apart"):
        triad([[0, 0, 1.0], [0, 1.0, 0]], [[0, 0, 1.0], [0, 0.01, 1.0]])


def test_adaptive_damping_follows_hartley_zisserman_worked_by_hand():
    """Two nearly parallel measured axes from a far start: the Gauss-Newton step overshoots. Each
    trial is recomputed here from Eq. 5-10 on the sphere, with a finite-difference Jacobian along
    the tangent basis: a step that lowers the cost is taken and lambda divided by 10 (not below
    MIN_DAMPING), one that raises it is refused (the estimate stays) and lambda multiplied by 10
    (Hartley & Zisserman, App. A6)."""
    from aceval.methods.ricci import MIN_DAMPING, tangent_basis

    v_ref, v_est, weights, q0 = REJECTION_CASE
    fit = lm_fit(v_ref, v_est, weights, q0_wxyz=q0)

    unit_ref = v_ref / np.linalg.norm(v_ref, axis=1, keepdims=True)
    unit_est = v_est / np.linalg.norm(v_est, axis=1, keepdims=True)
    W = np.repeat(weights, 3)

    def residual(q):
        return (unit_ref - unit_est @ quaternion_matrix(q).T).ravel()

    def cost(q):
        return residual(q) @ (W * residual(q))

    def trial_step(q, lam):
        B = tangent_basis(q)
        J = np.column_stack([(residual(q + h) - residual(q - h)) / 2e-7 for h in 1e-7 * B.T])
        JtWJ = (J.T * W) @ J
        delta = np.linalg.solve(JtWJ + lam * np.diag(np.diag(JtWJ)), (J.T * W) @ residual(q))
        new = q - B @ delta
        return new / np.linalg.norm(new)

    q, lam, expected = q0 / np.linalg.norm(q0), 1e-3, []
    for _ in range(8):
        candidate = trial_step(q, lam)
        accepted = cost(candidate) <= cost(q)
        expected.append((lam, accepted))
        q, lam = (candidate, max(lam / 10, MIN_DAMPING)) if accepted else (q, lam * 10)
    assert [a for _, a in expected] == [True, True, False, False, True, True, True, True]
    np.testing.assert_allclose(fit.damping_history[:8], [lam for lam, _ in expected])
    assert list(fit.trial_accepted[:8]) == [a for _, a in expected]
    assert np.all(np.diff(fit.cost_history) <= 0)  # a refused step never moves the estimate
    assert fit.n_rejected > 0

    fixed = lm_fit(v_ref, v_est, weights, q0_wxyz=q0, adaptive=False)
    assert fixed.trial_accepted.all() and set(fixed.damping_history) == {1e-3}
    optimum = cost(wahba_fit(v_ref, v_est, weights).as_quat(scalar_first=True))
    assert optimum <= fit.cost < fixed.cost  # the fixed rule, taking every step, stalls higher
    assert fit.converged and not fixed.converged  # and says so


REJECTION_CASE = (
    np.array([[0.213, 0.783, -1.343], [-0.431, 0.261, -0.018]]),
    np.array([[-0.192, -0.666, -0.258], [-0.774, -2.422, -1.195]]),
    np.array([0.668, 0.625]),
    np.array([0.262, 0.85, -0.201, 0.41]),
)


def perturbed_copies(indices) -> tuple[np.ndarray, np.ndarray]:
    """The rejection case's 125 perturbed copies (axes + N(0, 0.05), weights x U(0.8, 1.2), start
    + N(0, 0.1)), those at ``indices`` fitted: each one's distance (deg) from the closed-form
    optimum of its axes, and whether LM called it converged."""
    v_ref, v_est, weights, q0 = REJECTION_CASE
    rng = np.random.default_rng(0)
    copies = []
    for _ in range(125):  # drawn in this order: axes, weights, start
        noisy, w = v_est + rng.normal(0, 0.05, v_est.shape), weights * rng.uniform(0.8, 1.2, 2)
        copies.append((noisy, w, q0 + rng.normal(0, 0.1, 4)))
    distances, converged = [], []
    for noisy, w, start in (copies[k] for k in indices):
        run = lm_fit(v_ref, noisy, w, q0_wxyz=start)
        distances.append(np.degrees(angle_between(run.rotation, wahba_fit(v_ref, noisy, w))))
        converged.append(run.converged)
    return np.array(distances), np.array(converged)


def test_converged_means_at_the_optimum_on_the_rejection_case_and_a_sample_of_its_copies():
    """Issue 27 (the slow test below fits all 125 copies): the case reaches the optimum; of a
    sample of its perturbed copies (two typical ones, one of the two that stop unconverged 87-91
    deg off, and the converged one farthest from the optimum, 0.015 deg), those called converged
    are at it."""
    v_ref, v_est, weights, q0 = REJECTION_CASE
    fit = lm_fit(v_ref, v_est, weights, q0_wxyz=q0)
    assert fit.converged and angle_between(fit.rotation, wahba_fit(v_ref, v_est, weights)) < 1e-5
    distances, converged = perturbed_copies([0, 19, 50, 96])
    assert (distances[converged] < 0.05).all()


@pytest.mark.slow  # 125 LM fits (17 s); the quick tier fits a sample
def test_converged_means_at_the_optimum_on_the_rejection_case_and_its_perturbed_copies():
    """Issue 27: Eq. 9's step in 4-D quaternion space, normalised, stalled 5.9 deg from the
    closed-form optimum on this case and was reported converged (65 of 125 perturbed copies ended
    > 0.5 deg away, all 'converged'). On the sphere: the case reaches the optimum, and a copy that
    does not is not called converged."""
    v_ref, v_est, weights, q0 = REJECTION_CASE
    fit = lm_fit(v_ref, v_est, weights, q0_wxyz=q0)
    assert fit.converged and angle_between(fit.rotation, wahba_fit(v_ref, v_est, weights)) < 1e-5
    distances, converged = perturbed_copies(range(125))
    # converged: at the optimum (measured: at most 0.015 deg; 2 of 125 not converged, 87-91 deg off)
    assert (distances[converged] < 0.05).all()
    assert converged.mean() > 0.95


def batched_and_single_fits(indices) -> None:
    """lm_fit_batch of 60 problems far from the identity start, a third of them with nearly
    parallel axes (rejections), against lm_fit of those at ``indices``."""
    from aceval.methods.ricci import lm_fit_batch

    rng = np.random.default_rng(3)
    v_ref = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    axes = rng.standard_normal((60, 3))
    angles = np.radians(rng.uniform(0.0, 179.0, 60))  # far from the identity start
    truth = Rotation.from_rotvec(axes / np.linalg.norm(axes, axis=1)[:, None] * angles[:, None])
    v_est = np.einsum("bji,nj->bni", truth.as_matrix(), v_ref) + 0.2 * rng.standard_normal(
        (60, 2, 3)
    )
    v_est[::3, 1] = v_est[::3, 0] + 0.08 * rng.standard_normal(
        (20, 3)
    )  # nearly parallel: rejections
    weights = rng.uniform(0.3, 1.0, (60, 2))
    batch = lm_fit_batch(v_ref, v_est, weights)
    for k in indices:
        single = lm_fit(v_ref, v_est[k], weights[k])
        slack = max(2, 0.05 * single.n_iterations)
        assert abs(batch.n_iterations[k] - single.n_iterations) <= slack
        assert abs(batch.n_rejected[k] - single.n_rejected) <= slack
        assert batch.converged[k] == single.converged
        if single.converged:
            assert angle_between(Rotation.from_matrix(batch.R[k]), single.rotation) < 1e-4
    assert batch.n_rejected.sum() > 0 and len(set(batch.n_iterations)) > 3


def test_batched_lm_takes_the_single_fits_steps_on_a_sample():
    """As the slow test below, on a sample: problems 0 and 10 (with and without nearly parallel
    axes), 42 (a slow stall) and 54 (stops unconverged)."""
    batched_and_single_fits([0, 10, 42, 54])


@pytest.mark.slow  # 60 single LM fits (3 s); the quick tier compares a sample
def test_batched_lm_takes_the_single_fits_steps():
    """lm_fit_batch (the Obj 4 subsets of one IMU at once) = lm_fit of each problem: the same
    steps and verdict; the stopping step may differ by a few where the gradient sits at the limit
    within rounding (on a slow stall, each step changes it little: problem 42 stops after 89
    single steps and 92 batched on an AVX-512 machine, within 2 on an AVX2 one)."""
    batched_and_single_fits(range(60))


def test_batched_jacobian_is_the_single_one_per_problem():
    rng = np.random.default_rng(5)
    q, v_est = rng.standard_normal((4, 4)), rng.standard_normal((4, 3, 3))
    stacked = _residual_jacobian(q, v_est)
    for k in range(4):
        np.testing.assert_allclose(stacked[k], _residual_jacobian(q[k], v_est[k]), atol=1e-15)
