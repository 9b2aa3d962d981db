"""False-alarm and catch rates of the input checks of the fourth bad-input sweep (not a speed
benchmark: the rates in config/README.md's table of checks come from here).

    python benchmarks/input_check_rates.py files resources/kong_sim resources/ricci_sim ...
    python benchmarks/input_check_rates.py sides resources/neura resources/hugadb ...
    python benchmarks/input_check_rates.py sides-sim [--seeds 1 2 3]

``files``: each dataset folder's sheets and every recording as it is (a finding is a false
alarm), then each recording with one defect made in memory (a finding is a catch): the
recording checks of ``aceval validate`` (:func:`aceval.data.recording_checks.check_values`) on
* a jump of 0.3 s in ``t`` halfway (``t jumps``);
* the gyroscope in rad/s while dataset.yaml declares deg/s (a dataset declared in rad/s: its
  files as they are, declared deg/s), the recordings of tests that calibrate their IMU (the
  units named; the spike warnings counted);
* the recording cut to 0.49 s around its fastest turn (a motion recording left out);
and on the sheets: each imus.tsv row's segment and side capitalised (refused), each unit (subject,
set, IMU, test) of 2 or more repetitions with its last one removed from recordings.tsv (named).

``sides``: per IMU with a side and walking recordings, its gyroscope axis nearest the declared
right axis negated (a left-handed gyroscope), and, apart, its recordings exchanged with those of
the same segment's other side (legs exchanged; both in memory, in the one pass): the IMU's sensor
verdict, ``swing_reversed``, ``opposite_side_timing`` or none; the clean pass's verdicts too.
``sides-sim``: the same on 1-subject Kong simulations (both sets, every IMU in every test).

``ricci``: Ricci's functional design flagged by the sensor checks (:func:`ricci`).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import aceval.signals.reduction as reduction  # noqa: E402
from aceval.calibrate.plan import imu_checks  # noqa: E402
from aceval.data.contract import ValidationReport, recording_values  # noqa: E402
from aceval.data.dataset import load_dataset, read_sheets  # noqa: E402
from aceval.data.recording_checks import acc_spikes, check_values  # noqa: E402
from aceval.data.rotations import axis_vector  # noqa: E402

KEY = ["subject", "sensor_set", "imu"]


def findings(dataset, row, values) -> list[str]:
    report = ValidationReport(dataset.name)
    check_values(dataset, row, values.copy(), report)
    return [f.cause for f in report.findings]


def kinds(causes: list[str]) -> set[str]:
    words = {"t jumps": "jump", "units.gyr": "units", "spike": "spike", "very short": "short"}
    return {kind for cause in causes for text, kind in words.items() if text in cause}


def defects(values: np.ndarray, fs_hz: float, gyr_scale: float) -> dict[str, np.ndarray]:
    jump = values.copy()
    jump[len(jump) // 2 :, 0] += 0.3
    rad = values.copy()
    rad[:, 4:7] *= gyr_scale  # the file's numbers in rad/s (read as deg/s: :func:`as_deg_s`)
    peak = int(np.argmax(np.linalg.norm(values[:, 4:7], axis=1)))
    start = max(0, peak - int(0.245 * fs_hz))
    cut = values[start : start + int(round(0.49 * fs_hz))].copy()
    return {"jump": jump, "units": rad, "short": cut}


def as_deg_s(dataset):
    """The dataset with its gyroscope declared in deg/s (its files unchanged)."""
    units = {**dataset.meta["units"], "gyr": "deg/s"}
    return dataclasses.replace(dataset, meta={**dataset.meta, "units": units})


def files(root: str) -> dict:
    dataset = load_dataset(root)
    mislabelled = as_deg_s(dataset)
    allowed = set(map(tuple, dataset.calibrates[["test", "imu"]].to_numpy()))
    counts: Counter = Counter()
    for row in dataset.recordings.to_dict("records"):
        values = recording_values(dataset.root / row["path"])
        motion = dataset.test_kinds[row["test"]] == "motion"
        calibrating = motion and (row["test"], row["imu"]) in allowed
        counts["recordings"] += 1
        counts["motion"] += motion
        counts["calibrating"] += calibrating
        for kind in kinds(findings(dataset, row, values)):
            static = kind == "short" and not motion  # warned, and used (its z0)
            counts[f"clean {kind}" + (" (static: used)" if static else "")] += 1
        made = defects(values, dataset.fs_hz, dataset.gyr_scale)
        counts["caught jump"] += "jump" in kinds(findings(dataset, row, made["jump"]))
        if calibrating:
            found = kinds(findings(mislabelled, row, made["units"]))
            counts["caught units"] += "units" in found
            counts["spike warnings, rad/s"] += "spike" in found
            rad = made["units"]  # what the spike check took for spikes before it was skipped
            spikes = acc_spikes(rad[:, 1:4], rad[:, 4:7], dataset.acc_scale, mislabelled.gyr_scale)
            counts["spikes as judged before, rad/s"] += bool(spikes.any())
        if motion:
            counts["caught short"] += "short" in kinds(findings(dataset, row, made["short"]))
    return {"dataset": Path(root).name, **counts, **sheet_rates(root, dataset)}


def sheet_rates(root: str, dataset) -> Counter:
    """The sheet checks: clean, then each imus.tsv row's segment and side capitalised, each unit
    with its last repetition removed (in memory)."""
    counts: Counter = Counter()
    _, report = read_sheets(root)
    counts["clean sheet findings"] = len(report.findings)
    sheet = pd.read_csv(Path(root) / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    counts["imus rows"] = len(sheet)
    from aceval.data.names import check_places

    for column in ("segment", "side"):
        for index in sheet.index:
            broken = sheet.copy()
            broken.loc[index, column] = broken.loc[index, column].capitalize()
            caught = ValidationReport("x")
            check_places(broken, dataset.functional_axes, caught)
            counts[f"caught {column} capitalised"] += bool(caught.errors)
    from aceval.data.protocol_checks import check_repetitions

    units = dataset.recordings.groupby(["subject", "sensor_set", "imu", "test"])
    counts["units of 2+ repetitions"] = int((units.size() >= 2).sum())
    for _, group in units:
        last = group["rep"].max()
        fewer = dataset.recordings.drop(group.index[group["rep"] == last])
        caught = ValidationReport("x")
        check_repetitions(fewer, dataset.tests, caught)
        counts["caught repetition missing"] += bool(caught.warnings)
    return counts


def sided_units(dataset) -> list[tuple]:
    """(subject, set, IMU) with a side whose IMU is recorded in a walking test."""
    walking = [t for t in dataset.tests.index if dataset.first_phase(t) == "gait"]
    recorded = dataset.recordings[dataset.recordings["test"].isin(walking)]
    units = recorded[KEY].drop_duplicates().itertuples(index=False)
    return [u for u in units if dataset.places[(u[1], u[2])][1] in ("left", "right")]


def side_verdicts(dataset, subject: str, change=None) -> dict:
    """The sensor verdicts of one subject's walking pass, each recording read through
    ``change(rec)`` (None: as it is; else the recordings.tsv row to read instead, and whether to
    negate the gyroscope axis nearest the declared right axis), in memory."""
    walking = [t for t in dataset.tests.index if dataset.first_phase(t) == "gait"]
    original = reduction.read_checked

    def read(data_set, rec, report):
        source, negate = change(rec) if change else (rec, False)
        recording = original(data_set, source, report)
        if recording is not None and negate:
            right = axis_vector(dataset.right_axis(rec["sensor_set"], rec["imu"]))
            recording.gyr[:, int(np.argmax(np.abs(right)))] *= -1.0
        return recording

    reduction.read_checked = read
    try:
        summaries = reduction.reduce_recordings(dataset, subject, tests=walking).summaries
    finally:
        reduction.read_checked = original
    return imu_checks(dataset, summaries)


def partner(dataset, unit: tuple) -> str | None:
    """The IMU of the same set and segment on the other side (None when there is none)."""
    segment, side = dataset.places[(unit[1], unit[2])]
    other = {"left": "right", "right": "left"}[side]
    found = [
        imu
        for (s, imu), place in dataset.places.items()
        if s == unit[1] and place == (segment, other)
    ]
    return found[0] if found else None


def exchanged_with(dataset, unit: tuple, other: str):
    """Read the recordings of ``unit``'s IMU and of ``other`` (same subject and set) swapped."""
    rows = dataset.recordings[
        (dataset.recordings["subject"] == unit[0]) & (dataset.recordings["sensor_set"] == unit[1])
    ]
    paths = {(r["test"], r["rep"], r["imu"]): r["path"] for r in rows.to_dict("records")}
    swap = {unit[2]: other, other: unit[2]}

    def change(rec):
        if rec["imu"] not in swap or (rec["test"], rec["rep"], swap[rec["imu"]]) not in paths:
            return rec, False
        return {**rec, "path": paths[(rec["test"], rec["rep"], swap[rec["imu"]])]}, False

    return change


def verdict_name(flags: str) -> str:
    for name in ("swing_reversed", "opposite_side_timing"):
        if name in flags:
            return name
    return "none"


def sides(root: str) -> dict:
    dataset = load_dataset(root)
    counts: Counter = Counter()
    units = sided_units(dataset)
    counts["units"] = len(units)
    clean = {}
    for subject in sorted({u[0] for u in units}):
        clean |= side_verdicts(dataset, subject)
    for unit in units:
        found = verdict_name(clean.get(unit, {}).get("flag", ""))
        counts[f"clean: {found}"] += 1
        target = unit[1:]

        def negated(rec, target=target):
            return rec, (rec["sensor_set"], rec["imu"]) == target

        verdict = side_verdicts(dataset, unit[0], negated).get(unit, {})
        name = verdict_name(verdict.get("flag", ""))
        counts[f"gyro axis negated: {name}"] += 1
        counts["gyro axis negated: says only 'other leg'"] += (
            name == "opposite_side_timing" and "does not tell" not in verdict.get("message", "")
        )
        other = partner(dataset, unit)
        if other is not None:
            change = exchanged_with(dataset, unit, other)
            verdict = side_verdicts(dataset, unit[0], change).get(unit, {})
            message = verdict.get("message", "")
            name = verdict_name(verdict.get("flag", ""))
            counts[f"legs exchanged: {name}"] += 1
            counts["legs exchanged: says only 'other leg'"] += (
                name == "opposite_side_timing" and "does not tell" not in message
            )
    return {"dataset": Path(root).name, **counts}


def ricci(root: str) -> dict:
    """Ricci's functional design: the calibrations flagged on the dataset as it is, and with each
    IMU's acc_x and acc_y exchanged in every recording (a mirrored frame; in memory): whether
    every calibration of that IMU is flagged (and by which flags), and no other."""
    from aceval.calibrate.pipeline import calibrate

    dataset = load_dataset(root)
    original = reduction.read_checked

    def calibrations(target):
        def read(data_set, rec, report):
            recording = original(data_set, rec, report)
            if recording is not None and (rec["sensor_set"], rec["imu"]) == target:
                recording.acc[:, [0, 1]] = recording.acc[:, [1, 0]]
            return recording

        reduction.read_checked = read
        try:
            parts = [reduction.reduce_recordings(dataset, s) for s in dataset.subjects.index]
        finally:
            reduction.read_checked = original
        summaries = pd.concat([p.summaries for p in parts], ignore_index=True)
        return calibrate(dataset, summaries, "full", retest_k=None)[0]

    counts: Counter = Counter()
    table = calibrations(None)
    counts["calibrations"] = len(table)
    counts["clean: flagged"] = int((table["flag"].fillna("") != "").sum())
    for target in dataset.imus.index:
        table = calibrations(target)
        mine = (table["sensor_set"] == target[0]) & (table["imu"] == target[1])
        flagged = table["flag"].fillna("") != ""
        units = table[mine].groupby("subject")
        counts["units (subject, IMU)"] += units.ngroups
        caught = units["flag"].agg(lambda f: bool((f.fillna("") != "").all()))
        counts["acc_x, acc_y exchanged: every calibration flagged"] += int(caught.sum())
        counts["acc_x, acc_y exchanged: by the sensor checks"] += int(
            units["flag"].agg(lambda f: f.fillna("").str.contains("gyro_acc").all()).sum()
        )
        counts["acc_x, acc_y exchanged: calibrations of other IMUs flagged"] += int(
            flagged[~mine].sum()
        )
    return {"dataset": Path(root).name, **counts}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=["files", "sides", "sides-sim", "ricci"])
    parser.add_argument("datasets", nargs="*")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    args = parser.parse_args()
    rows = []
    if args.what == "sides-sim":
        from aceval.cli import main as aceval

        with tempfile.TemporaryDirectory() as scratch:
            for seed in args.seeds:
                out = Path(scratch) / f"kong{seed}"
                argv = ["simulate", "kong", "--out", str(out), "--subjects", "1", "--seed"]
                assert aceval([*argv, str(seed)]) == 0
                rows.append(sides(str(out)) | {"dataset": f"kong seed {seed}"})
    else:
        run = {"files": files, "sides": sides, "ricci": ricci}[args.what]
        rows = [run(root) for root in args.datasets]
    print(pd.DataFrame(rows).fillna(0).set_index("dataset").T.to_string())


if __name__ == "__main__":
    main()
