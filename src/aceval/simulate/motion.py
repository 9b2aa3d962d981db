"""Movement profiles and the segment chain shared by the protocols.

Profiles are minimum-jerk (Flash & Hogan 1985, J Neurosci 5:1688): zero velocity and acceleration
at their ends, so every simulated movement starts and stops smoothly, as voluntary movements do.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aceval.simulate.body import SEGMENTS, Anthropometry
from aceval.simulate.engine import each_times, euler_pitch_roll_yaw


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk step 0 -> 1 for s in [0, 1] (clipped outside)."""
    s = np.clip(s, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def step(t: np.ndarray, start: float, duration: float) -> np.ndarray:
    """0 before ``start``, 1 after ``start + duration``, minimum-jerk in between."""
    return min_jerk((t - start) / duration)


def bell(t: np.ndarray, start: float, duration: float) -> np.ndarray:
    """There and back: 0 -> 1 (at mid-time) -> 0 over ``duration`` from ``start``."""
    half = duration / 2
    return step(t, start, half) - step(t, start + half, half)


@dataclass
class Posture:
    """Absolute segment angles (rad) over time and the position of the hip centre (m, world).

    ``angles[segment] = (pitch, roll, yaw)``, arrays of the time grid's length (or scalars).
    ``envelope`` (0-1) marks when segments move, to scale soft-tissue wobble. ``strikes``: the
    heel strikes' times (s) per side ('r', 'l') of a walk, for the heel-strike shaking
    (:func:`aceval.simulate.options.heel_strike_shaking`).
    """

    t: np.ndarray
    angles: dict = field(default_factory=dict)
    hip: np.ndarray | None = None
    envelope: np.ndarray | None = None
    strikes: dict = field(default_factory=dict)

    def angle(self, segment: str):
        """(pitch, roll, yaw) of ``segment`` (rad); zeros when it was never moved."""
        return self.angles.get(segment, (0.0, 0.0, 0.0))

    def add(self, segment: str, pitch=0.0, roll=0.0, yaw=0.0) -> None:
        """Add angles (rad, scalars or arrays over the time grid) to ``segment``."""
        p, r, y = self.angle(segment)
        self.angles[segment] = (p + pitch, r + roll, y + yaw)


def segment_poses(posture: Posture, body: Anthropometry, fixed_ankle: str | None = None):
    """Orientation (segment -> world, (M, 3, 3)) and origin (m, (M, 3)) of every segment.

    The chain starts at the hip centre (``posture.hip``) or, when ``fixed_ankle`` is 'r' or 'l', at
    that ankle held still on the floor, from which the hip centre follows.
    """
    n = len(posture.t)
    R = {
        seg: euler_pitch_roll_yaw(*[np.broadcast_to(a, n) for a in posture.angle(seg)])
        for seg in SEGMENTS
    }
    ez = np.array([0.0, 0.0, 1.0])
    lateral = {
        "r": np.array([0.0, 0.5 * body.hip_width, 0.0]),
        "l": np.array([0.0, -0.5 * body.hip_width, 0.0]),
    }
    if fixed_ankle is not None:
        s = fixed_ankle
        ankle = np.array([0.0, lateral[s][1], -body.ankle_height])
        hip = (
            ankle
            - each_times(R[f"shank_{s}"], ez * body.shank)
            - each_times(R[f"thigh_{s}"], ez * body.thigh)
            - each_times(R["waist"], lateral[s])
        )
    else:
        hip = np.broadcast_to(posture.hip, (n, 3))
    origins = {"waist": hip}
    origins["chest"] = hip + each_times(R["waist"], -ez * body.pelvis)
    origins["head"] = origins["chest"] + each_times(R["chest"], -ez * body.thorax)
    for s in ("r", "l"):
        origins[f"thigh_{s}"] = hip + each_times(R["waist"], lateral[s])
        shank = origins[f"thigh_{s}"] + each_times(R[f"thigh_{s}"], ez * body.thigh)
        origins[f"shank_{s}"] = shank
        origins[f"foot_{s}"] = shank + each_times(R[f"shank_{s}"], ez * body.shank)
    return R, origins


def standing_hip(body: Anthropometry) -> np.ndarray:
    """Hip centre (world, m) when standing upright with the ankles on the floor."""
    return np.array([0.0, 0.0, -(body.ankle_height + body.shank + body.thigh)])


def sitting_hip(body: Anthropometry) -> np.ndarray:
    """Hip centre when seated: thighs horizontal, shanks vertical, feet flat (chair at knee height)."""
    return np.array([-body.thigh, 0.0, -(body.ankle_height + body.shank)])
