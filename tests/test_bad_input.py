"""The bad-input matrix: one defect per copy of a small simulated dataset, as a new user would make
it by mistake. Every case must end in a clear error (exit code, and a message naming the file or
sheet, the row and the cause), a visible flag or warning, or a refusal to write; and no input file
may change, whatever the command wrote. config/README.md ("What aceval checks") lists the checks.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aceval.calibrate.table import SPREAD_FLAGS
from aceval.data.contract import RecordingError, recording_values
from aceval.data.dataset import load_dataset
from aceval.data.safety import MARKER
from aceval.methods.registry import functional_design

from .runner import aceval


@pytest.fixture(scope="session")
def pristine(clean) -> Path:
    return clean.small()


@pytest.fixture(scope="session")
def full_lab(clean) -> Path:
    """Every IMU of the frontal set in every test, as a lab records them, with 5 repetitions."""
    return clean.full_lab()


@pytest.fixture(scope="session")
def full_lab_calibrations(clean) -> Path:
    return clean.clean_calibrations("full_lab")


@pytest.fixture(scope="session")
def good_calibrations(clean) -> Path:
    return clean.clean_calibrations("small")


# --- how to break a copy ----------------------------------------------------------------------


def edit(path: Path, old: str, new: str, count: int = -1) -> None:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path.name}"
    path.write_text(text.replace(old, new, count))


def paths_of(lab: Path, imu: str, test: str | None = None) -> list[Path]:
    sheet = pd.read_csv(lab / "recordings.tsv", sep="\t", dtype=str)
    chosen = sheet[(sheet["imu"] == imu) & ((sheet["test"] == test) if test else True)]
    return [lab / p for p in chosen["path"]]


def rewrite(path: Path, change: Callable[[pd.DataFrame], pd.DataFrame]) -> None:
    change(pd.read_csv(path)).to_csv(path, index=False, float_format="%.6g")


def first_path(lab: Path, imu: str = "IMU2", test: str = "T1") -> str:
    return str(paths_of(lab, imu, test)[0].relative_to(lab))


def swap_acc_xy(lab: Path) -> None:
    for path in paths_of(lab, "IMU2"):
        rewrite(path, lambda t: t.assign(acc_x=t["acc_y"], acc_y=t["acc_x"]))


def exchanged(first: str, second: str):
    """Two IMUs' labels exchanged in every row of recordings.tsv (the sensors worn swapped)."""

    def breakage(lab: Path) -> None:
        sheet = pd.read_csv(lab / "recordings.tsv", sep="\t", dtype=str, keep_default_na=False)
        sheet["imu"] = sheet["imu"].replace({first: second, second: first})
        sheet.to_csv(lab / "recordings.tsv", sep="\t", index=False)

    return breakage


def random_rotation(lab: Path, imu: str = "IMU4", test: str = "T3") -> None:
    """``imu``'s ``test`` recordings replaced by a rigid random 3-D rotation (no plane, no axis)."""
    rng = np.random.default_rng(0)
    for path in paths_of(lab, imu, test):
        table = pd.read_csv(path)
        t = table["t"].to_numpy()
        omega = 1.5 * np.column_stack(
            [
                np.sin(2 * np.pi * f * t + p)
                for f, p in zip(rng.uniform(0.3, 1.2, 3), rng.uniform(0, 6, 3))
            ]
        )
        steps = Rotation.from_rotvec(omega / 100.0)
        orientation, up = Rotation.identity(), []
        for step in steps:
            orientation = orientation * step
            up.append(
                orientation.inv().apply([0.0, 0.0, -1.0])
            )  # specific force (g) of a still body
        table[["acc_x", "acc_y", "acc_z"]] = np.array(up)
        table[["gyr_x", "gyr_y", "gyr_z"]] = np.degrees(omega)
        table.to_csv(path, index=False, float_format="%.6g")


def clip_shank(lab: Path) -> None:
    """IMU5 clipped at 0.8 g, and no range declared in dataset.yaml."""
    edit(lab / "dataset.yaml", "acc_range_g:\n  upper_body: 4.0\n  lower_body: 8.0\n", "")
    for path in paths_of(lab, "IMU5"):
        rewrite(
            path,
            lambda t: t.assign(**{c: t[c].clip(-0.8, 0.8) for c in ("acc_x", "acc_y", "acc_z")}),
        )


def transpose_truth(lab: Path) -> None:
    sheet = pd.read_csv(lab / "ground_truth.tsv", sep="\t", dtype=str)
    sheet[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]] = sheet[
        [f"r{j}{i}" for i in (1, 2, 3) for j in (1, 2, 3)]
    ].to_numpy()
    sheet.to_csv(lab / "ground_truth.tsv", sep="\t", index=False)


def semicolons(lab: Path) -> None:
    path = lab / first_path(lab)
    path.write_text(path.read_text().replace(",", ";"))


def turned(table: pd.DataFrame, turn: Rotation) -> pd.DataFrame:
    """A recording's acc and gyr turned by ``turn`` (the sensor held differently)."""
    for quantity in ("acc", "gyr"):
        columns = [f"{quantity}_{axis}" for axis in "xyz"]
        table[columns] = turn.apply(table[columns].to_numpy(float))
    return table


def static_seated(imu: str, degrees: float):
    """The static trial (T0) of ``imu`` taken seated or leaning: its recordings turned by
    ``degrees`` about the IMU's declared right axis (both sensor sets)."""

    def breakage(lab: Path) -> None:
        sheet = pd.read_csv(lab / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
        for row in sheet[sheet["imu"] == imu].itertuples():
            sign, axis = (
                (-1.0 if row.right_axis[0] == "-" else 1.0),
                "xyz".index(row.right_axis[-1]),
            )
            vector = np.zeros(3)
            vector[axis] = sign
            turn = Rotation.from_rotvec(np.radians(degrees) * vector)
            recordings = pd.read_csv(lab / "recordings.tsv", sep="\t", dtype=str)
            chosen = recordings[
                (recordings["imu"] == imu)
                & (recordings["sensor_set"] == row.sensor_set)
                & (recordings["test"] == "T0")
            ]
            for path in chosen["path"]:
                rewrite(lab / path, lambda t, turn=turn: turned(t, turn))

    return breakage


def set_right_axis(lab: Path, imu: str, axis: str) -> None:
    sheet = pd.read_csv(lab / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    sheet.loc[sheet["imu"] == imu, "right_axis"] = axis
    sheet.to_csv(lab / "imus.tsv", sep="\t", index=False)


def empty_calibrations(lab: Path) -> None:
    (lab.parent / "empty.csv").write_text("subject,sensor_set,imu,test,method,n_reps,flag\n")


def calibrations_copy(change: Callable[[Path, Path], None]):
    """`aceval apply` of the dataset with a changed copy of the good calibrations file."""

    def argv(lab, tmp, calibrations):
        broken = tmp / "broken.csv"
        change(calibrations, broken)
        return ["apply", str(lab), "--calibrations", str(broken), "--out", str(tmp / "copy")]

    return argv


def edited_calibrations(change: Callable[[pd.DataFrame], pd.DataFrame]):
    return calibrations_copy(
        lambda good, broken: change(pd.read_csv(good)).to_csv(broken, index=False)
    )


def nudge_one_recording(lab: Path) -> None:
    """A recording changed after calibration, still valid: one time value in its tenth digit."""
    path = lab / T1
    path.write_text(path.read_text().replace("\n0.05,", "\n0.0500000001,", 1))


# --- the commands -----------------------------------------------------------------------------


def validate(lab, tmp, _):
    return ["validate", str(lab)]


def calibrate(lab, tmp, _):
    return ["calibrate", str(lab), "--out", str(tmp / "out.csv")]


def apply(out: str | Callable, *extra):
    def argv(lab, tmp, calibrations):
        target = out(lab, tmp) if callable(out) else tmp / out
        return [
            "apply",
            str(lab),
            "--calibrations",
            str(calibrations),
            "--out",
            str(target),
            *extra,
        ]

    return argv


@dataclass
class Case:
    name: str
    breakage: Callable[[Path], None] | None
    command: Callable
    code: int
    says: tuple[str, ...]
    outcome: str  # error | refused | warning | flag
    flags: dict = field(default_factory=dict)  # {(imu, test or None): {flags every row has one of}}
    no_output: tuple[str, ...] = ()  # paths (relative to tmp) that must not exist afterwards
    left_out: tuple[str, ...] = ()  # IMUs with no calibration at all (their recordings left out)
    fixture: str = "pristine"  # the dataset broken: pristine (3 IMUs, 3 reps) or full_lab
    untouched_tests: tuple[str, ...] = ()  # tests of a flagged IMU whose rows must stay unflagged


def yaml_case(name, old, new, *says):
    return Case(
        name,
        lambda lab: edit(lab / "dataset.yaml", old, new),
        validate,
        1,
        ("dataset.yaml", *says),
        "error",
    )


def sheet_case(name, sheet, old, new, where, *says, outcome="error", code=1, count=-1):
    return Case(
        name,
        lambda lab: edit(lab / sheet, old, new, count),
        validate,
        code,
        (where, *says),
        outcome,
    )


T1 = "data/S1/frontal/T1_R1_IMU2.csv"
CASES = [
    # data loss (the first findings of the sweep)
    Case(
        "absolute path in recordings.tsv",
        lambda lab: edit(lab / "recordings.tsv", f"\t{T1}", f"\t{lab / T1}"),
        apply("copy"),
        1,
        ("recordings.tsv line", "is absolute"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "path climbing into a sibling dataset",
        lambda lab: edit(lab / "recordings.tsv", f"\t{T1}", f"\t../other/{T1}"),
        apply("copy"),
        1,
        ("recordings.tsv line", "climbs out"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply --out the folder holding the dataset --force",
        None,
        apply(lambda lab, tmp: tmp, "--force"),
        2,
        ("contains the input",),
        "refused",
    ),
    Case(
        "apply --out the dataset",
        None,
        apply(lambda lab, tmp: lab),
        2,
        ("is the input",),
        "refused",
    ),
    Case(
        "apply --out inside the dataset",
        None,
        apply(lambda lab, tmp: lab / "copy"),
        2,
        ("lies inside",),
        "refused",
    ),
    Case(
        "apply --force onto a folder aceval did not write",
        lambda lab: (
            (lab.parent / "mine").mkdir()
            or (lab.parent / "mine" / "thesis.docx").write_text("months of work")
        ),
        apply("mine", "--force"),
        2,
        ("not written by aceval",),
        "refused",
    ),
    Case(
        "calibrate --out the recordings sheet",
        None,
        lambda lab, tmp, _: ["calibrate", str(lab), "--out", str(lab / "recordings.tsv")],
        2,
        ("lies inside",),
        "refused",
    ),
    Case(
        "calibrate --out the dataset folder",
        None,
        lambda lab, tmp, _: ["calibrate", str(lab), "--out", str(lab)],
        2,
        ("is the input",),
        "refused",
    ),
    Case(
        "calibrate --recordings-out inside the dataset",
        None,
        lambda lab, tmp, _: [
            "calibrate",
            str(lab),
            "--out",
            str(tmp / "c.csv"),
            "--recordings-out",
            str(lab / "r.csv"),
        ],
        2,
        ("lies inside",),
        "refused",
        no_output=("c.csv",),
    ),
    Case(
        "validate --out inside the dataset",
        None,
        lambda lab, tmp, _: ["validate", str(lab), "--out", str(lab / "validation.txt")],
        2,
        ("lies inside",),
        "refused",
    ),
    Case(
        "simulate --force onto a folder aceval did not write",
        lambda lab: None,
        lambda lab, tmp, _: ["simulate", "box", "--out", str(lab), "--force"],
        2,
        ("not written by aceval",),
        "refused",
    ),
    Case(
        "import --out inside its source",
        None,
        lambda lab, tmp, _: ["import", "hugadb", str(lab), "--out", str(lab / "imported")],
        2,
        ("lies inside",),
        "refused",
    ),
    # silent wrong results, now flagged
    Case(
        "right_axis declared with the wrong sign",
        lambda lab: set_right_axis(lab, "IMU4", "-y"),
        calibrate,
        0,
        ("calibrations",),
        "flag",
        flags={("IMU4", None): {"backward"}},
    ),
    Case(
        "the static trial of the thigh taken seated (turned 90 deg about its right axis)",
        static_seated("IMU4", 90.0),
        calibrate,
        0,
        ("calibrations", "taken seated or leaning"),
        "flag",
        flags={("IMU4", None): {"static_not_standing"}},
    ),
    Case(
        "the static trial of the chest taken leaning (turned 20 deg about its right axis)",
        static_seated("IMU2", 20.0),
        calibrate,
        0,
        ("calibrations", "taken seated or leaning"),
        "flag",
        flags={("IMU2", None): {"static_not_standing"}},
    ),
    Case(
        "right_axis +z for a sensor whose y points right",
        lambda lab: set_right_axis(lab, "IMU4", "+z"),
        calibrate,
        0,
        ("calibrations",),
        "flag",
        flags={("IMU4", None): {"backward", "right_axis_mismatch"}},
    ),
    Case(
        "acc_x and acc_y swapped (mirrored frame)",
        swap_acc_xy,
        calibrate,
        0,
        ("calibrations",),
        "flag",
        flags={("IMU2", None): {"gyro_acc_inconsistent"}},
    ),
    Case(
        "random 3-D motion instead of sit-to-stand (5 repetitions, every IMU recorded)",
        random_rotation,
        calibrate,
        0,
        ("calibrations", "IMU4: in T3 its angular speed rises and falls with no other sensor"),
        "flag",
        # Kong's own limits (planarity, normal) pass some subsets of random motion (before this
        # check: 7-19.5 deg unflagged); its timing against the test's other sensors does not
        flags={("IMU4", "T3"): {"not_moving_with_others"}},
        fixture="full_lab",
        untouched_tests=("T5", "T6"),
    ),
    Case(
        "random 3-D motion instead of bowing, the only IMU recorded in it (3 repetitions)",
        lambda lab: random_rotation(lab, "IMU2", "T1"),
        calibrate,
        0,
        ("calibrations",),
        "flag",
        # no other sensor in the test to time it against: the axis methods are flagged by their
        # own limits; Kong's and the combined (which then rests on Kong's) are not (a blind spot,
        # config/README.md)
        flags={("IMU2", "T1", "axis methods"): {"low_rho", "axes_disagree", "axis_near_vertical"}},
    ),
    Case(
        "chest and right thigh sensors exchanged (every IMU recorded)",
        exchanged("IMU2", "IMU4"),
        calibrate,
        0,
        ("calibrations", "moves in", "a test that does not calibrate it"),
        "flag",
        flags={
            ("IMU2", None): {"unexpected_motion_pattern"},
            ("IMU4", None): {"unexpected_motion_pattern"},
        },  # fmt: skip
        fixture="full_lab",
    ),
    Case(
        "right thigh and right shank sensors exchanged (every IMU recorded)",
        exchanged("IMU4", "IMU5"),
        calibrate,
        0,
        ("calibrations", "labels exchanged"),
        "flag",
        flags={
            ("IMU4", None): {"unexpected_motion_pattern"},
            ("IMU5", None): {"unexpected_motion_pattern"},
        },  # fmt: skip
        fixture="full_lab",
    ),
    Case(
        "left and right thigh sensors exchanged (every IMU recorded)",
        exchanged("IMU4", "IMU7"),
        calibrate,
        0,
        ("calibrations", "swings with the other side's segments"),
        "flag",
        flags={
            ("IMU4", None): {"opposite_side_timing"},
            ("IMU7", None): {"opposite_side_timing"},
        },  # fmt: skip
        fixture="full_lab",
    ),
    Case(
        "clipped at 0.8 g with no range declared (validation)",
        clip_shank,
        validate,
        0,
        ("T4_R1_IMU5.csv", "sit at +-0.8 g", "clipped below the declared range"),
        "warning",
    ),
    Case(
        "clipped at 0.8 g with no range declared (calibration)",
        clip_shank,
        calibrate,
        0,
        ("left out", "T4_R1_IMU5.csv", "clipped"),
        "flag",
        left_out=("IMU5",),
    ),
    Case(
        "a typo in an acc_range_g region",
        lambda lab: edit(lab / "dataset.yaml", "lower_body: 8.0", "lower_bdy: 8.0"),
        validate,
        1,
        ("dataset.yaml", "acc_range_g names region 'lower_bdy'"),
        "error",
    ),
    sheet_case(
        "rep 01 beside rep 1",
        "recordings.tsv",
        "T1\t2\tIMU2",
        "T1\t01\tIMU2",
        "recordings.tsv line",
        "duplicate recording S1 frontal T1 1 IMU2",
    ),
    Case(
        "two rows pointing at one file",
        lambda lab: edit(lab / "recordings.tsv", "T1_R2_IMU2.csv", "T1_R1_IMU2.csv"),
        validate,
        1,
        ("recordings.tsv line", "also the file of line"),
        "error",
    ),
    Case(
        "duplicate ground-truth rows",
        lambda lab: (lab / "ground_truth.tsv").write_text(
            (lab / "ground_truth.tsv").read_text()
            + (lab / "ground_truth.tsv").read_text().splitlines()[1]
            + "\n"
        ),
        validate,
        1,
        ("ground_truth.tsv line", "more than one row"),
        "error",
    ),
    Case(
        "transposed ground truth",
        transpose_truth,
        calibrate,
        0,
        ("WARNING", "transposed"),
        "warning",
    ),
    Case(
        "a ;-separated file, met by the pass that reads it",
        semicolons,
        calibrate,
        1,
        ("T1_R1_IMU2.csv", "comma-separated", "no file written"),
        "error",
        no_output=("out.csv",),
    ),
    Case(
        "a NaN sample, met by the pass that reads it",
        lambda lab: edit(lab / T1, "\n0.05,", "\nnan,"),
        calibrate,
        1,
        (T1, "NaN, inf or non-numeric", "line 7", "no file written"),
        "error",
        no_output=("out.csv",),
    ),
    # names that a CSV reader takes for missing: their rows would drop out of every results table
    Case(
        "a subject named NA",
        lambda lab: [
            edit(lab / sheet, "S1\t", "NA\t")
            for sheet in ("subjects.tsv", "recordings.tsv", "ground_truth.tsv")
        ],
        validate,
        1,
        ("subjects.tsv line 2", "subject 'NA' reads as a missing value"),
        "error",
    ),
    sheet_case(
        "the chest's side written n/a",
        "imus.tsv",
        "\tchest\tcenter\t",
        "\tchest\tn/a\t",
        "imus.tsv line 2",
        "side 'n/a' reads as a missing value",
    ),
    # crashes, now clear errors
    Case(
        "right_axis empty",
        lambda lab: set_right_axis(lab, "IMU2", ""),
        validate,
        1,
        ("imus.tsv line", "right_axis '' is not one of"),
        "error",
    ),
    Case(
        "right_axis xy",
        lambda lab: set_right_axis(lab, "IMU2", "xy"),
        validate,
        1,
        ("imus.tsv line", "right_axis 'xy' is not one of"),
        "error",
    ),
    Case(
        "dataset.yaml is a list",
        lambda lab: (lab / "dataset.yaml").write_text("- name: x\n- fs: 100\n"),
        validate,
        1,
        ("dataset.yaml", "must be a mapping"),
        "error",
    ),
    Case(
        "dataset.yaml lines without colons",
        lambda lab: (lab / "dataset.yaml").write_text("name x\nrate 100\n"),
        validate,
        1,
        ("dataset.yaml", "must be a mapping"),
        "error",
    ),
    yaml_case(
        "units: g",
        "units:\n  acc: g\n  gyr: deg/s\n",
        "units: g\n",
        "units: 'g' is not of type 'object'",
    ),
    yaml_case(
        "acc_range_g: 8",
        "acc_range_g:\n  upper_body: 4.0\n  lower_body: 8.0\n",
        "acc_range_g: 8\n",
        "acc_range_g: 8 is not of type 'object'",
    ),
    yaml_case(
        "gyr_range_dps: 400 dps",
        "gyr_range_dps: 400.0",
        "gyr_range_dps: 400 dps",
        "gyr_range_dps: '400 dps' is not of type 'number'",
    ),
    yaml_case(
        "sampling_rate_hz: .inf",
        "sampling_rate_hz: 100.0",
        "sampling_rate_hz: .inf",
        "sampling_rate_hz",
    ),
    yaml_case("units.acc mg", "acc: g", "acc: mg", "units.acc: 'mg' is not one of"),
    Case(
        "nothing to calibrate",
        lambda lab: (lab / "calibrates.tsv").write_text("test\timu\n"),
        calibrate,
        1,
        ("nothing to calibrate", "no file written"),
        "error",
        no_output=("out.csv",),
    ),
    Case(
        "apply: a calibration matrix that is not a rotation (r11 doubled)",
        None,
        edited_calibrations(lambda t: t.assign(r11=2 * t["r11"])),
        1,
        ("broken.csv", "S1 frontal", "not a rotation"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply: a calibration cell that is not a number",
        None,
        edited_calibrations(lambda t: t.assign(r12="x")),
        1,
        ("broken.csv", "not all numbers"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply: the calibrations file is missing",
        None,
        calibrations_copy(lambda good, broken: None),
        1,
        ("broken.csv", "file is missing"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply: the calibrations file is binary",
        None,
        calibrations_copy(lambda good, broken: broken.write_bytes(bytes(range(256)) * 8)),
        1,
        ("broken.csv",),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply: calibrations made from other recordings (a file changed since)",
        nudge_one_recording,
        apply("copy"),
        1,
        (
            "calibrations.csv",
            "subject S1",
            "other recordings",
            "--other-dataset",
            "nothing written",
        ),
        "refused",
        no_output=("copy",),
    ),
    Case(
        "apply: a recording it cannot read (;-separated)",
        semicolons,
        apply("copy"),
        1,
        ("T1_R1_IMU2.csv", "comma-separated", "nothing written"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "apply: a recording whose time goes back",
        lambda lab: edit(lab / T1, "\n0.05,", "\n0.03,"),
        apply("copy"),
        1,
        (T1, "not strictly increasing", "nothing written"),
        "error",
        no_output=("copy",),
    ),
    Case(
        "calibrate --out under a file (no folder can be made there)",
        lambda lab: (lab.parent / "afile").write_text("x"),
        lambda lab, tmp, _: ["calibrate", str(lab), "--out", str(tmp / "afile" / "out.csv")],
        2,
        ("afile", "is a file"),
        "refused",
    ),
    Case(
        "apply with an empty calibrations file",
        empty_calibrations,
        lambda lab, tmp, _: [
            "apply",
            str(lab),
            "--calibrations",
            str(tmp / "empty.csv"),
            "--out",
            str(tmp / "copy"),
        ],
        1,
        ("empty.csv", "holds no calibrations"),
        "error",
        no_output=("copy",),
    ),
    # already handled before the sweep: file and sheet problems
    Case(
        "missing file",
        lambda lab: (lab / T1).unlink(),
        validate,
        1,
        (T1, "file is missing"),
        "error",
    ),
    Case(
        "binary garbage",
        lambda lab: (lab / T1).write_bytes(b"\x00\xff\xfe garbage"),
        validate,
        1,
        (T1, "cannot be read as CSV"),
        "error",
    ),
    Case(
        "missing column",
        lambda lab: (lab / T1).write_text("t,acc_x,acc_y\n0,1,2\n"),
        validate,
        1,
        (T1, "missing column(s) acc_z"),
        "error",
    ),
    Case(
        "renamed column",
        lambda lab: edit(lab / T1, "gyr_z", "gyro_z"),
        validate,
        1,
        (T1, "missing column(s) gyr_z"),
        "error",
    ),
    Case(
        "NaN sample",
        lambda lab: edit(lab / T1, "\n0.05,", "\nnan,"),
        validate,
        1,
        (T1, "NaN, inf or non-numeric"),
        "error",
    ),
    Case(
        "duplicate time",
        lambda lab: edit(lab / T1, "\n0.05,", "\n0.04,"),
        validate,
        1,
        (T1, "duplicate time at line 7"),
        "error",
    ),
    Case(
        "decreasing time",
        lambda lab: edit(lab / T1, "\n0.05,", "\n0.01,"),
        validate,
        1,
        (T1, "decreasing time at line 7"),
        "error",
    ),
    Case(
        "wrong sampling rate",
        lambda lab: edit(lab / "dataset.yaml", "sampling_rate_hz: 100.0", "sampling_rate_hz: 50"),
        validate,
        1,
        ("T0_R1_IMU2.csv", "sampling rate in t is 100 Hz, dataset.yaml declares 50 Hz"),
        "error",
    ),
    Case(
        "wrong acceleration units",
        lambda lab: edit(lab / "dataset.yaml", "acc: g", "acc: m/s^2"),
        validate,
        1,
        ("T0_R1_IMU2.csv", "acceleration at rest is 0.1", "are units.acc (m/s^2) right?"),
        "error",
    ),
    sheet_case(
        "unknown IMU in recordings",
        "recordings.tsv",
        "T1\t2\tIMU2",
        "T1\t2\tIMU9",
        "recordings.tsv line",
        "imu 'IMU9' is not defined in imus.tsv",
    ),
    sheet_case(
        "unknown subject",
        "recordings.tsv",
        "S1\tfrontal\tT1\t2",
        "S2\tfrontal\tT1\t2",
        "recordings.tsv line",
        "subject 'S2' is not defined in subjects.tsv",
    ),
    sheet_case(
        "unknown test",
        "recordings.tsv",
        "T1\t2\tIMU2",
        "T7\t2\tIMU2",
        "recordings.tsv line",
        "test 'T7' is not defined in tests.tsv",
    ),
    sheet_case(
        "duplicate recording row",
        "recordings.tsv",
        "T1\t2\tIMU2",
        "T1\t1\tIMU2",
        "recordings.tsv line",
        "duplicate recording S1 frontal T1 1 IMU2",
    ),
    sheet_case(
        "rep zero", "recordings.tsv", "T1\t2\tIMU2", "T1\t0\tIMU2", "recordings.tsv line", "rep '0'"
    ),
    Case(
        "no static recording",
        lambda lab: edit(
            lab / "recordings.tsv", "S1\tfrontal\tT0\t1\tIMU2\tdata/S1/frontal/T0_R1_IMU2.csv\n", ""
        ),
        validate,
        1,
        ("calibrates.tsv", "IMU IMU2", "no static test"),
        "error",
    ),
    sheet_case(
        "bad right_axis word",
        "imus.tsv",
        "\t-y",
        "\tright",
        "imus.tsv line",
        "right_axis 'right' is not one of",
    ),
    sheet_case(
        "bad test kind",
        "tests.tsv",
        "T1\tmotion",
        "T1\tmoving",
        "tests.tsv line 3",
        "kind 'moving'",
    ),
    Case(
        "bad first_phase",
        lambda lab: (
            pd.read_csv(lab / "tests.tsv", sep="\t", dtype=str, keep_default_na=False)
            .assign(first_phase="forward")
            .to_csv(lab / "tests.tsv", sep="\t", index=False)
        ),
        validate,
        1,
        ("tests.tsv line", "first_phase 'forward'"),
        "error",
    ),
    sheet_case(
        "unknown IMU in calibrates",
        "calibrates.tsv",
        "T1\tIMU2",
        "T1\tIMU8",
        "calibrates.tsv line",
        "IMU 'IMU8' is not defined",
        count=1,
    ),
    Case(
        "missing sheet",
        lambda lab: (lab / "imus.tsv").unlink(),
        validate,
        1,
        ("imus.tsv", "sheet is missing"),
        "error",
    ),
    Case(
        "missing sheet column",
        lambda lab: edit(lab / "recordings.tsv", "\tpath", "\tfile"),
        validate,
        1,
        ("recordings.tsv", "missing column(s) path"),
        "error",
    ),
    Case(
        "test defined twice",
        lambda lab: (lab / "tests.tsv").write_text(
            (lab / "tests.tsv").read_text() + (lab / "tests.tsv").read_text().splitlines()[2] + "\n"
        ),
        validate,
        1,
        ("tests.tsv line", "test 'T1' is defined twice"),
        "error",
    ),
    Case(
        "subject defined twice",
        lambda lab: (lab / "subjects.tsv").write_text(
            (lab / "subjects.tsv").read_text()
            + (lab / "subjects.tsv").read_text().splitlines()[1]
            + "\n"
        ),
        validate,
        1,
        ("subjects.tsv line 3", "subject 'S1' is defined twice"),
        "error",
    ),
    Case(
        "ground truth not a rotation",
        lambda lab: (
            pd.read_csv(lab / "ground_truth.tsv", sep="\t", dtype=str)
            .assign(r11="2.0")
            .to_csv(lab / "ground_truth.tsv", sep="\t", index=False)
        ),
        validate,
        1,
        ("ground_truth.tsv line 2", "not a rotation matrix"),
        "error",
    ),
    Case(
        "unknown dataset.yaml key",
        lambda lab: (lab / "dataset.yaml").write_text(
            (lab / "dataset.yaml").read_text() + "acc_range: 8\n"
        ),
        validate,
        0,
        ("dataset.yaml", "unknown key 'acc_range'"),
        "warning",
    ),
]


def checksums(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input(case, request, good_calibrations, tmp_path):
    pristine = request.getfixturevalue(case.fixture)
    lab = tmp_path / "lab"
    shutil.copytree(pristine, lab)
    other = tmp_path / "other"  # a sibling dataset that a '../other/...' path would reach
    shutil.copytree(pristine / "data", other / "data")
    if case.breakage:
        case.breakage(lab)
    inputs = {"lab": checksums(lab), "other": checksums(other)}
    extra = [p for p in tmp_path.iterdir() if p.name not in ("lab", "other")]
    inputs |= {p.name: checksums(p) for p in extra if p.is_dir()}

    argv = case.command(lab, tmp_path, good_calibrations)
    files_before = {p for p in tmp_path.rglob("*") if p.is_file()}
    result = aceval(*argv)

    output = result.said
    assert result.code == case.code, output[-3000:]
    for text in case.says:
        assert text in output, f"{text!r} not in:\n{output[-3000:]}"
    assert checksums(lab) == inputs["lab"], "an input file changed"
    assert checksums(other) == inputs["other"], "a sibling dataset changed"
    for name, before in inputs.items():
        if name not in ("lab", "other"):
            assert checksums(tmp_path / name) == before, f"{name} changed"
    for name in case.no_output:
        assert not (tmp_path / name).exists(), f"{name} was written"
    assert not [p for p in tmp_path.rglob(".*") if p.name != MARKER], (
        "hidden temporary files were left"
    )
    if case.outcome in ("error", "refused"):  # nothing new anywhere under the folder
        new = {p for p in tmp_path.rglob("*") if p.is_file()} - files_before
        assert not new, f"a refused or failed command wrote {sorted(map(str, new))}"
    if case.outcome in ("flag", "warning") and (tmp_path / "out.csv").exists():
        # apply on the defective copy: body-frame copies that validate, or a clear refusal
        applied = tmp_path / "applied"
        calibrations = str(tmp_path / "out.csv")
        applying = aceval("apply", lab, "--calibrations", calibrations, "--out", applied)
        said = applying.err
        assert applying.code in (0, 1), said[-3000:]
        assert (applying.code == 0) == applied.is_dir(), said[-3000:]
        if applying.code == 0:
            validating = aceval("validate", applied)
            assert validating.code == 0, validating.out[-3000:]
        assert checksums(lab) == inputs["lab"], "apply changed an input file"
    if case.left_out:
        calibrations = pd.read_csv(tmp_path / "out.csv", keep_default_na=False)
        assert not calibrations["imu"].isin(case.left_out).any(), "a left-out IMU was calibrated"
        assert not defect_flags(calibrations).any(), "an IMU without a defect was flagged"
    if case.flags:
        clean = request.getfixturevalue(
            "good_calibrations" if case.fixture == "pristine" else f"{case.fixture}_calibrations"
        )
        read = lambda path: pd.read_csv(path, keep_default_na=False)  # noqa: E731
        assert_flags(read(tmp_path / "out.csv"), read(clean), case)


def assert_flags(calibrations: pd.DataFrame, clean: pd.DataFrame, case: Case) -> None:
    """Every affected row carries one of its case's flags (beside any others: flags are joined
    by ';'); the other IMUs' rows, and the ``untouched_tests`` of the affected ones, carry the
    flags of the clean copy's same calibration (the axis methods' own limits can flag clean data:
    config/README.md's rates), and no more.
    """
    names = calibrations["flag"].str.split(";").map(set)
    for (imu, test, *methods), allowed in case.flags.items():
        rows = (calibrations["imu"] == imu) & ((calibrations["test"] == test) if test else True)
        if methods:  # ("axis methods",): the three axis methods only
            rows &= calibrations["method"].isin(functional_design())
        shown = calibrations.loc[rows, ["test", "method", "flag"]].to_string()
        assert rows.any() and names[rows].map(allowed.intersection).map(bool).all(), shown
    untouched = ~calibrations["imu"].isin([imu for imu, *_ in case.flags]) | calibrations[
        "test"
    ].isin(case.untouched_tests)
    key = ["subject", "sensor_set", "imu", "test", "method", "repetitions"]
    compared = calibrations[untouched].merge(clean, on=key, suffixes=("", "_clean"), how="left")
    changed = compared[compared["flag"] != compared["flag_clean"]]
    assert changed.empty, f"rows without a defect flagged:\n{changed[key[2:] + ['flag']]}"


def test_the_matrix_covers_every_outcome():
    counts = pd.Series([c.outcome for c in CASES]).value_counts().to_dict()
    assert set(counts) == {"error", "refused", "warning", "flag"}, counts


@pytest.mark.slow
def test_force_replaces_a_folder_aceval_wrote(pristine, good_calibrations, tmp_path):
    out = tmp_path / "copy"
    argv = ["apply", str(pristine), "--calibrations", str(good_calibrations), "--out", str(out)]
    assert aceval(*argv).code == 0 and (out / MARKER).is_file()
    assert aceval(*argv).code == 2  # not empty, no --force
    assert aceval(*argv, "--force").code == 0 and (out / "applied_calibrations.tsv").is_file()


@pytest.mark.slow
def test_sigterm_leaves_no_partial_output(tmp_path):
    """Snakemake stops a job with SIGTERM: the staging folder and temporary files go with it."""
    out = tmp_path / "sim"
    process = subprocess.Popen(
        [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(out), "--subjects", "1"],
        stderr=subprocess.PIPE,
    )
    deadline = time.time() + 30
    while time.time() < deadline and not any(p.name.endswith(".sim") for p in tmp_path.iterdir()):
        time.sleep(0.05)  # wait until the staging folder exists
    assert any(p.name.endswith(".sim") for p in tmp_path.iterdir()), (
        "simulate never started writing"
    )
    time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=30) == 128 + signal.SIGTERM
    assert list(tmp_path.iterdir()) == [], [p.name for p in tmp_path.iterdir()]


@pytest.mark.slow
def test_apply_keeps_times_columns_and_truth_and_its_copy_validates(pristine, tmp_path):
    """Epoch times (1.7e9 s) come out as the input's text; the vendor's quaternions are turned
    with the frame (world vectors unchanged); ground_truth.tsv is carried as truth R_cal^T, whose
    angle from the identity is the calibration's error; the copy validates."""
    lab = tmp_path / "lab"
    shutil.copytree(pristine, lab)
    quat = Rotation.from_euler("zyx", [30, -20, 10], degrees=True)
    for path in sorted((lab / "data").rglob("*.csv")):
        table = pd.read_csv(path, dtype=str)
        table["t"] = [repr(1.7e9 + float(t)) for t in table["t"]]
        table[["quat_w", "quat_x", "quat_y", "quat_z"]] = quat.as_quat(scalar_first=True)
        table.to_csv(path, index=False)
    calibrations = tmp_path / "calibrations.csv"
    assert aceval("calibrate", str(lab), "--out", str(calibrations), "--method", "kong").code == 0
    copy = tmp_path / "copy"
    assert (
        aceval("apply", str(lab), "--calibrations", str(calibrations), "--out", str(copy)).code == 0
    )
    assert aceval("validate", str(copy)).code == 0

    source, body = pd.read_csv(lab / T1, dtype=str), pd.read_csv(copy / T1, dtype=str)
    assert (body["t"] == source["t"]).all() and body["t"].nunique() == len(body)
    applied = pd.read_csv(copy / "applied_calibrations.tsv", sep="\t")
    row = applied[(applied["subject"] == "S1") & (applied["imu"] == "IMU2")].iloc[0]
    R = row[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float).reshape(3, 3)
    acc_sensor = source[["acc_x", "acc_y", "acc_z"]].to_numpy(float)
    acc_body = body[["acc_x", "acc_y", "acc_z"]].to_numpy(float)
    # written one significant digit finer than the source's 6 (g near 1: 5e-7)
    np.testing.assert_allclose(acc_body, acc_sensor @ R.T, atol=1e-6)
    turned = Rotation.from_quat(
        body[["quat_w", "quat_x", "quat_y", "quat_z"]].to_numpy(float), scalar_first=True
    )
    np.testing.assert_allclose(turned.apply(acc_body), quat.apply(acc_sensor), atol=2e-6)

    truth = load_dataset(lab).ground_truth_matrix("S1", row["sensor_set"], "IMU2")
    copied = load_dataset(copy).ground_truth_matrix("S1", row["sensor_set"], "IMU2")
    np.testing.assert_allclose(copied, truth @ R.T, atol=1e-12)
    error = Rotation.from_matrix(R @ truth.T).magnitude()
    assert np.isclose(Rotation.from_matrix(copied).magnitude(), error) and error > 0


@pytest.mark.slow
def test_sigterm_of_calibrate_leaves_all_of_its_outputs_or_none(pristine, tmp_path):
    """`aceval calibrate` with nine outputs, stopped by SIGTERM once it has staged the first:
    none of them is in place and no temporary is left (or, had it finished first, all nine)."""
    names = ["out", "recordings-out", "axes-out", "pairs-out", "correlations-out", "findings-out",
             "angles-out", "retest-out", "plan-out"]  # fmt: skip
    argv = [sys.executable, "-m", "aceval", "calibrate", str(pristine)]
    for name in names:
        argv += [f"--{name}", str(tmp_path / "out" / f"{name}.txt")]
    process = subprocess.Popen(argv, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline and not [
        p for p in tmp_path.glob("out/.aceval-*") if p.stat().st_size > 0
    ]:
        time.sleep(0.01)  # until it has staged its first output (the others are reserved empty)
    process.send_signal(signal.SIGTERM)
    code = process.wait(timeout=60)
    written = sorted(p.name for p in (tmp_path / "out").glob("*")) if code == 0 else []
    assert code in (0, 128 + signal.SIGTERM)
    assert written in ([], sorted(f"{name}.txt" for name in names))
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == written


def test_an_output_set_is_written_together_or_not_at_all(tmp_path):
    """FileSet: nothing in place before the block ends, nothing after an error, a killed run's
    temporaries (unlocked) removed by the next run writing the same output and nobody else's
    touched (names matched in full: another output's, or one that only looks like a process id),
    and an output under a file refused before any work."""
    from aceval.data.safety import FileSet, UnsafeOutputError, claim

    (tmp_path / ".aceval-1-0123abcd.a.csv").write_text("left by a killed run")
    (tmp_path / ".aceval-1-0123abcd.a.csv.1").write_text("another output's temporary")
    (tmp_path / ".a.csv.1.x1y2").mkdir()  # not aceval's naming at all
    (tmp_path / ".aceval-1-0123abcd.copy").mkdir()
    paths = [tmp_path / "a.csv", tmp_path / "sub" / "b.csv"]
    with pytest.raises(RuntimeError), FileSet(paths) as files:
        files.write(paths[0], lambda tmp: Path(tmp).write_text("a"))
        raise RuntimeError("the work failed")
    others = [".a.csv.1.x1y2", ".aceval-1-0123abcd.a.csv.1", ".aceval-1-0123abcd.copy"]
    assert sorted(p.name for p in tmp_path.rglob("*")) == [*others, "sub"]
    with FileSet(paths) as files:
        for path in paths:
            files.write(path, lambda tmp: Path(tmp).write_text("done"))
        assert not any(p.exists() for p in paths)
    assert all(p.read_text() == "done" for p in paths)
    assert sorted(p.name for p in tmp_path.rglob(".*")) == others
    claim(tmp_path / "copy")
    assert sorted(p.name for p in tmp_path.rglob(".*")) == others[:2]
    (tmp_path / "afile").write_text("x")
    with pytest.raises(UnsafeOutputError, match="is a file"):
        FileSet([tmp_path / "afile" / "out.csv"])
    # a second aceval writing the same output while the first works is refused
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from aceval.data.safety import FileSet; "
         f"FileSet([{str(paths[0])!r}]); print('held', flush=True); time.sleep(30)"],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(UnsafeOutputError, match=f"process {holder.pid}.*is writing"):
            FileSet([paths[0]])
    finally:
        holder.kill()
        holder.wait()
    with FileSet([paths[0]]):  # its reservation is a leftover now: removed, the output free
        pass
    assert sorted(p.name for p in tmp_path.rglob(".*")) == others[:2]


# --- the recording reader on arbitrary bytes ----------------------------------------------------

HEADER = b"t,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n"
VALID = HEADER + b"".join(b"%.2f,0,0,-1,%d,0,0\n" % (k / 100, k) for k in range(20))


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.one_of(
        st.binary(max_size=400),
        st.integers(0, len(VALID)).map(lambda n: VALID[:n]),
        st.tuples(st.integers(0, len(VALID) - 1), st.binary(min_size=1, max_size=8)).map(
            lambda cut: VALID[: cut[0]] + cut[1] + VALID[cut[0] + 1 :]
        ),
    )
)
def test_reader_gives_a_table_or_a_clear_error(tmp_path, content):
    path = tmp_path / "recording.csv"
    path.write_bytes(content)
    try:
        values = recording_values(path)
    except RecordingError as exc:
        assert str(exc).startswith(str(path)) and exc.cause
        return
    assert values.ndim == 2 and values.shape[1] == 7


@pytest.mark.slow
def test_read_recording_names_the_file_and_cause(pristine, tmp_path):
    lab = tmp_path / "lab"
    shutil.copytree(pristine, lab)
    (lab / T1).write_text(HEADER.decode() + "0,1,2,3,4,5,6\n")
    with pytest.raises(RecordingError, match=r"T1_R1_IMU2.csv: 1 samples"):
        load_dataset(lab).read_recording(T1)
    os.remove(lab / T1)
    with pytest.raises(RecordingError, match="file is missing"):
        load_dataset(lab).read_recording(T1)


def defect_flags(calibrations: pd.DataFrame) -> pd.Series:
    """True for the rows with a flag that says something is wrong: a subset's spread from its
    full set (``unstable``, :data:`SPREAD_FLAGS`) is a measurement of the data, not a defect."""
    names = calibrations["flag"].astype(str).str.split(";")
    return names.map(lambda flags: bool(set(flags) - {"", *SPREAD_FLAGS}))


@pytest.mark.slow
def test_right_axis_plus_z_flags_every_row_on_five_repetitions(tmp_path):
    """right_axis '+z' for the frontal right thigh, on a 5-repetition subject: every calibration
    of that IMU is flagged, every row whose y0 is more than 60 deg from the declared right axis is
    flagged (whatever its subset's own direction vote), and no other IMU gets a flag."""
    lab = tmp_path / "five"
    assert aceval("simulate", "kong", "--out", str(lab), "--seed", "1", "--subjects", "1").code == 0
    sheet = pd.read_csv(lab / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    sheet.loc[(sheet["imu"] == "IMU4") & (sheet["sensor_set"] == "frontal"), "right_axis"] = "+z"
    sheet.to_csv(lab / "imus.tsv", sep="\t", index=False)
    out = tmp_path / "out.csv"
    assert aceval("calibrate", str(lab), "--out", str(out)).code == 0
    table = pd.read_csv(out, keep_default_na=False)
    assert set(table["n_reps"]) == {1, 2, 3, 4, 5}
    defective = (table["imu"] == "IMU4") & (table["sensor_set"] == "frontal")
    assert (table.loc[defective, "flag"] != "").all()
    assert not defect_flags(table.loc[~defective]).any()
    angle = pd.to_numeric(table["right_axis_angle_deg"], errors="coerce")
    assert (table.loc[angle > 60, "flag"] != "").all()
