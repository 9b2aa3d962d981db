"""Body model: segment lengths from anthropometry, sensor placements and random mountings.

Segment frames: at neutral quiet standing every segment frame equals the whole-body frame {0}
(x anterior, y right, z down). Leg segments and the foot hang from their proximal joint along +z;
trunk segments (pelvis, thorax, head) rise from the hip centre along -z. Lengths are fractions of
body height from Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed. (2009),
Fig. 4.1: hip height 0.530 H, knee 0.285 H, ankle 0.039 H, shoulder 0.818 H, chin 0.870 H.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

SEGMENTS = [
    "head",
    "chest",
    "waist",
    "thigh_r",
    "shank_r",
    "foot_r",
    "thigh_l",
    "shank_l",
    "foot_l",
]


@dataclass(frozen=True)
class Anthropometry:
    """Segment lengths (m) as fractions of body height (Winter 2009, Fig. 4.1)."""

    height_m: float

    @property
    def thigh(self) -> float:  # hip to knee
        """Hip to knee (m)."""
        return (0.530 - 0.285) * self.height_m

    @property
    def shank(self) -> float:  # knee to ankle
        """Knee to ankle (m)."""
        return (0.285 - 0.039) * self.height_m

    @property
    def ankle_height(self) -> float:
        """Ankle above the floor (m)."""
        return 0.039 * self.height_m

    @property
    def pelvis(self) -> float:  # hip centre to lumbar joint (L3/L4), about 0.1 H
        """Hip centre to the lumbar joint (L3/L4), about 0.1 H (m)."""
        return 0.10 * self.height_m

    @property
    def thorax(self) -> float:  # lumbar joint to C7
        """Lumbar joint to C7 (m)."""
        return (0.818 - 0.530 - 0.10 + 0.02) * self.height_m

    @property
    def hip_width(self) -> float:  # distance between hip centres, about 0.1 H
        """Distance between the hip centres, about 0.1 H (m)."""
        return 0.10 * self.height_m


@dataclass(frozen=True)
class Placement:
    """Where and how a sensor sits on its segment, nominally.

    ``position`` (m) in the segment frame from the segment origin; ``outward`` the skin normal
    (segment frame) = sensor z; ``along`` the sensor x (segment long axis or foot forward).
    """

    segment: str
    position: tuple[float, float, float]
    outward: tuple[float, float, float]
    along: tuple[float, float, float]

    def nominal_mount(self) -> np.ndarray:
        """Sensor -> segment rotation of the nominal placement (columns = sensor axes)."""
        x = np.asarray(self.along, float)
        z = np.asarray(self.outward, float)
        return np.column_stack([x, np.cross(z, x), z])

    def right_axis(self) -> str:
        """The signed sensor axis that points most to the subject's right, as a lab would declare."""
        y0_in_sensor = self.nominal_mount()[1]
        k = int(np.argmax(np.abs(y0_in_sensor)))
        return ("+" if y0_in_sensor[k] > 0 else "-") + "xyz"[k]


UP, FORWARD, BACK = (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)
RIGHT, LEFT = (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)


def kong_placements(body: Anthropometry) -> dict[str, dict[str, Placement]]:
    """Kong Fig. 4b: frontal/back set (back of head, chest and waist; front of thighs, shanks and
    feet) and lateral set (right side of head/chest/waist; outer side of each leg segment).
    """
    H = body.height_m
    frontal = {
        "head": Placement("head", (-0.09, 0.0, -0.10), BACK, UP),
        "chest": Placement("chest", (-0.11, 0.0, -0.6 * body.thorax), BACK, UP),
        "waist": Placement("waist", (-0.11, 0.0, -0.4 * body.pelvis), BACK, UP),
    }
    lateral = {
        "head": Placement("head", (0.0, 0.075, -0.10), RIGHT, UP),
        "chest": Placement("chest", (0.0, 0.15, -0.6 * body.thorax), RIGHT, UP),
        "waist": Placement("waist", (0.0, 0.16, -0.4 * body.pelvis), RIGHT, UP),
    }
    for side, sign, outward_lat in (("r", 1.0, RIGHT), ("l", -1.0, LEFT)):
        frontal[f"thigh_{side}"] = Placement(
            f"thigh_{side}", (0.08, 0.0, 0.5 * body.thigh), FORWARD, UP
        )
        frontal[f"shank_{side}"] = Placement(
            f"shank_{side}", (0.05, 0.0, 0.35 * body.shank), FORWARD, UP
        )
        frontal[f"foot_{side}"] = Placement(
            f"foot_{side}", (0.06, 0.0, 0.03 * H / 1.75), UP, FORWARD
        )
        lateral[f"thigh_{side}"] = Placement(
            f"thigh_{side}", (0.0, sign * 0.09, 0.5 * body.thigh), outward_lat, UP
        )
        lateral[f"shank_{side}"] = Placement(
            f"shank_{side}", (0.0, sign * 0.055, 0.35 * body.shank), outward_lat, UP
        )
        lateral[f"foot_{side}"] = Placement(
            f"foot_{side}", (0.03, sign * 0.045, 0.04 * H / 1.75), outward_lat, FORWARD
        )
    return {"frontal": frontal, "lateral": lateral}


def random_mount(rng, placement: Placement, misalignment_sd_deg: float) -> np.ndarray:
    """True sensor -> segment rotation: the nominal mount turned by a random misalignment whose
    angle is half-normal with SD ``misalignment_sd_deg`` about a uniformly random axis.
    """
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(abs(rng.normal(0, misalignment_sd_deg)))
    return Rotation.from_rotvec(axis * angle).as_matrix() @ placement.nominal_mount()
