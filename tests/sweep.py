"""Issue 41's sweep, reconstructed: each case breaks a copy of a small simulated dataset (or the
environment) one way, runs ``aceval`` as a user would (in this process as a subprocess would run it,
tests/runner.py; in a subprocess where only a process shows the outcome: a hang, a signal, a
full disk, a pipe) and says what came out, one of

* ``error``, ``refused``: a non-zero exit with one line naming the file (or option) and the
  cause, no traceback, no partial output, no input changed;
* ``flag``, ``warning``: exit 0 and the defect named (a flag in the calibrations, a line on screen);
* ``correct``: exit 0 and the right number (or the right files);
* ``silent_wrong``, ``traceback``, ``partial``, ``input_changed``, ``hang``, ``wrong_refusal``,
  ``misleading``: what the issue counted as failures.

Each case states the outcome it expects; ``tests/test_bad_input_sweep.py`` asserts it, and
``benchmarks/bad_input_sweep.py`` counts the observed outcomes (of this checkout, or of an older
one with ``PYTHONPATH``: the cases use nothing but the command line and the files).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from .datasets import CleanDatasets
from .runner import Result, aceval_process
from .runner import aceval as aceval_here

R_COLUMNS = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
ACC = ["acc_x", "acc_y", "acc_z"]
GYR = ["gyr_x", "gyr_y", "gyr_z"]
QUAT = ["quat_w", "quat_x", "quat_y", "quat_z"]
FAILURES = (
    "silent_wrong",
    "traceback",
    "partial",
    "input_changed",
    "hang",
    "wrong_refusal",
    "misleading",
)
#: a calibration farther than this from the clean copy's same calibration is a wrong number
WRONG_DEG = 2.0


#: every command of every case in a subprocess, not only where the case needs one
#: (benchmarks/bad_input_sweep.py: an older checkout is swept through ``PYTHONPATH``)
IN_SUBPROCESSES = False


def aceval(
    *args, cwd=None, timeout: float | None = None, limit_bytes: int | None = None, user=None
):
    """``aceval *args`` as a user runs it: its exit code, stdout and stderr. In this process
    (tests/runner.py: as a subprocess would run it), or in a subprocess where only a process shows
    the outcome: one that may hang (``timeout``, s), a full disk (``limit_bytes``: writes beyond
    it fail with EFBIG), another ``user``."""
    if IN_SUBPROCESSES or timeout is not None or limit_bytes is not None or user is not None:
        return aceval_process(
            *args, cwd=cwd, timeout=timeout or 300, limit_bytes=limit_bytes, user=user
        )
    return aceval_here(*args, cwd=cwd)


def checksums(*folders: Path) -> dict[str, str]:
    out = {}
    for folder in folders:
        for path in sorted(Path(folder).rglob("*")):
            if path.is_file() and not path.is_symlink():
                out[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def hidden_leftovers(folder: Path) -> list[str]:
    return [str(p) for p in Path(folder).rglob(".*") if p.name not in (".aceval-output",)]


def refusal(result: Result, says: tuple[str, ...], kind: str = "error") -> str:
    """``kind`` when the command failed cleanly saying every one of ``says``; else what it did."""
    if result.code is None:
        return "hang"
    if result.traceback:
        return "traceback"
    if result.code == 0:
        return "silent_wrong"
    lowered = result.said.lower()
    return kind if all(s.lower() in lowered for s in says) else "misleading"


# --- datasets -----------------------------------------------------------------------------------


#: the clean datasets the cases copy or read (tests/datasets.py), by the name the benchmark knows
Workspace = CleanDatasets


def sheet(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, sep="\t", dtype=str, keep_default_na=False)


def write_sheet(table: pd.DataFrame, path: Path) -> None:
    table.to_csv(path, sep="\t", index=False)


def read_recording(path: Path) -> pd.DataFrame:
    return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)


def write_recording(table: pd.DataFrame, path: Path) -> None:
    if path.suffix == ".parquet":
        table.to_parquet(path, index=False)
    else:
        table.to_csv(path, index=False, float_format="%.7g")


def recordings_of(lab: Path, imu=None, test=None, sensor_set=None, rep=None) -> list[Path]:
    table = sheet(lab / "recordings.tsv")
    chosen = pd.Series(True, index=table.index)
    for column, value in (("imu", imu), ("test", test), ("sensor_set", sensor_set), ("rep", rep)):
        if value is not None:
            chosen &= table[column] == str(value)
    return [lab / p for p in table.loc[chosen, "path"]]


def change_recordings(paths, change: Callable[[pd.DataFrame], pd.DataFrame]) -> None:
    for path in paths:
        write_recording(change(read_recording(path)), path)


def drop_yaml_key(lab: Path, key: str) -> None:
    import yaml

    meta = yaml.safe_load((lab / "dataset.yaml").read_text())
    meta.pop(key, None)
    (lab / "dataset.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))


def set_yaml_key(lab: Path, key: str, value) -> None:
    import yaml

    meta = yaml.safe_load((lab / "dataset.yaml").read_text())
    meta[key] = value
    (lab / "dataset.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))


def calibrations(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, keep_default_na=False, dtype={"subject": str})


def full_sets(table: pd.DataFrame, method: str = "kong") -> pd.DataFrame:
    table = table[table["method"] == method]
    most = table.groupby(["subject", "sensor_set", "imu", "test"])["n_reps"].transform("max")
    return table[table["n_reps"] == most]


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(Rotation.from_matrix(a @ b.T).magnitude()))


def matrix(row) -> np.ndarray:
    return row[R_COLUMNS].to_numpy(float).reshape(3, 3)


def judged(
    result: Result,
    out: Path,
    clean: Path,
    imus: tuple[str, ...],
    flags: tuple[str, ...] = (),
    says: tuple[str, ...] = (),
    method: str = "kong",
    sensor_set: str = "frontal",
) -> str:
    """A calibrate run on a broken copy: ``flag`` when every calibration of ``imus`` (``method``,
    from all repetitions) carries one of ``flags``, or the IMU was left out with its reason on
    screen (``says``), or each of its calibrations that is farther than :data:`WRONG_DEG` from
    the clean copy's is flagged (by any check); ``correct`` when its numbers are those of the
    clean copy; ``silent_wrong`` when an unflagged one is not.
    """
    if result.code is None:
        return "hang"
    if result.traceback:
        return "traceback"
    if result.code != 0:
        return "wrong_refusal"
    table, reference = full_sets(calibrations(out), method), full_sets(calibrations(clean), method)
    key = ["subject", "sensor_set", "imu", "test"]
    outcome = "correct"
    for imu in imus:
        rows = table[(table["imu"] == imu) & (table["sensor_set"] == sensor_set)]
        if rows.empty:
            said = all(s.lower() in result.said.lower() for s in says) and says
            outcome = "flag" if said else "silent_wrong"
            continue
        names = rows["flag"].astype(str).str.split(";").map(set)
        if flags and names.map(lambda n: bool(n & set(flags))).all():
            outcome = "flag" if outcome != "silent_wrong" else outcome
            continue
        merged = rows.merge(reference, on=key, suffixes=("", "_clean"))
        for _, row in merged.iterrows():
            clean_R = row[[f"{c}_clean" for c in R_COLUMNS]].to_numpy(float).reshape(3, 3)
            if angle_deg(matrix(row), clean_R) > WRONG_DEG:
                if row["flag"] == "":
                    return "silent_wrong"
                outcome = "flag"  # wrong, but flagged (by whichever check)
    return outcome


# --- the cases ----------------------------------------------------------------------------------


@dataclass
class Case:
    name: str
    group: str
    expected: str
    run: Callable[[Workspace, Path], str]


CASES: list[Case] = []


def case(group: str, expected: str, name: str):
    def register(run):
        CASES.append(Case(name, group, expected, run))
        return run

    return register


def negate_acc(table: pd.DataFrame) -> pd.DataFrame:
    return table.assign(**{c: -table[c] for c in ACC})


def _calibrate(ws: Workspace, tmp: Path, lab: Path, *extra) -> tuple[Result, Path]:
    out = tmp / "out.csv"
    return aceval("calibrate", lab, "--out", out, *extra), out


# silent wrong numbers: the accelerometer's sign


@case("silent wrong numbers", "warning", "acc sign reversed in every file, not declared (truth)")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    change_recordings(recordings_of(lab), negate_acc)
    result, out = _calibrate(ws, tmp, lab)
    if result.code != 0:
        return refusal(result, ())
    said = result.said.lower()
    return "warning" if "acc_at_rest" in said else "silent_wrong"


@case(
    "silent wrong numbers", "correct", "acc sign reversed in every file, declared in dataset.yaml"
)
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    change_recordings(recordings_of(lab), negate_acc)
    set_yaml_key(lab, "acc_at_rest", "down")
    result, out = _calibrate(ws, tmp, lab)
    return judged(result, out, ws.clean_calibrations("small"), ("IMU2", "IMU4", "IMU5"))


@case("silent wrong numbers", "warning", "acc sign reversed in one IMU, one sensor set (truth)")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    change_recordings(recordings_of(lab, imu="IMU4"), negate_acc)
    result, out = _calibrate(ws, tmp, lab)
    if result.code != 0:
        return refusal(result, ())
    return (
        "warning"
        if "acc_at_rest" in result.said.lower() and "imu4" in result.said.lower()
        else (judged(result, out, ws.clean_calibrations("small"), ("IMU4",)))
    )


@case("silent wrong numbers", "flag", "acc sign reversed in one IMU of two sensor sets")
def _(ws, tmp):
    lab = ws.copy("kong", tmp)
    change_recordings(recordings_of(lab, imu="IMU4", sensor_set="frontal"), negate_acc)
    (lab / "ground_truth.tsv").unlink()
    result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
    return judged(result, out, ws.clean_calibrations("kong"), ("IMU4",), ("acc_sign_mismatch",))


def with_vendor_quaternions(lab: Path, imu: str) -> None:
    """Quaternions (sensor -> a z-up world) in the static recordings of ``imu``, made from the
    accelerometer as it reads at rest (specific force: up), with heading 0."""
    for path in recordings_of(lab, imu=imu, test="T0"):
        table = read_recording(path)
        up = table[ACC].median().to_numpy(float)
        turn, _ = Rotation.align_vectors([[0, 0, 1]], [up / np.linalg.norm(up)])
        quat = turn.as_quat(scalar_first=True)
        write_recording(table.assign(**dict(zip(QUAT, quat))), path)


@case("silent wrong numbers", "flag", "acc sign reversed in one IMU with vendor quaternions")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    with_vendor_quaternions(lab, "IMU4")
    change_recordings(recordings_of(lab, imu="IMU4"), negate_acc)
    (lab / "ground_truth.tsv").unlink()
    result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
    return judged(result, out, ws.clean_calibrations("small"), ("IMU4",), ("acc_sign_mismatch",))


# silent wrong numbers: identity


@case("silent wrong numbers", "refused", "labels IMU4 <-> IMU7 swapped after calibrating, apply")
def _(ws, tmp):
    lab = ws.copy("kong", tmp)
    table = sheet(lab / "recordings.tsv")
    table["imu"] = table["imu"].replace({"IMU4": "IMU7", "IMU7": "IMU4"})
    write_sheet(table, lab / "recordings.tsv")
    result = aceval(
        "apply", lab, "--calibrations", ws.clean_calibrations("kong"), "--out", tmp / "copy"
    )
    return refusal(result, ("other recordings",), "refused")


def spike(table: pd.DataFrame, g: float) -> pd.DataFrame:
    """One sample of ``g`` g on acc_y (IMU4's declared right axis: out of the plane of its
    movement, where one sample turns Kong's plane most), where the segment turns fastest (inside
    the movement)."""
    table = table.copy()
    table.loc[int(np.argmax(np.linalg.norm(table[GYR].to_numpy(float), axis=1))), "acc_y"] = g
    return table


def applied(folder: Path) -> pd.DataFrame:
    return pd.read_csv(folder / "applied_calibrations.tsv", sep="\t", dtype={"subject": str})


def apply_judged(ws, tmp, lab, calibrations_csv, imu, says=(), *extra) -> str:
    """``apply`` of ``calibrations_csv``: ``correct`` when ``imu`` (frontal) gets a calibration
    from all repetitions within :data:`WRONG_DEG` of the clean copy's, or is left out with
    ``says`` on screen (``warning``); a subset applied without notice is ``silent_wrong``."""
    copy = tmp / "copy"
    result = aceval("apply", lab, "--calibrations", calibrations_csv, "--out", copy, *extra)
    if result.code is None or result.traceback:
        return "hang" if result.code is None else "traceback"
    if result.code != 0:
        return "wrong_refusal"
    rows = applied(copy)
    rows = rows[(rows["imu"] == imu) & (rows["sensor_set"] == "frontal")]
    said = result.said.lower()
    if rows.empty or ("calibration" in rows and (rows["calibration"] == "none").all()):
        return "warning" if says and all(s.lower() in said for s in says) else "silent_wrong"
    row = rows.iloc[0]
    clean = full_sets(calibrations(ws.clean_calibrations("kong")))
    clean = clean[
        (clean["imu"] == imu) & (clean["sensor_set"] == "frontal") & (clean["test"] == row["test"])
    ]
    n_reps = len(str(row["repetitions"]).split("+"))
    if n_reps < clean.iloc[0]["n_reps"]:  # a subset
        told = "subset" in str(row.get("calibration", "")) and imu.lower() in said
        return (
            "warning"
            if told and says and all(s.lower() in said for s in says)
            else ("silent_wrong")
        )
    return (
        "correct"
        if angle_deg(matrix(row), matrix(clean.iloc[0])) <= WRONG_DEG
        else ("silent_wrong")
    )


@case("silent wrong numbers", "correct", "one 16 g sample in T3_R1 (no acc_range_g), apply")
def _(ws, tmp):
    lab = ws.copy("kong", tmp)
    drop_yaml_key(lab, "acc_range_g")
    change_recordings(recordings_of(lab, "IMU4", "T3", "frontal", 1), lambda t: spike(t, 16.0))
    result, out = _calibrate(ws, tmp, lab)
    if result.code != 0:
        return refusal(result, ())
    return apply_judged(ws, tmp, lab, out, "IMU4")


for _extra, _says in (((), ("IMU4", "--allow-subset")), (("--allow-subset",), ("IMU4", "subset"))):

    @case(
        "silent wrong numbers",
        "warning",
        f"the full-set row deleted by hand, apply {' '.join(_extra)}".strip(),
    )
    def _(ws, tmp, extra=_extra, says=_says):
        lab = ws.copy("kong", tmp)
        table = calibrations(ws.clean_calibrations("kong"))
        full = full_sets(table)
        drop = full[(full["imu"] == "IMU4") & (full["sensor_set"] == "frontal")].index
        edited = tmp / "edited.csv"
        table.drop(index=drop).to_csv(edited, index=False)
        return apply_judged(ws, tmp, lab, edited, "IMU4", says, *extra)


for _g in (16.0, 8.0):

    @case("silent wrong numbers", "correct", f"the same {_g:g} g spike in every T3 repetition")
    def _(ws, tmp, g=_g):
        lab = ws.copy("kong", tmp)
        drop_yaml_key(lab, "acc_range_g")
        change_recordings(recordings_of(lab, "IMU4", "T3", "frontal"), lambda t: spike(t, g))
        result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
        return judged(result, out, ws.clean_calibrations("kong"), ("IMU4",))


@case("silent wrong numbers", "flag", "gyro bias 5 deg/s on two axes of one IMU")
def _(ws, tmp):
    lab = ws.copy("kong", tmp)
    change_recordings(
        recordings_of(lab, "IMU4", sensor_set="frontal"),
        lambda t: t.assign(gyr_x=t["gyr_x"] + 5.0, gyr_z=t["gyr_z"] + 5.0),
    )  # TRIAD's T5 calibration of the thigh: 4.6 deg from the truth before, 27.5 after
    result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
    return judged(
        result, out, ws.clean_calibrations("kong"), ("IMU4",), ("gyro_bias",), method="triad"
    )


def stuck(column: str, value: float):
    return lambda t: t.assign(**{column: value})


for _column, _value, _range in (
    ("gyr_y", 0.0, True),
    ("acc_y", 0.0, True),
    ("acc_y", 0.0731, True),
):

    @case(
        "silent wrong numbers",
        "flag",
        f"{_column} stuck at {_value:g} (one IMU, every recording)",
    )
    def _(ws, tmp, column=_column, value=_value):
        lab = ws.copy("kong", tmp)
        change_recordings(recordings_of(lab, "IMU4", sensor_set="frontal"), stuck(column, value))
        result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
        method = "combined" if column.startswith("gyr") else "kong"
        return judged(
            result,
            out,
            ws.clean_calibrations("kong"),
            ("IMU4",),
            ("stuck_channel",),
            ("IMU4", column, "stuck"),
            method=method,
        )


@case("silent wrong numbers", "flag", "two T0 repetitions, one leaning 18 deg")
def _(ws, tmp):
    lab = ws.copy("kong", tmp)
    table = sheet(lab / "recordings.tsv")
    rows = table[
        (table["test"] == "T0") & (table["imu"] == "IMU4") & (table["sensor_set"] == "frontal")
    ]
    source = lab / rows.iloc[0]["path"]
    second = source.with_name("T0_R2_IMU4" + source.suffix)
    turn = Rotation.from_rotvec(np.radians(18.0) * np.array([0.0, 1.0, 0.0]))
    recording = read_recording(source).copy()
    recording[ACC] = turn.apply(np.array(recording[ACC], dtype=float))
    recording[GYR] = turn.apply(np.array(recording[GYR], dtype=float))
    write_recording(recording, second)
    extra = rows.iloc[[0]].assign(rep="2", path=str(second.relative_to(lab)))
    write_sheet(pd.concat([table, extra], ignore_index=True), lab / "recordings.tsv")
    result, out = _calibrate(ws, tmp, lab, "--subsets", "full")
    return judged(result, out, ws.clean_calibrations("kong"), ("IMU4",), ("static_disagree",))


def run_on(ws, tmp, command: str, lab: Path, dataset: str, *apply_extra) -> Result:
    """``aceval validate``, ``calibrate`` or ``apply`` (the clean ``dataset``'s calibrations)
    of ``lab``."""
    if command == "validate":
        return aceval("validate", lab)
    if command == "calibrate":
        return aceval("calibrate", lab, "--out", tmp / "out.csv")
    calibrations_csv = ws.clean_calibrations(dataset)
    return aceval(
        "apply", lab, "--calibrations", calibrations_csv, "--out", tmp / "copy", *apply_extra
    )


def imu3_reads_imu2(lab: Path) -> None:
    table = sheet(lab / "recordings.tsv")
    for test in ("T1",):
        rows = table[
            (table["test"] == test) & (table["rep"] == "1") & (table["sensor_set"] == "frontal")
        ]
        imu2 = rows[rows["imu"] == "IMU2"].iloc[0]["path"]
        table.loc[rows[rows["imu"] == "IMU3"].index, "path"] = imu2
    write_sheet(table, lab / "recordings.tsv")


for _command in ("validate", "calibrate", "apply"):

    @case("silent wrong numbers", "error", f"one file for two IMUs ({_command})")
    def _(ws, tmp, command=_command):
        lab = ws.copy("kong", tmp)
        imu3_reads_imu2(lab)
        before = checksums(lab)
        result = run_on(ws, tmp, command, lab, "kong")
        if checksums(lab) != before:
            return "input_changed"
        if result.code == 0 and command == "apply":
            return "silent_wrong"
        if result.code == 0 and "also the file of" in result.said:
            return "warning"
        return refusal(result, ("T1_R1_IMU2",))


def relabel_subject(
    lab: Path, new: str, sheets=("subjects.tsv", "recordings.tsv", "ground_truth.tsv")
):
    for name in sheets:
        if (lab / name).is_file():
            table = sheet(lab / name)
            table["subject"] = table["subject"].replace({"S1": new})
            write_sheet(table, lab / name)


@case("silent wrong numbers", "error", "subjects '1' and '01' both defined")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    relabel_subject(lab, "1")
    subjects = sheet(lab / "subjects.tsv")
    write_sheet(pd.concat([subjects, subjects.assign(subject="01")]), lab / "subjects.tsv")
    recordings = sheet(lab / "recordings.tsv")
    write_sheet(pd.concat([recordings, recordings.assign(subject="01")]), lab / "recordings.tsv")
    result = aceval(
        "calibrate", lab, "--out", tmp / "out.csv", "--angles-out", tmp / "angles.csv",
        "--retest-out", tmp / "retest.csv",
    )  # fmt: skip
    if result.code == 0:
        angles = pd.read_csv(tmp / "angles.csv", dtype={"subject": str})
        return "correct" if set(angles["subject"]) == {"1", "01"} else "silent_wrong"
    return refusal(result, ("'01'", "'1'"))


@case("silent wrong numbers", "refused", "calibrate --subject S1 S1")
def _(ws, tmp):
    lab = ws.small()
    result = aceval("calibrate", lab, "--out", tmp / "out.csv", "--subject", "S1", "S1")
    if result.code == 0:
        reps = calibrations(tmp / "out.csv")["repetitions"].astype(str)
        return "silent_wrong" if reps.str.contains(r"R1\+R1").any() else "correct"
    return refusal(result, ("S1", "twice"), "refused")


for _extra in ((), ("--other-dataset",)):

    @case(
        "partial or lost outputs",
        "correct",
        f"subject '001': calibrate, then apply {' '.join(_extra)}".strip(),
    )
    def _(ws, tmp, extra=_extra):
        lab = ws.copy("small", tmp)
        relabel_subject(lab, "001")
        result, out = _calibrate(ws, tmp, lab, "--method", "kong")
        if result.code != 0:
            return refusal(result, ())
        copy = tmp / "copy"
        result = aceval("apply", lab, "--calibrations", out, "--out", copy, *extra)
        if result.code != 0:
            return refusal(result, ()) if result.traceback else "wrong_refusal"
        written = sheet(copy / "recordings.tsv")
        return "correct" if len(written) == len(sheet(lab / "recordings.tsv")) else "partial"


# tracebacks


def duplicated_parquet_column(path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    columns = [table.column(c) for c in table.column_names] + [table.column("acc_x")]
    pq.write_table(pa.Table.from_arrays(columns, names=[*table.column_names, "acc_x"]), path)


for _command in ("calibrate", "apply"):

    @case("tracebacks", "error", f"a Parquet file with a duplicated column name ({_command})")
    def _(ws, tmp, command=_command):
        lab = ws.copy("kong", tmp)
        target = recordings_of(lab, "IMU4", "T3", "frontal", 1)[0]
        duplicated_parquet_column(target)
        if command == "calibrate":
            result = aceval("calibrate", lab, "--out", tmp / "out.csv")
            if result.code == 0:
                return "silent_wrong"
        else:
            result = aceval(
                "apply", lab, "--calibrations", ws.clean_calibrations("kong"), "--out", tmp / "copy",
                "--other-dataset",
            )  # fmt: skip
        return refusal(result, (target.name, "acc_x"))


for _bad in ("zero", "empty", "NaN"):

    @case("tracebacks", "error", f"a vendor quaternion row {_bad}, apply")
    def _(ws, tmp, bad=_bad):
        lab = ws.copy("small", tmp)
        with_vendor_quaternions(lab, "IMU4")
        target = recordings_of(lab, "IMU4", "T0")[0]
        text = target.read_text().splitlines()
        cells = text[5].split(",")
        cells[-4:] = {"zero": ["0"] * 4, "empty": [""] * 4, "NaN": ["nan"] * 4}[bad]
        text[5] = ",".join(cells)
        target.write_text("\n".join(text) + "\n")
        result = aceval(
            "apply", lab, "--calibrations", ws.clean_calibrations("small"), "--out", tmp / "copy",
            "--other-dataset",
        )  # fmt: skip
        if result.code == 0:
            return "correct"  # the bad rows carried as they were: nothing made up
        return refusal(result, (target.name, "quat"))


def full_disk(result: Result, tmp: Path, outputs: tuple[str, ...]) -> str:
    """A command on a 'full disk' (RLIMIT_FSIZE: writes beyond 4 KiB fail): one line naming the
    cause, exit non-zero, nothing partial."""
    left = [p for p in tmp.rglob("*") if p.name in outputs or p.name.startswith(".")]
    if result.traceback:
        return "traceback"
    if result.code == 0:
        return "correct" if not hidden_leftovers(tmp) else "partial"
    if left:
        return "partial"
    return (
        "error"
        if "too large" in result.said.lower() or "space" in result.said.lower()
        else ("misleading")
    )


@case("tracebacks", "error", "disk full during simulate")
def _(ws, tmp):
    result = aceval("simulate", "box", "--out", tmp / "sim", limit_bytes=4096)
    return full_disk(result, tmp, ("sim",))


@case("tracebacks", "error", "disk full during calibrate")
def _(ws, tmp):
    result = aceval("calibrate", ws.small(), "--out", tmp / "out.csv", limit_bytes=4096)
    return full_disk(result, tmp, ("out.csv",))


@case("tracebacks", "error", "disk full during apply")
def _(ws, tmp):
    result = aceval(
        "apply", ws.small(), "--calibrations", ws.clean_calibrations("small"), "--out",
        tmp / "copy", limit_bytes=4096,
    )  # fmt: skip
    return full_disk(result, tmp, ("copy",))


LONG = "x" * 300


for _command in ("validate", "calibrate", "apply", "simulate"):

    @case("tracebacks", "error", f"a path component over 255 bytes ({_command})")
    def _(ws, tmp, command=_command):
        if command == "simulate":
            result = aceval("simulate", "box", "--out", tmp / LONG)
            return refusal(result, ("too long",))
        lab = ws.copy("small", tmp)
        table = sheet(lab / "recordings.tsv")
        table.loc[3, "path"] = f"data/{LONG}.csv"
        write_sheet(table, lab / "recordings.tsv")
        result = run_on(ws, tmp, command, lab, "small", "--other-dataset")
        return refusal(result, ("too long",))


@case("tracebacks", "refused", "simulate into a read-only folder")
def _(ws, tmp):
    folder = tmp / "readonly"
    folder.mkdir()
    root = os.getuid() == 0  # root writes into any folder but an immutable one
    subprocess.run(
        ["chattr", "+i", str(folder)] if root else ["chmod", "555", str(folder)], check=True
    )
    try:
        result = aceval("simulate", "box", "--out", folder / "sim")
    finally:
        subprocess.run(
            ["chattr", "-i", str(folder)] if root else ["chmod", "755", str(folder)], check=True
        )
    return refusal(result, ("readonly",), "refused")


@case("tracebacks", "refused", "apply --force onto a symlink to an aceval folder")
def _(ws, tmp):
    lab = ws.small()
    calibrations_csv = ws.clean_calibrations("small")
    first = aceval("apply", lab, "--calibrations", calibrations_csv, "--out", tmp / "real")
    assert first.code == 0, first.err
    (tmp / "link").symlink_to(tmp / "real")
    before = checksums(tmp / "real")
    result = aceval(
        "apply", lab, "--calibrations", calibrations_csv, "--out", tmp / "link", "--force"
    )
    if result.code == 0:
        return "correct" if (tmp / "link").is_symlink() or (tmp / "link").is_dir() else "partial"
    if checksums(tmp / "real") != before and not result.traceback:
        return "partial"
    return refusal(result, ("symbolic link",), "refused")


def table_input(kind: str, tmp: Path) -> Path:
    path = tmp / f"{kind}.csv"
    if kind == "binary":
        path.write_bytes(bytes(range(256)) * 8)
    elif kind == "wrong":
        path.write_text("a,b\n1,2\n")
    return path  # missing: not written


for _command in ("angles", "table", "outputs"):
    for _kind in ("missing", "binary", "wrong"):

        @case("tracebacks", "error", f"{_command} given a {_kind} CSV")
        def _(ws, tmp, command=_command, kind=_kind):
            given = table_input(kind, tmp)
            lab = ws.small()
            if command == "angles":
                result = aceval("angles", "--calibrations", given, "--out", tmp / "angles.csv")
            elif command == "table":
                result = aceval(
                    "table", "5", "--dataset", lab, "--calibrations", given,
                    "--csv", tmp / "t.csv", "--md", tmp / "t.md",
                )  # fmt: skip
            else:
                result = aceval(
                    "outputs", "--dataset", lab, "--results", tmp / "results", "--analyses",
                    "kong", "--calibrations", given,
                )  # fmt: skip
            new = [p for p in tmp.rglob("*") if p.is_file() and p != given]
            if result.code != 0 and new:
                return "partial"
            return refusal(result, (given.name,))


@case("tracebacks", "error", "dataset.yaml is a folder")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    (lab / "dataset.yaml").unlink()
    (lab / "dataset.yaml").mkdir()
    return refusal(aceval("validate", lab), ("dataset.yaml",))


@case("tracebacks", "error", "aceval validate ... | head -1 (a broken pipe)")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    import yaml

    meta = yaml.safe_load((lab / "dataset.yaml").read_text())
    meta |= {f"unknown_key_{k}": k for k in range(3000)}  # a long report (more than a pipe holds)
    (lab / "dataset.yaml").write_text(yaml.safe_dump(meta))
    subprocess.run(
        f"'{sys.executable}' -m aceval validate '{lab}' 2>'{tmp}/err' | head -1",
        shell=True, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    err = (tmp / "err").read_text()
    return "traceback" if "Traceback" in err else "error"


@case("hang", "error", "a FIFO as imus.tsv")
def _(ws, tmp):
    lab = ws.copy("small", tmp)
    (lab / "imus.tsv").unlink()
    os.mkfifo(lab / "imus.tsv")
    return refusal(aceval("validate", lab, timeout=30), ("imus.tsv",))


# partial or lost outputs


def count_files(folder: Path) -> int:
    return sum(1 for p in Path(folder).rglob("*") if p.is_file())


@case(
    "partial or lost outputs",
    "correct",
    "simulate --out res.4000000 (a pid no process has) and --out res side by side",
)
def _(ws, tmp):
    first = subprocess.Popen(  # a Kong simulation: still writing when the second one starts
        [sys.executable, "-m", "aceval", "simulate", "kong", "--subjects", "1", "--out",
         str(tmp / "res.4000000")],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.time() + 60
    while time.time() < deadline and not [p for p in tmp.iterdir() if p.name.startswith(".")]:
        time.sleep(0.02)  # until the first has its staging folder
    second = aceval("simulate", "box", "--out", tmp / "res")
    first.wait(timeout=600)
    made = [
        aceval("simulate", "kong", "--subjects", 1, "--out", tmp / "kong").code,
        aceval("simulate", "box", "--out", tmp / "box").code,
    ]
    if second.traceback or "Traceback" in first.stderr.read():
        return "traceback"
    expected = {"res.4000000": count_files(tmp / "kong"), "res": count_files(tmp / "box")}
    complete = [count_files(tmp / n) == expected[n] for n in expected if (tmp / n).is_dir()]
    return "correct" if made == [0, 0] and complete == [True, True] else "partial"


@case("partial or lost outputs", "correct", "kill -9 of a run writing out.1, then --out out")
def _(ws, tmp):
    killed = subprocess.Popen(
        [sys.executable, "-m", "aceval", "simulate", "box", "--out", str(tmp / "out.1")],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    deadline = time.time() + 60
    while time.time() < deadline and not [p for p in tmp.iterdir() if p.name.startswith(".")]:
        time.sleep(0.02)
    killed.kill()
    killed.wait()
    result = aceval("simulate", "box", "--out", tmp / "out")
    if result.code == 0:
        return "correct"
    return "traceback" if result.traceback else "wrong_refusal"


@case("partial or lost outputs", "refused", "calibrate --out x.csv --findings-out x.csv")
def _(ws, tmp):
    result = aceval(
        "calibrate", ws.small(), "--out", tmp / "x.csv", "--findings-out", tmp / "x.csv"
    )
    if result.code == 0:
        return "partial"  # one of the two outputs lost
    return refusal(result, ("x.csv", "both name"), "refused")


# inputs changed


def linked_dataset(ws, tmp: Path, into: Path) -> Path:
    """dsB: the small dataset's sheets, its data folder a symbolic link to ``into``."""
    lab = ws.copy("small", tmp)
    target = into / "data"
    shutil.move(lab / "data", target)
    (lab / "data").symlink_to(target)
    return lab


@case("inputs changed", "refused", "calibrate --out onto a recording reached through a symlink")
def _(ws, tmp):
    elsewhere = tmp / "elsewhere"
    elsewhere.mkdir()
    lab = linked_dataset(ws, tmp, elsewhere)
    before = checksums(elsewhere, lab)
    victim = lab / sheet(lab / "recordings.tsv")["path"].iloc[0]
    result = aceval("calibrate", lab, "--out", victim)
    if checksums(elsewhere, lab) != before:
        return "input_changed"
    return refusal(result, ("input",), "refused")


@case("inputs changed", "refused", "apply --out X --force where the dataset's data links into X")
def _(ws, tmp):
    lab = ws.small()
    first = aceval(
        "apply", lab, "--calibrations", ws.clean_calibrations("small"), "--out", tmp / "simA"
    )
    assert first.code == 0, first.err
    dsb = tmp / "dsB"
    dsb.mkdir()
    for name in lab.iterdir():
        if name.is_file():
            shutil.copy(name, dsb / name.name)
    (dsb / "data").symlink_to(tmp / "simA" / "data")
    clean = aceval("calibrate", dsb, "--out", tmp / "dsB.csv")
    assert clean.code == 0, clean.err
    before = checksums(tmp / "simA")
    result = aceval(
        "apply", dsb, "--calibrations", tmp / "dsB.csv", "--out", tmp / "simA", "--force"
    )
    if checksums(tmp / "simA") != before or not (tmp / "simA").is_dir():
        return "input_changed"
    return refusal(result, ("simA",), "refused")


# wrong refusals: the workflow's first check and calibrate accept the same files


def workflow_and_calibrate_agree(ws, tmp, change: Callable[[Path], None]) -> str:
    lab = ws.copy("small", tmp)
    change(lab)
    gate = aceval("validate", lab, "--sheets-only")
    full = aceval("calibrate", lab, "--out", tmp / "out.csv")
    if gate.traceback or full.traceback:
        return "traceback"
    return "correct" if (gate.code == 0) == (full.code == 0) else "wrong_refusal"


def with_bom(lab: Path) -> None:
    path = recordings_of(lab, "IMU4", "T3")[0]
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())


def as_bz2(lab: Path) -> None:
    import bz2

    table = sheet(lab / "recordings.tsv")
    row = table.index[table["path"].str.contains("T3_R1_IMU4")][0]
    path = lab / table.loc[row, "path"]
    path.with_name(path.name + ".bz2").write_bytes(bz2.compress(path.read_bytes()))
    path.unlink()
    table.loc[row, "path"] += ".bz2"
    write_sheet(table, lab / "recordings.tsv")


@case("wrong refusals", "correct", "a recording CSV in UTF-8 with BOM (Excel's CSV UTF-8)")
def _(ws, tmp):
    return workflow_and_calibrate_agree(ws, tmp, with_bom)


@case("wrong refusals", "correct", "a recording as .csv.bz2")
def _(ws, tmp):
    return workflow_and_calibrate_agree(ws, tmp, as_bz2)


# apply says what it applies (issue 40, point 3)


@case("apply says what it applies", "warning", "apply a peer tool's calibrations CSV")
def _(ws, tmp):
    table = full_sets(calibrations(ws.clean_calibrations("small")))
    columns = ["subject", "sensor_set", "imu", "segment", "side", "test", "repetitions", "n_reps"]
    peer = table[[*columns, *R_COLUMNS]].assign(method="gaitmap_pca", flag="", note="", seconds=0.1)
    peer.to_csv(tmp / "peer.csv", index=False)
    result = aceval(
        "apply", ws.small(), "--calibrations", tmp / "peer.csv", "--out", tmp / "copy",
        "--method", "gaitmap_pca",
    )  # fmt: skip
    if result.code != 0:
        return refusal(result, ("peer",))
    said = result.said.lower()
    return "warning" if "peer" in said and "older aceval" not in said else "misleading"


@case("apply says what it applies", "warning", "apply a CSV of an older aceval (no fingerprint)")
def _(ws, tmp):
    calibrations(ws.clean_calibrations("small")).drop(columns="recordings_sha1").to_csv(
        tmp / "old.csv", index=False
    )
    result = aceval("apply", ws.small(), "--calibrations", tmp / "old.csv", "--out", tmp / "copy")
    if result.code != 0:
        return refusal(result, ())
    return "warning" if "older aceval" in result.said.lower() else "silent_wrong"


@case("apply says what it applies", "correct", "apply says per IMU which calibration it applies")
def _(ws, tmp):
    copy = tmp / "copy"
    result = aceval(
        "apply", ws.small(), "--calibrations", ws.clean_calibrations("small"), "--out", copy
    )
    if result.code != 0:
        return refusal(result, ())
    rows = applied(copy)
    said = result.said
    told = all(f"{imu}" in said for imu in rows["imu"]) and "all 3 repetitions" in said
    return "correct" if told and "calibration" in rows and "why" in rows else "silent_wrong"


@case(
    "apply says what it applies",
    "warning",
    "apply a CSV of an older aceval (paths and bytes hashed)",
)
def _(ws, tmp):
    lab = ws.small()
    digest = hashlib.sha1()
    for path in sheet(lab / "recordings.tsv")["path"]:  # the fingerprint before labels were hashed
        digest.update(f"{path}\0".encode())
        digest.update((lab / path).read_bytes())
    table = calibrations(ws.clean_calibrations("small")).assign(recordings_sha1=digest.hexdigest())
    table.to_csv(tmp / "old.csv", index=False)
    result = aceval("apply", lab, "--calibrations", tmp / "old.csv", "--out", tmp / "copy")
    if result.code != 0:
        return "wrong_refusal" if not result.traceback else "traceback"
    return "warning" if "older aceval" in result.said.lower() else "correct"
