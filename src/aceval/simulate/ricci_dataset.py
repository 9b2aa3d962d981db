"""Simulated Ricci et al. 2014 dataset: 40 children (6-8 years), sensors on the thorax and both
upper arms and forearms, the movement list of Ricci Sec. 2.2.1, 3 trials of 3-4 repetitions each,
and the static supine posture; written in the dataset contract with ground truth.

Segment frames equal the body frame {0} (x anterior, y right, z down) when standing with the arms
alongside the body, palms facing the thighs. ``functional_axes.tsv`` (an extra sheet) gives, for
each movement and segment, the segment-frame axis the movement is about (or, for the static
posture, the direction of the specific force), for the Ricci LM fit.
"""

from __future__ import annotations

import numpy as np

from aceval.data.units import SIMULATED_SUBJECTS
from aceval.data.writer import DatasetWriter, simulated_meta, write_sheet
from aceval.simulate.body import Placement, random_mount
from aceval.simulate.engine import (
    ImuErrorModel,
    band_noise,
    each_times,
    euler_pitch_roll_yaw,
    fine_time,
    small_rotations,
)
from aceval.simulate.motion import bell
from aceval.simulate.options import SimOptions, sensor_signals
from aceval.simulate.simulation import Simulation, written

SEGMENTS = ["thorax", "upper_arm_r", "upper_arm_l", "forearm_r", "forearm_l"]
IMUS = [  # Ricci Fig. 2: 1 thorax, 2/3 right/left upper arm, 4/5 right/left forearm
    ("SU1", "thorax", "center"),
    ("SU2", "upper_arm", "right"),
    ("SU3", "upper_arm", "left"),
    ("SU4", "forearm", "right"),
    ("SU5", "forearm", "left"),
]
D2R = np.pi / 180
#: off-axis share of each movement (amplitude of the rotation about the two other axes relative to
#: the main one). An assumption, stated here and in docs/simulation.md: children move less
#: precisely than adults (Ricci Sec. 1); a bar constrains the movement. Not fitted to Table 1.
OFF_AXIS = {"free": 0.20, "bar": 0.10}
MOVEMENTS = {
    # test: (description, moving segments, axis name, amplitude deg, there-and-back duration s, support)
    "TR": (
        "thorax rotation on the transverse plane, holding a bar",
        "thorax",
        "z",
        30.0,
        2.5,
        "free",
    ),
    "TFE": ("thorax flexion-extension", "thorax", "y", -45.0, 3.0, "free"),
    "AA": ("upper arm ab-adduction", "arms", "x", 80.0, 3.0, "free"),
    "FE": ("upper arm flexion-extension", "arms", "y", 110.0, 3.0, "free"),
    "FEB": ("upper arm flexion-extension holding a bar", "arms", "y", 110.0, 3.0, "bar"),
    "PS": ("forearm prono-supination, arms extended", "forearms_twist", "z", 70.0, 1.4, "free"),
    "FFEB": ("forearm flexion-extension holding a bar", "forearms", "y", 110.0, 2.5, "bar"),
}
TRIALS = 3  # Ricci Sec. 2.2.1: the complete protocol is 3 trials
ACC_RANGE_G, GYR_RANGE_DPS = 8.0, 1000.0  # assumption: Ricci does not give the ranges
WOBBLE_DEG = 1.0  # soft-tissue wobble RMS on thorax and arms (as Kong's chest; docs/simulation.md)
CALIBRATES = {
    "TR": ["SU1"],
    "TFE": ["SU1"],
    "AA": ["SU2", "SU3", "SU4", "SU5"],
    "FE": ["SU2", "SU3", "SU4", "SU5"],
    "FEB": ["SU2", "SU3", "SU4", "SU5"],
    "PS": ["SU2", "SU3", "SU4", "SU5"],
    "FFEB": ["SU4", "SU5"],
}


class Child:
    """Segment lengths from height (Winter 2009 proportions, as for adults)."""

    def __init__(self, height_m: float):
        self.height = height_m
        self.upper_arm = 0.186 * height_m
        self.forearm = 0.146 * height_m
        self.shoulder_half_width = 0.129 * height_m
        self.shoulder_drop = 0.15 * height_m  # mid-thorax to shoulder joint height

    def placements(self) -> dict[str, Placement]:
        """Where each unit sits on this child (segment frame, m) and its nominal axes."""
        up = (0.0, 0.0, -1.0)
        return {
            "SU1": Placement("thorax", (0.08, 0.0, -0.5 * self.shoulder_drop), (1, 0, 0), up),
            "SU2": Placement("upper_arm_r", (0.0, 0.04, 0.7 * self.upper_arm), (0, 1, 0), up),
            "SU3": Placement("upper_arm_l", (0.0, -0.04, 0.7 * self.upper_arm), (0, -1, 0), up),
            "SU4": Placement("forearm_r", (0.0, 0.025, 0.85 * self.forearm), (0, 1, 0), up),
            "SU5": Placement("forearm_l", (0.0, -0.025, 0.85 * self.forearm), (0, -1, 0), up),
        }


def _axis_rotvec(axis: str, angle):
    vector = np.zeros((np.size(angle), 3))
    vector[:, "xyz".index(axis)] = angle
    return vector


def _compose(A, B):
    """``A @ B`` of two stacks of rotations, where ``None`` is the identity: its product is
    skipped (a product with the identity gives the other factor's values).
    """
    if A is None:
        return B
    return A if B is None else A @ B


def _rotate(R, v: np.ndarray):
    """``R @ v`` for a stack ``R`` (``None``: the identity, ``v`` itself)."""
    return v if R is None else each_times(R, v)


def _poses(child: Child, relative: dict, base, n: int):
    """Chain thorax -> upper arms -> forearms on ``n`` samples. ``relative[seg]`` (n, 3, 3)
    rotates each segment relative to its parent (thorax relative to the world ``base``); ``None``
    (in ``relative`` or as ``base``) is the identity.
    """
    R = {"thorax": _compose(base, relative["thorax"])}
    origin = {"thorax": np.zeros((n, 3))}
    for s, sign in (("r", 1.0), ("l", -1.0)):
        shoulder = np.array([0.0, sign * child.shoulder_half_width, -child.shoulder_drop])
        R[f"upper_arm_{s}"] = _compose(R["thorax"], relative[f"upper_arm_{s}"])
        origin[f"upper_arm_{s}"] = origin["thorax"] + _rotate(R["thorax"], shoulder)
        R[f"forearm_{s}"] = _compose(R[f"upper_arm_{s}"], relative[f"forearm_{s}"])
        origin[f"forearm_{s}"] = origin[f"upper_arm_{s}"] + _rotate(
            R[f"upper_arm_{s}"], np.array([0, 0, child.upper_arm])
        )
    identity = np.tile(np.eye(3), (n, 1, 1))
    return {seg: identity if rotation is None else rotation for seg, rotation in R.items()}, origin


def _trial(rng, child, test, fs, offplane):
    """One trial: 1 s rest, 3-4 repetitions of the movement, 1 s rest."""
    if test == "S":
        t = fine_time(5.0, fs)
        relative = dict.fromkeys(SEGMENTS)  # None: the identity (_poses)
        for s, sign in (("r", 1.0), ("l", -1.0)):  # palms facing down: forearms pronated 90 deg
            relative[f"forearm_{s}"] = euler_pitch_roll_yaw(np.zeros(len(t)), 0.0, -sign * 90 * D2R)
        supine = euler_pitch_roll_yaw(np.full(len(t), 90 * D2R))  # lying on the back: x up
        breathing = small_rotations(_axis_rotvec("y", 0.5 * D2R * np.sin(2 * np.pi * 0.3 * t)))
        R, origin = _poses(child, relative, supine @ breathing, len(t))
        return t, R, origin, np.zeros(len(t))
    description, moving, axis, amplitude, duration, support = MOVEMENTS[test]
    n_reps = int(rng.integers(3, 5))
    durations = [duration * max(0.5, rng.normal(1, 0.1)) for _ in range(n_reps)]
    t = fine_time(2.0 + sum(durations), fs)
    profile = np.zeros_like(t)
    start = 1.0
    for d in durations:
        profile += bell(t, start, d) * max(0.5, rng.normal(1, 0.1))
        start += d
    main = _axis_rotvec(axis, amplitude * D2R * profile)
    share = OFF_AXIS[support] * offplane
    other = [a for a in "xyz" if a != axis]

    def movement(sign=1.0):
        off = sum(
            _axis_rotvec(a, share * abs(amplitude) * D2R * profile * band_noise(rng, t, 0.3, 1.5))
            for a in other
        )
        return small_rotations(sign * (main + off))

    relative = dict.fromkeys(SEGMENTS)  # None: the identity (_poses)
    if test == "TR" or moving == "forearms_twist":  # the movements with the arms forward
        arms_forward = euler_pitch_roll_yaw(np.full(len(t), 90 * D2R))
    if moving == "thorax":
        relative["thorax"] = movement()
        if test == "TR":  # holding a bar in front: arms forward, following the thorax
            relative["upper_arm_r"] = relative["upper_arm_l"] = arms_forward
    elif moving == "arms":
        for s, sign in (("r", 1.0), ("l", -1.0)):
            # abduction (about x) lifts the right arm about -x and the left about +x
            relative[f"upper_arm_{s}"] = movement(_side_sign(test, sign))
    elif moving == "forearms":
        for s in ("r", "l"):
            relative[f"forearm_{s}"] = movement()
    elif moving == "forearms_twist":
        for s, sign in (("r", 1.0), ("l", -1.0)):
            relative[f"upper_arm_{s}"] = arms_forward @ small_rotations(
                _axis_rotvec("z", sign * 0.15 * amplitude * D2R * profile)
            )  # shoulder rotation coupling
            relative[f"forearm_{s}"] = movement()
    R, origin = _poses(child, relative, None, len(t))
    return t, R, origin, np.clip(profile, 0, 1)


def _side_sign(test: str, side_sign: float) -> float:
    """Direction of ``test``'s rotation for one side (+1 right, -1 left): abduction lifts the right
    arm about -x and the left about +x; every other movement turns the same way on both sides.
    """
    return -side_sign if MOVEMENTS[test][2] == "x" and MOVEMENTS[test][1] == "arms" else 1.0


def functional_axes() -> list[list[str]]:
    """(test, segment, signed axis) for ``functional_axes.tsv``, in the segment frame.

    Static supine posture: the direction of the specific force (up = anterior, +x; for the
    pronated forearm, the dorsum of the hand, which faces laterally in the standing posture: +y
    right, -y left). Movements: the axis of the first phase of each repetition (right-hand rule),
    e.g. thorax flexion first is a rotation about -y. ``<segment>_r|l`` rows are side-specific.
    """
    rows = [
        ["S", "thorax", "+x"],
        ["S", "upper_arm", "+x"],
        ["S", "forearm_r", "+y"],
        ["S", "forearm_l", "-y"],
    ]
    for test, (_, moving, axis, amplitude, *_rest) in MOVEMENTS.items():
        segment = {
            "thorax": "thorax",
            "arms": "upper_arm",
            "forearms": "forearm",
            "forearms_twist": "forearm",
        }[moving]
        signs = {
            side: np.sign(amplitude) * _side_sign(test, side_sign)
            for side, side_sign in (("r", 1.0), ("l", -1.0))
        }
        if signs["r"] == signs["l"]:
            rows.append([test, segment, f"{'+' if signs['r'] > 0 else '-'}{axis}"])
        else:
            rows += [
                [test, f"{segment}_{side}", f"{'+' if sign > 0 else '-'}{axis}"]
                for side, sign in signs.items()
            ]
    return rows


def ricci_simulation(
    seed: int,
    n_subjects: int = SIMULATED_SUBJECTS["ricci"],
    options: SimOptions = SimOptions(),
    name: str = "ricci_sim",
) -> Simulation:
    """The SIMULATED Ricci et al. 2014 children named ``name``, before they are written."""
    meta = simulated_meta(
        name,
        "Ricci et al. 2014",
        "ricci",
        seed,
        options.fs_hz,
        units={"acc": "m/s^2", "gyr": "rad/s"},
        sensor_sets=["main"],
        acc_range_g={"upper_body": ACC_RANGE_G},
        gyr_range_dps=GYR_RANGE_DPS,
    )
    rng0 = np.random.default_rng([seed, 0])
    subjects = []
    for k in range(n_subjects):  # 6-8 years (Ricci Sec. 2.1); height ~122 +- 5 cm at age 7 (WHO)
        subjects.append(
            [
                f"C{k + 1:02d}",
                round(float(rng0.uniform(6.0, 8.0)), 1),
                round(float(rng0.normal(122, 5))),
            ]
        )
    tests = {"S": ("static", "supine, arms alongside the body, palms down, 5 s")}
    tests.update({test: ("motion", m[0]) for test, m in MOVEMENTS.items()})

    def sheets(writer: DatasetWriter) -> None:
        write_sheet(writer.root / "subjects.tsv", ["subject", "age", "height_cm"], subjects)
        writer.protocol_sheets(tests, {test: TRIALS for test in tests}, CALIBRATES)
        probe = Child(1.22).placements()
        write_sheet(
            writer.root / "imus.tsv",
            ["imu", "segment", "side", "region", "right_axis"],
            [
                [imu, segment, side, "upper_body", probe[imu].right_axis()]
                for imu, segment, side in IMUS
            ],
        )
        columns = ["test", "segment", "axis"]
        write_sheet(writer.root / "functional_axes.tsv", columns, functional_axes())

    error_model = ImuErrorModel(gyr_range_dps=GYR_RANGE_DPS)
    runs = [(test, trial) for test in tests for trial in range(1, TRIALS + 1)]

    def write_subject(k: int, writer: DatasetWriter) -> None:
        subject, _, height_cm = subjects[k]
        rng = np.random.default_rng([seed, 1, k])
        child = Child(height_cm / 100.0)
        placements = child.placements()
        mounts = {
            imu: random_mount(rng, placements[imu], options.misalignment_sd_deg) for imu, *_ in IMUS
        }
        for imu, *_ in IMUS:
            writer.ground_truth(subject, "main", imu, mounts[imu])
        for j, (test, trial) in enumerate(runs):
            run_rng = np.random.default_rng([seed, 2, k, j])
            _, R, origin, envelope = _trial(run_rng, child, test, options.fs_hz, options.offplane)
            for imu, *_ in IMUS:
                placement = placements[imu]
                gyr, acc = sensor_signals(
                    run_rng,
                    R[placement.segment],
                    origin[placement.segment],
                    mounts[imu],
                    placement.position,
                    envelope,
                    WOBBLE_DEG,
                    options,
                    ACC_RANGE_G,
                    error_model,
                )
                writer.recording(subject, "main", test, trial, imu, gyr, acc)

    return Simulation(meta, [s[0] for s in subjects], sheets, write_subject, "ricci_sim")


#: writes :func:`ricci_simulation` into a folder: ``simulate_ricci(out, seed, n_subjects, options, name)``
simulate_ricci = written(ricci_simulation)
