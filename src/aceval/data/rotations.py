"""One vocabulary for rotations and error angles, on top of ``scipy.spatial.transform.Rotation``.

A calibration is a 3x3 matrix ``R`` that maps sensor-frame vectors into the body frame
(``d_body = R @ d_sensor``, Kong Eq. 6). Stacks of matrices have shape (..., 3, 3).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # imported where used: SciPy costs 0.3-0.4 s at the start of the jobs that
    # only need the axis vocabulary (`aceval validate`: the sheets' right axes)
    from scipy.spatial.transform import Rotation

#: unit vectors of the declared sensor axes (imus.tsv ``right_axis``)
AXIS_VECTORS = {
    "+x": (1.0, 0.0, 0.0),
    "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0),
    "-z": (0.0, 0.0, -1.0),
}


def axis_vector(spec: str) -> np.ndarray:
    """Unit vector of a signed sensor axis such as ``'+x'`` or ``'-y'`` (``'x'`` means ``'+x'``)."""
    key = spec.strip().lower()
    if len(key) == 1:
        key = "+" + key
    try:
        return np.array(AXIS_VECTORS[key])
    except KeyError:
        raise ValueError(f"right_axis {spec!r} is not one of {', '.join(AXIS_VECTORS)}") from None


def _as_rotation(matrices: np.ndarray) -> tuple[Rotation, tuple[int, ...]]:
    matrices = np.asarray(matrices, dtype=float)
    if matrices.shape[-2:] != (3, 3):
        raise ValueError(f"expected (..., 3, 3) rotation matrices, got shape {matrices.shape}")
    batch_shape = matrices.shape[:-2]
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(matrices.reshape(-1, 3, 3)), batch_shape


def relative_rotvec(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Rotation vector (rad, shape (..., 3)) of ``R1 @ R2.T``, in the body frame.

    The difference between two calibrations of the same sensor (Kong Eq. 11-16).
    """
    R1, R2 = np.broadcast_arrays(np.asarray(R1, float), np.asarray(R2, float))
    rotation, batch_shape = _as_rotation(R1 @ np.swapaxes(R2, -1, -2))
    return rotation.as_rotvec().reshape(*batch_shape, 3)


def error_angle_deg(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Angle (deg) of ``R1 @ R2.T`` in axis-angle form (Kong Eq. 11-16); broadcasts over stacks."""
    return np.degrees(np.linalg.norm(relative_rotvec(R1, R2), axis=-1))


def vertical_share(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Share (0-1) of the error rotation ``R1 @ R2.T`` that is about the body vertical z.

    ``|rotvec_z| / |rotvec|``; NaN where the two calibrations are identical.
    """
    return rotvec_vertical_share(relative_rotvec(R1, R2))


def rotvec_vertical_share(rotvec: np.ndarray) -> np.ndarray:
    """Share (0-1) of rotation vectors (..., 3) about z: ``|rotvec_z| / |rotvec|``; NaN for none."""
    norm = np.linalg.norm(rotvec, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0, np.abs(rotvec[..., 2]) / norm, np.nan)


def vector_angle_deg(a: np.ndarray, b: np.ndarray, sign_free: bool = False) -> np.ndarray:
    """Angle (deg) between unit vectors ``a`` and ``b`` ((..., 3), broadcast); ``sign_free``:
    between the lines they span (0-90 deg: an axis whose sign is not known). NaN where either is
    not finite.
    """
    with np.errstate(invalid="ignore"):
        cosine = np.sum(np.asarray(a, float) * np.asarray(b, float), axis=-1)
        if sign_free:
            cosine = np.abs(cosine)
        return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def random_rotations(n: int, seed: int | np.random.Generator | None = None) -> np.ndarray:
    """``n`` uniformly random rotation matrices, shape (n, 3, 3)."""
    from scipy.spatial.transform import Rotation

    return Rotation.random(n, random_state=seed).as_matrix()
