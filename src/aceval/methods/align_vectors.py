"""SciPy's ``Rotation.align_vectors``: the closed-form optimum of Ricci's rho-weighted cost
(Wahba's problem), in Kong's protocol z0 and the motion test's gyroscope axis onto body z and y
(:mod:`aceval.methods.sagittal`). The cross-check of Ricci's LM (:mod:`aceval.methods.ricci`), and
a method of its own in the comparisons.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.data.errors import check_axes
from aceval.methods.interface import AxisProblem
from aceval.methods.sagittal import SAGITTAL_REFERENCE, AxisMethod, sagittal_axes, usable_axes
from aceval.methods.sufficient import Pooled


def wahba_fit(v_ref, v_est, weights=None) -> Rotation:
    """Closed-form weighted optimum of the LM cost: ``Rotation.align_vectors(v_ref, v_est, w)``."""
    v_ref, v_est, weights = check_axes(v_ref, v_est, weights)
    rotation, _ = Rotation.align_vectors(v_ref, v_est, weights=weights)
    return rotation


def wahba_batch(v_ref: np.ndarray, v_est: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The weighted Wahba optimum (R with ``R v_est ~ v_ref``, as ``Rotation.align_vectors``) of
    each row: ``v_ref`` (n, 3), ``v_est`` (B, n, 3), ``weights`` (B, n); by the SVD of
    ``sum w v_ref v_est^T`` with the determinant made +1 (Kabsch), all rows at once.
    """
    profile = np.einsum("bi,ij,bik->bjk", weights, v_ref, v_est)
    U, _, Vt = np.linalg.svd(profile)
    scale = np.ones((len(profile), 3))
    scale[:, 2] = np.sign(np.linalg.det(U @ Vt))
    return U @ (scale[:, :, None] * Vt)


class AlignVectors(AxisMethod):
    """The weighted Wahba optimum (``Rotation.align_vectors``) of each pooled row, flagged as the
    axis methods are (:class:`aceval.methods.sagittal.AxisMethod`).
    """

    @classmethod
    def fit_functional(cls, problem: AxisProblem) -> dict:
        """The optimum of the axis pairs (Ricci's functional design)."""
        return {"R": wahba_fit(problem.v_ref, problem.v_est, problem.rho).as_matrix()}

    def _batch(self, pooled: Pooled, rows: np.ndarray) -> tuple[np.ndarray, dict]:
        v_est, weights = sagittal_axes(pooled)
        return wahba_batch(SAGITTAL_REFERENCE, v_est[rows], weights[rows]), {}

    def _single(self, pooled: Pooled, row: int) -> tuple[np.ndarray, dict]:
        v_est, weights = sagittal_axes(pooled)
        return wahba_fit(SAGITTAL_REFERENCE, v_est[row], weights[row]).as_matrix(), {}

    def resample(self, pooled: Pooled, fitted=None) -> AlignVectors:
        """The optimum of each bootstrap resample, NaN where its axis would be flagged."""
        return self._set(*optimum_resample(pooled))


def optimum_resample(pooled: Pooled) -> tuple[np.ndarray, np.ndarray]:
    """``(R, flag)``: the weighted Wahba optimum of each bootstrap resample, NaN (and ``low_rho``)
    where its axis would be flagged (the resample of Ricci's LM too, which reaches this optimum).
    """
    v_est, weights = sagittal_axes(pooled)
    usable = usable_axes(pooled)
    R = np.where(usable[:, None, None], wahba_batch(SAGITTAL_REFERENCE, v_est, weights), np.nan)
    return R, np.where(usable, "", "low_rho")
