"""The peers' file interface (workflow/peers/peer_io.py, which needs NumPy only): the frame it
builds from a peer's vertical and medial-lateral axis."""

import sys

import numpy as np

from .runner import REPO

sys.path.insert(0, str(REPO / "workflow" / "peers"))
from peer_io import frame_from_axes  # noqa: E402


def test_an_axis_near_vertical_is_signed_by_its_horizontal_part():
    """A tilted sensor (its declared right axis has a vertical part) and a hinge axis 11 deg from
    the vertical whose raw vector points slightly right while its horizontal part points left:
    the frame's y must point right (before the fix it pointed left, 180 deg off)."""
    down = np.array([0.0, 0.3, 1.0])
    down /= np.linalg.norm(down)
    declared = np.array([0.0, 1.0, 0.0])
    right = declared - (declared @ down) * down
    right /= np.linalg.norm(right)
    axis = down - 0.2 * right  # near the vertical, its horizontal part to the left
    assert axis @ declared > 0 and (axis - (axis @ down) * down) @ right < 0
    R = frame_from_axes(down, axis, declared)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(R), 1.0)
    np.testing.assert_allclose(R[2], down)
    np.testing.assert_allclose(R[1], right, atol=1e-12)
    # and an axis with no vertical part gives the same frame whichever sign it comes with
    np.testing.assert_allclose(frame_from_axes(down, -right, declared), R, atol=1e-12)
