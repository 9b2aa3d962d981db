"""Ricci et al. 2014: functional axes by SVD, reliability index rho, rho-weighted LM (Sec. 2.2.2-2.2.4).

* :func:`functional_axis`: unit-normalise the samples (Sec. 2.2.2), take the first right singular
  vector as the axis and ``rho = s1 / (s1 + s2 + s3)`` as its reliability (Eq. 1-2).
* :func:`lm_fit`: the rotation ``R`` (sensor frame -> functional/body frame) that minimises the
  weighted cost ``C = e^T W e`` with ``e = v_ref - Q(R) v_est`` (Eq. 3-7), by Levenberg-Marquardt on
  a quaternion (Eq. 8-11): Marquardt's diagonal damping, q0 = identity, lambda = 1e-3 as the start
  of Hartley & Zisserman's adaptive rule (App. A6, which Ricci cites; lambda fixed as an option),
  stop when the relative cost change is below 1e-4, renormalise q after each step.
* The closed-form optimum of the same cost (``Rotation.align_vectors``,
  :mod:`aceval.methods.align_vectors`) is the LM's cross-check: ``optimum_distance_deg``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.data.errors import CalibrationError, check_axes
from aceval.data.rotations import error_angle_deg, vector_angle_deg
from aceval.methods.align_vectors import optimum_resample, wahba_batch, wahba_fit
from aceval.methods.interface import AxisProblem
from aceval.methods.sagittal import SAGITTAL_REFERENCE, AxisMethod, sagittal_axes
from aceval.methods.sufficient import Pooled


@dataclass
class LMResult:
    """Outcome of the rho-weighted LM fit (Ricci Eq. 3-11).

    ``n_iterations`` counts the accepted steps (k of Eq. 9-11); ``n_rejected`` the trial steps that
    raised the cost and were re-solved with more damping (adaptive rule only). ``cost_history`` and
    ``quaternion_history`` hold the start and every accepted step; ``damping_history`` and
    ``trial_accepted`` every trial step; ``gradient_norm`` the cost's gradient on the sphere at the
    end, and ``converged`` whether it is below the fit's ``grad_tol`` (or the fit is exact).
    """

    rotation: Rotation
    quaternion_wxyz: np.ndarray
    n_iterations: int
    converged: bool
    cost_history: np.ndarray
    quaternion_history: np.ndarray
    residual_angle_before_deg: np.ndarray
    residual_angle_after_deg: np.ndarray
    n_rejected: int = 0
    damping_history: np.ndarray | None = None
    trial_accepted: np.ndarray | None = None
    gradient_norm: float = np.nan

    @property
    def R(self) -> np.ndarray:
        """The fitted rotation as a 3x3 matrix (sensor -> functional frame)."""
        return self.rotation.as_matrix()

    @property
    def cost(self) -> float:
        """The final cost C (Eq. 6)."""
        return float(self.cost_history[-1])


def quaternion_matrix(q_wxyz: np.ndarray) -> np.ndarray:
    """Ricci Eq. 8: the quadratic rotation matrix of a (not necessarily unit) quaternion [w x y z]."""
    w, x, y, z = q_wxyz
    return np.array(
        [
            [w * w + x * x - y * y - z * z, 2 * x * y - 2 * z * w, 2 * x * z + 2 * y * w],
            [2 * x * y + 2 * z * w, w * w + y * y - x * x - z * z, 2 * y * z - 2 * x * w],
            [2 * x * z - 2 * y * w, 2 * y * z + 2 * x * w, w * w + z * z - x * x - y * y],
        ]
    )


def _residual_jacobian(q: np.ndarray, v_est: np.ndarray) -> np.ndarray:
    """D e / d q, shape (..., 3N, 4), for e = v_ref - R(q) v_est with R(q) of Eq. 8; ``q`` (..., 4)
    and ``v_est`` (..., N, 3) (one problem, or a stack of them).

    R(q) v = (w^2 - |u|^2) v + 2 (u.v) u + 2 w (u x v), u = (x, y, z); differentiated analytically.
    """
    w, u = q[..., 0, None, None], q[..., None, 1:]  # (..., 1, 1) and (..., 1, 3)
    x, y, z = v_est[..., 0], v_est[..., 1], v_est[..., 2]
    zero = np.zeros_like(x)
    skew_v = np.stack(
        [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)],
        -2,
    )  # (..., N, 3, 3)
    u_dot_v = np.sum(v_est * u, axis=-1)  # (..., N)
    jac = np.empty((*v_est.shape, 4))
    jac[..., 0] = 2 * w * v_est + 2 * np.cross(u, v_est)
    jac[..., 1:] = (
        -2 * v_est[..., :, None] * u[..., None, :]
        + 2 * u[..., :, None] * v_est[..., None, :]
        + 2 * u_dot_v[..., None, None] * np.eye(3)
        - 2 * w[..., None] * skew_v
    )
    return -jac.reshape(*v_est.shape[:-2], -1, 4)


def tangent_basis(q: np.ndarray) -> np.ndarray:
    """Orthonormal basis (..., 4, 3) of the unit sphere's tangent space at the unit quaternion(s)
    ``q`` (..., 4) [w x y z]: the columns q * (0, e_i), each orthogonal to q. A step along them turns
    the rotation (by twice the step's length, rad) without changing |q|.
    """
    w, x, y, z = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack(
        [
            np.stack([-x, -y, -z], -1),
            np.stack([w, -z, y], -1),
            np.stack([z, w, -x], -1),
            np.stack([-y, x, w], -1),
        ],
        -2,
    )


def _sphere_gradient_norm(q: np.ndarray, v_est: np.ndarray, W: np.ndarray, e: np.ndarray):
    """|B^T J^T W e|: the gradient of the LM cost on the sphere at ``q`` (one problem or a stack)."""
    J = _residual_jacobian(q, v_est) @ tangent_basis(q)
    return np.linalg.norm(np.einsum("...ij,...i->...j", J, W * e), axis=-1)


def _residual_angles_deg(v_ref, v_est, R) -> np.ndarray:
    return vector_angle_deg(v_ref, v_est @ R.T)


#: the adaptive rule divides lambda by 10 after an accepted step, but not below this: with lambda
#: -> 0 the steps are Gauss-Newton's, which on two nearly parallel measured axes (tests/test_ricci.py's
#: rejection case) crawl along the poorly determined rotation (341 steps, still 82 deg from the
#: optimum); floored at 1e-6 the same case reaches the optimum (within 1e-4 deg)
MIN_DAMPING = 1e-6
#: the gradient of the LM cost on the sphere below which a fit is converged (the cost is
#: dimensionless, the tangent step in quaternion units): measured, within 0.015 deg of the
#: closed-form optimum on 123 converged perturbed copies of the rejection case (nearly parallel
#: axes, the worst conditioning; tests/test_ricci.py asserts < 1e-6 rad on exact problems)
GRAD_TOL = 1e-6


def lm_fit(
    v_ref,
    v_est,
    weights=None,
    q0_wxyz=(1.0, 0.0, 0.0, 0.0),
    damping: float = 1e-3,
    rel_tol: float = 1e-4,
    max_iter: int = 1000,
    abs_tol: float = 1e-15,
    adaptive: bool = True,
    max_rejections: int = 20,
    grad_tol: float = GRAD_TOL,
) -> LMResult:
    """Rotation R (sensor -> functional frame) with ``v_ref ~ R v_est``, by Ricci's LM (Eq. 3-11).

    Parameters
    ----------
    v_ref, v_est : (N, 3) axes (unit-normalised here), N >= 2.
    weights : (N,) rho of each axis (Eq. 7); default 1.
    q0_wxyz : starting quaternion (Ricci: the identity).
    damping : lambda of Eq. 10 (Ricci: 1e-3, "typical" after Hartley & Zisserman, App. A6).
    rel_tol : stop when ``|C_k - C_k+1| / C_k < rel_tol`` (Eq. 11; Ricci: 1e-4) and the gradient
        on the sphere is below ``grad_tol``, or when the cost is below ``abs_tol`` (an exact fit,
        where the relative change is undefined).
    adaptive : Hartley & Zisserman's rule (App. A6), which Ricci cites: lambda starts at
        ``damping``; a step that lowers the cost is accepted and lambda divided by 10 (not below
        ``MIN_DAMPING``), a step that raises it is rejected and re-solved with lambda multiplied
        by 10. ``False``: lambda stays fixed and every step is taken (Eq. 9-10 read literally).
    max_rejections : stop after this many rejections in a row (no step lowers the cost any more).
    grad_tol : ``converged`` means the gradient of the cost on the sphere, ``|B^T J^T W e|``, is
        below this at the end (``GRAD_TOL``); a fit that stops for any other reason (Eq. 11
        alone, rejections, ``max_iter``) away from it is not.

    Each trial (Eq. 9-10, on the sphere): ``J_B = J B`` with ``B`` the tangent basis at q
    (:func:`tangent_basis`), ``F = J_B^T W J_B + lambda diag(J_B^T W J_B)``,
    ``Delta = F^-1 J_B^T W e``, ``q* = q - B Delta``, ``q = q*/|q*|``. Ricci's Eq. 9 solves for all
    four components of q; normalising then undoes the radial part of the step, and near a stall
    every damped step points uphill along the sphere while the gradient there is not zero (the
    rejection case of tests/test_ricci.py ended 5.9 deg from the optimum, reported converged).
    Steps in the tangent space keep Eq. 9-10's damping and acceptance rule without that defect.
    One fit is :func:`lm_fit_batch` of one problem, its history recorded.
    """
    v_ref, v_est, weights = check_axes(v_ref, v_est, weights)
    q0 = np.asarray(q0_wxyz, dtype=float) / np.linalg.norm(q0_wxyz)
    rule = _Rule(damping, rel_tol, max_iter, abs_tol, adaptive, max_rejections, grad_tol)
    fit, history = _levenberg_marquardt(v_ref, v_est[None], weights[None], q0[None], rule, True)
    rotation = Rotation.from_matrix(fit.R[0])
    return LMResult(
        rotation=rotation,
        quaternion_wxyz=rotation.as_quat(scalar_first=True),
        n_iterations=int(fit.n_iterations[0]),
        converged=bool(fit.converged[0]),
        cost_history=np.array(history["cost"]),
        quaternion_history=np.array(history["q"]),
        residual_angle_before_deg=_residual_angles_deg(v_ref, v_est, quaternion_matrix(q0)),
        residual_angle_after_deg=_residual_angles_deg(v_ref, v_est, rotation.as_matrix()),
        n_rejected=int(fit.n_rejected[0]),
        damping_history=np.array(history["damping"]),
        trial_accepted=np.array(history["accepted"], dtype=bool),
        gradient_norm=float(history["gradient_norm"]),
    )


@dataclass
class LMBatch:
    """:func:`lm_fit_batch`'s outcome, one entry per problem: R (B, 3, 3), accepted steps,
    rejected trial steps, convergence and final cost (as :class:`LMResult`).
    """

    R: np.ndarray
    n_iterations: np.ndarray
    n_rejected: np.ndarray
    converged: np.ndarray
    cost: np.ndarray


@dataclass(frozen=True)
class _Rule:
    """The LM's damping and stopping rule (:func:`lm_fit`'s parameters)."""

    damping: float = 1e-3
    rel_tol: float = 1e-4
    max_iter: int = 1000
    abs_tol: float = 1e-15
    adaptive: bool = True
    max_rejections: int = 20
    grad_tol: float = GRAD_TOL


def _quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """:func:`quaternion_matrix` of each row of ``q`` (B, 4), shape (B, 3, 3)."""
    return np.moveaxis(quaternion_matrix(q.T), (0, 1), (-2, -1))


def lm_fit_batch(
    v_ref,
    v_est,
    weights,
    damping: float = 1e-3,
    rel_tol: float = 1e-4,
    max_iter: int = 1000,
    abs_tol: float = 1e-15,
    max_rejections: int = 20,
    grad_tol: float = GRAD_TOL,
    adaptive: bool = True,
    q0_wxyz: np.ndarray | None = None,
) -> LMBatch:
    """:func:`lm_fit` of B problems at once: ``v_ref`` (n, 3) shared, ``v_est`` (B, n, 3) and
    ``weights`` (B, n) one row per problem (every calibration of a job), each stopping on its own
    rule; ``q0_wxyz`` (B, 4): each problem's start (default: the identity, Ricci's).
    """
    v_ref = np.asarray(v_ref, float)
    v_ref = v_ref / np.linalg.norm(v_ref, axis=-1, keepdims=True)
    v_est = np.asarray(v_est, float)
    v_est = v_est / np.linalg.norm(v_est, axis=-1, keepdims=True)
    weights = np.asarray(weights, float)
    if not (np.isfinite(v_est).all() and np.isfinite(weights).all()):
        raise ValueError("lm_fit_batch: v_est or weights contain NaN or inf")
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(weights), 1)) if q0_wxyz is None else np.array(q0_wxyz)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    rule = _Rule(damping, rel_tol, max_iter, abs_tol, adaptive, max_rejections, grad_tol)
    return _levenberg_marquardt(v_ref, v_est, weights, q, rule, False)[0]


def _levenberg_marquardt(v_ref, v_est, weights, q, rule: _Rule, record: bool):
    """The LM of :func:`lm_fit` on B problems from starts ``q`` (B, 4): ``(LMBatch, history)``,
    the history (``record``, one problem) its costs and quaternions after each accepted step,
    the damping and verdict of each trial and the final gradient norm.
    """
    W = np.repeat(weights, 3, axis=1)  # (B, 3n)
    s = _State.start(v_ref, v_est, W, q, rule)
    history = {"cost": [float(s.cost[0])], "q": [s.q[0].copy()], "damping": [], "accepted": []}
    while s.active.any():
        s.renew(v_ref, v_est, W, rule)
        at = np.flatnonzero(s.active)
        if not len(at):
            break
        if record:
            history["damping"].append(float(s.lam[0]))
        better = s.trial(v_ref, v_est, W, at, rule)
        if record:
            history["accepted"].append(bool(better[0]))
            if better[0]:
                history["cost"].append(float(s.cost[0]))
                history["q"].append(s.q[0].copy())
    history["gradient_norm"] = _sphere_gradient_norm(s.q, v_est, W, s.e)[0] if record else np.nan
    s.converged |= _sphere_gradient_norm(s.q, v_est, W, s.e) <= rule.grad_tol
    q = np.where(s.q[:, :1] < 0, -s.q, s.q)  # the same rotation, canonical sign
    fit = LMBatch(
        R=Rotation.from_quat(q, scalar_first=True).as_matrix(),
        n_iterations=s.n_iter,
        n_rejected=s.n_rejected,
        converged=s.converged,
        cost=s.cost,
    )
    return fit, history if record else None


def _residuals(v_ref, v_est, q) -> np.ndarray:
    """E = v_ref - R(q) v_est of each problem (B, 3n) (Eq. 5)."""
    rotated = v_est @ np.swapaxes(_quaternion_matrices(q), -1, -2)
    return (v_ref[None] - rotated).reshape(len(q), -1)


@dataclass
class _State:
    """Where each problem of :func:`_levenberg_marquardt` stands: its quaternion, residuals and
    cost, damping, counts, and (``stale``) whether its Jacobian must be renewed.
    """

    q: np.ndarray
    e: np.ndarray
    cost: np.ndarray
    lam: np.ndarray
    converged: np.ndarray
    active: np.ndarray
    n_iter: np.ndarray
    n_rejected: np.ndarray
    in_a_row: np.ndarray
    last_change: np.ndarray
    stale: np.ndarray
    JtW: np.ndarray
    JtWJ: np.ndarray
    gradient: np.ndarray

    @classmethod
    def start(cls, v_ref, v_est, W, q, rule: _Rule) -> _State:
        n = len(q)
        e = _residuals(v_ref, v_est, q)
        cost = np.einsum("bi,bi->b", e, W * e)
        converged = cost < rule.abs_tol
        return cls(
            q=q.copy(),
            e=e,
            cost=cost,
            lam=np.full(n, float(rule.damping)),
            converged=converged,
            active=~converged,
            n_iter=np.zeros(n, int),
            n_rejected=np.zeros(n, int),
            in_a_row=np.zeros(n, int),
            last_change=np.full(n, np.inf),
            stale=np.ones(n, bool),
            JtW=np.empty((n, 3, W.shape[1])),
            JtWJ=np.empty((n, 3, 3)),
            gradient=np.empty((n, 3)),
        )

    def renew(self, v_ref, v_est, W, rule: _Rule) -> None:
        """The Jacobian on the sphere of the problems that moved; those at a stationary point
        after a small relative change stop (Eq. 11).
        """
        renew = np.flatnonzero(self.active & self.stale)
        if len(renew):
            J = _residual_jacobian(self.q[renew], v_est[renew]) @ tangent_basis(self.q[renew])
            self.JtW[renew] = np.swapaxes(J, -1, -2) * W[renew, None, :]
            self.JtWJ[renew] = self.JtW[renew] @ J
            self.gradient[renew] = (self.JtW[renew] @ self.e[renew][:, :, None])[:, :, 0]
            done = renew[
                (self.last_change[renew] < rule.rel_tol)
                & (np.linalg.norm(self.gradient[renew], axis=1) <= rule.grad_tol)
            ]
            self.active[done] = False
        self.stale[:] = False

    def trial(self, v_ref, v_est, W, at: np.ndarray, rule: _Rule) -> np.ndarray:
        """One damped step (Eq. 9-10) of the problems ``at``; accepted where it lowers the cost
        (always, without the adaptive rule). Returns, per problem of ``at``, whether it was.
        """
        diagonal = np.eye(3) * np.diagonal(self.JtWJ[at], 0, -2, -1)[:, None]
        F = self.JtWJ[at] + self.lam[at, None, None] * diagonal
        step = np.linalg.solve(F, self.gradient[at][:, :, None])
        trial = self.q[at] - (tangent_basis(self.q[at]) @ step)[:, :, 0]
        trial = trial / np.linalg.norm(trial, axis=1, keepdims=True)
        trial_e = _residuals(v_ref, v_est[at], trial)
        trial_cost = np.einsum("bi,bi->b", trial_e, W[at] * trial_e)
        better = ~((trial_cost > self.cost[at]) & rule.adaptive)
        rejected, accepted = at[~better], at[better]
        self.n_rejected[rejected] += 1
        self.in_a_row[rejected] += 1
        self.lam[rejected] *= 10.0
        given_up = rejected[self.in_a_row[rejected] >= rule.max_rejections]
        self.in_a_row[accepted] = 0
        self.n_iter[accepted] += 1
        self.last_change[accepted] = (
            np.abs(self.cost[accepted] - trial_cost[better]) / self.cost[accepted]
        )
        self.converged[accepted] = trial_cost[better] < rule.abs_tol
        self.q[accepted], self.e[accepted] = trial[better], trial_e[better]
        self.cost[accepted] = trial_cost[better]
        self.stale[accepted] = True
        if rule.adaptive:
            self.lam[accepted] = np.maximum(self.lam[accepted] / 10.0, MIN_DAMPING)
        self.active &= ~self.converged & (self.n_iter < rule.max_iter)
        self.active[given_up] = False
        return better


# --- the method's interface in Kong's protocol (aceval.methods.interface) -----------------------


#: a start "reaches the optimum" when its result is within this angle of the closed-form optimum:
#: Kong's own threshold for a calibration that no longer changes ("after including three
#: repetitions the change ... is less than one degree", Kong et al. 2016, Sec. 3.3)
SAME_SOLUTION_DEG = 1.0


def _distance_deg(R: np.ndarray, optimum: np.ndarray | None) -> float:
    """Angle (deg) between a fitted rotation and the closed-form optimum (NaN without one)."""
    return float("nan") if optimum is None else float(error_angle_deg(R, optimum))


def _optimum_distance_deg(R: np.ndarray, optimum: np.ndarray) -> np.ndarray:
    """Angle (deg) between fitted rotations and the closed-form optima (B, 3, 3 each)."""
    return np.asarray(error_angle_deg(R, optimum), float)


class RicciLM(AxisMethod):
    """Ricci's rho-weighted LM (Eq. 3-11) in Kong's protocol: z0 and the motion test's gyroscope
    axis mapped onto body z and y (:mod:`aceval.methods.sagittal`), with its steps, convergence
    and distance to the closed-form optimum (``n_iterations``, ``n_rejected``, ``converged``,
    ``cost``, ``optimum_distance_deg``; ``fixed_*`` the same with lambda fixed, on the
    calibrations from all repetitions); in Ricci's functional design (:meth:`fit_functional`)
    also how many random starts reach the optimum. The gyroscope's reference in the others' cones.
    """

    diagnostics = (
        "n_iterations",
        "n_rejected",
        "optimum_distance_deg",
        "fixed_n_iterations",
        "fixed_cost",
        "fixed_optimum_distance_deg",
        "fixed_converged",
        "converged",
        "cost",
        "random_starts",
        "random_starts_optimum",
        "random_start_iterations_mean",
        "random_start_iterations_max",
    )
    cone_reference = True

    @classmethod
    def fit_functional(cls, problem: AxisProblem) -> dict:
        """The LM (adaptive damping, Hartley & Zisserman's, as Ricci cites) of the axis pairs: its
        accepted and rejected steps, convergence, final cost, distance to the closed-form optimum
        (deg), the residual angles (deg) before and after; with ``problem.diagnostics`` the same
        for lambda fixed at 1e-3 (``fixed_*``: Eq. 9-10 read literally); with
        ``problem.random_starts``, how many random starts reach the closed-form optimum
        (within :data:`SAME_SOLUTION_DEG`) and their iterations.
        """
        v_ref, v_est, rho = problem.v_ref, problem.v_est, problem.rho
        try:
            optimum = wahba_fit(v_ref, v_est, rho).as_matrix()
        except (CalibrationError, ValueError):
            optimum = None
        fit = lm_fit(v_ref, v_est, rho)
        entry = {
            "R": fit.R,
            "n_iterations": fit.n_iterations,
            "n_rejected": fit.n_rejected,
            "converged": fit.converged,
            "cost": fit.cost,
            "optimum_distance_deg": _distance_deg(fit.R, optimum),
            "residual_before_deg": fit.residual_angle_before_deg,
            "residual_after_deg": fit.residual_angle_after_deg,
        }
        if problem.diagnostics:
            fixed = lm_fit(v_ref, v_est, rho, adaptive=False)
            entry.update(
                fixed_n_iterations=fixed.n_iterations,
                fixed_cost=fixed.cost,
                fixed_converged=fixed.converged,
                fixed_optimum_distance_deg=_distance_deg(fixed.R, optimum),
            )
        if problem.random_starts and optimum is not None:
            n = problem.random_starts
            starts = Rotation.random(n, random_state=problem.seed).as_quat(scalar_first=True)
            runs = lm_fit_batch(
                v_ref,
                np.broadcast_to(v_est, (n, *np.shape(v_est))),
                np.broadcast_to(rho, (n, len(rho))),
                q0_wxyz=starts,
            )
            reached = error_angle_deg(runs.R, optimum) <= SAME_SOLUTION_DEG
            entry.update(
                random_starts=n,
                random_starts_optimum=int(np.sum(reached)),
                random_start_iterations_mean=float(np.mean(runs.n_iterations)),
                random_start_iterations_max=int(np.max(runs.n_iterations)),
            )
        return entry

    def _batch(self, pooled: Pooled, rows: np.ndarray) -> tuple[np.ndarray, dict]:
        """The LM of the regular rows at once (:func:`lm_fit_batch`), its convergence and distance to
        the closed-form optimum; for the calibrations from all repetitions also the LM with lambda
        fixed (Eq. 9-10 read literally: ``fixed_*``), which table ``ricci_lm`` sets beside it.
        """
        v_est, weights = sagittal_axes(pooled)
        v_est, weights = v_est[rows], weights[rows]
        optimum = wahba_batch(SAGITTAL_REFERENCE, v_est, weights)
        lm = lm_fit_batch(SAGITTAL_REFERENCE, v_est, weights)
        columns = {
            "n_iterations": lm.n_iterations.astype(float),
            "n_rejected": lm.n_rejected.astype(float),
            "converged": lm.converged.astype(object),
            "cost": lm.cost,
            "optimum_distance_deg": _optimum_distance_deg(lm.R, optimum),
        }
        full = np.flatnonzero(pooled.all_repetitions[rows])
        fixed_columns = {
            "fixed_n_iterations": np.full(len(rows), np.nan),
            "fixed_cost": np.full(len(rows), np.nan),
            "fixed_converged": np.full(len(rows), None, dtype=object),
            "fixed_optimum_distance_deg": np.full(len(rows), np.nan),
        }
        if len(full):
            fixed = lm_fit_batch(SAGITTAL_REFERENCE, v_est[full], weights[full], adaptive=False)
            fixed_columns["fixed_n_iterations"][full] = fixed.n_iterations
            fixed_columns["fixed_cost"][full] = fixed.cost
            fixed_columns["fixed_converged"][full] = fixed.converged
            fixed_columns["fixed_optimum_distance_deg"][full] = _optimum_distance_deg(
                fixed.R, optimum[full]
            )
        return lm.R, columns | fixed_columns

    def _single(self, pooled: Pooled, row: int) -> tuple[np.ndarray, dict]:
        """:meth:`_batch` of one irregular row by :func:`lm_fit` (raises on axes it cannot fit)."""
        v_est, weights = sagittal_axes(pooled)
        fit = lm_fit(SAGITTAL_REFERENCE, v_est[row], weights[row])
        optimum = wahba_fit(SAGITTAL_REFERENCE, v_est[row], weights[row]).as_matrix()
        columns = {
            "n_iterations": float(fit.n_iterations),
            "n_rejected": float(fit.n_rejected),
            "converged": fit.converged,
            "cost": fit.cost,
            "optimum_distance_deg": float(error_angle_deg(fit.R, optimum)),
        }
        if pooled.all_repetitions[row]:
            fixed = lm_fit(SAGITTAL_REFERENCE, v_est[row], weights[row], adaptive=False)
            columns |= {
                "fixed_n_iterations": float(fixed.n_iterations),
                "fixed_cost": fixed.cost,
                "fixed_converged": fixed.converged,
                "fixed_optimum_distance_deg": float(error_angle_deg(fixed.R, optimum)),
            }
        return fit.R, columns

    def resample(self, pooled: Pooled, fitted=None) -> RicciLM:
        """The LM minimises the closed-form optimum's cost and reaches it
        (``optimum_distance_deg``): a bootstrap resample's calibration is that optimum, not 200
        LM runs (:func:`aceval.methods.align_vectors.optimum_resample`).
        """
        return self._set(*optimum_resample(pooled))
