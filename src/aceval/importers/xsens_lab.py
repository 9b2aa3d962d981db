"""A lab's exports -> the dataset contract: many subjects and trials in one call, from two
sheets (config/README.md, "A lab's exports"; docs/your_data.md walks through it). The exports
are Xsens MT Manager's (:func:`import_xsens_lab`) or any vendor's delimited text read through a
mapping (:mod:`aceval.importers.table`): :func:`import_lab` takes a file reader and is the same
for both.

``trials.tsv`` (tab-separated; one row per trial, per file of a trial, or per segment):

* ``subject``; ``trial`` (or ``file``): a path under the exports folder, a folder or the start
  of file names (``P01/walk_01`` matches ``P01/walk_01-000_00B4A1B2.txt``: it must be followed
  by ``-``, ``_``, ``.`` or ``/``); files there that are not exports are skipped and named;
* ``test``: the lab's name of the condition. The trials of one subject and test are its
  repetitions, in sheet order, or as column ``rep`` numbers them;
* ``start_s``, ``end_s`` (optional): the trial is that segment of its files (seconds from their
  first sample); several rows may cut one recording into repetitions and static windows;
* ``static`` (optional): where the subject's vertical (z0, Kong Eq. 2) comes from. ``file``: the
  whole trial is quiet standing (a static test named by ``test``); a number N: the trial's first
  N seconds are quiet standing (static test ``standing``), the rest is ``test``; ``walking``: no
  quiet standing, the vertical of the mean walking posture (static test ``walking_vertical``, the
  trial's movement low-passed at 0.5 Hz: a fallback, see :mod:`aceval.importers.shared`). The
  motion of a recording that holds quiet standing takes that standing's vertical
  (``verticals.tsv``, :func:`verticals`);
* ``first_phase`` (optional, as tests.tsv: ``gait`` for walking) and ``calibrates`` (optional:
  the segments the test calibrates, comma-separated; for ``gait`` by default thigh, shank, foot
  and waist: Kong Table 2's walking segments and the pelvis, as the NeuRA and qmt imports).

``sensors.tsv`` (one row per sensor, or per subject and sensor): ``sensor_id segment side``,
optionally ``imu`` (the lab's name; default segment and side, ``shank_r``), ``sensor_set``
(``main``), ``region`` (``upper_body`` for head, chest and waist, else ``lower_body``),
``right_axis`` (empty: the import proposes one from the recordings and stops) and ``subject``
(a row without one applies to every subject). ``segment`` is Kong's vocabulary (head chest
waist thigh shank foot): a segment no test calibrates is named on screen, not dropped silently.
Without it, an Xsens import writes the sheet the exports' sensorspec files propose
(:mod:`aceval.importers.sensorspec`).

Exports (:mod:`aceval.importers.lab_trials` reads a trial): MT Manager text files (``//`` header
lines, comma- or tab-separated; Acc m/s^2, Gyr rad/s; :func:`aceval.importers.xsens.read_mt_export`),
the sensor ID from the file name (``_<8 hex>.txt``) or the header's ``DeviceId``, the rate from
``// Update Rate``, SampleTimeFine or ``--rate`` (checked against each other; a rate given only
by hand against the recordings, :mod:`aceval.signals.rate_check`). The files of a trial must
share their PacketCounter range (one synchronised recording, no sample lost), or be trimmed to
the samples they share (``--trim-to-shared``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.contract import FS_TOLERANCE
from aceval.data.errors import CalibrationError
from aceval.data.verticals import COLUMNS as VERTICAL_COLUMNS
from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers.lab_sheets import (
    STANDING,
    UPPER_BODY,
    WALKING_VERTICAL,
    Trial,
    find_trials,
    read_lab_sensors,
    read_trials,
)
from aceval.importers.lab_trials import check_declared_rate, read_lab_trial, segment
from aceval.importers.sensorspec import disagreements, propose_sensor_sheet
from aceval.importers.shared import FormatError, ImportReport, mean_posture
from aceval.importers.xsens import ACC_RANGE_G, GYR_RANGE_DPS, not_an_export, xsens_samples
from aceval.signals.segmentation import TrimParams, movement_mask


def import_xsens_lab(
    src: str | Path,
    out: Path,
    trials_path: str | Path,
    sensors_path: str | Path | None,
    name: str = "xsens_lab",
    rate: float | None = None,
    trim_to_shared: bool = False,
) -> ImportReport:
    """Write the dataset of every trial of ``trials_path`` (MT Manager exports under ``src``)
    into ``out``; without ``sensors_path``, the sensor sheet the exports' sensorspec files
    propose is written beside ``trials_path`` and the import stops (:mod:`.sensorspec`).
    """
    if sensors_path is None:
        propose_sensor_sheet(Path(src), Path(trials_path))
    report = import_lab(
        LabImport(
            Path(src),
            Path(trials_path),
            Path(sensors_path),
            name,
            f"Xsens MT Manager exports ({Path(src).name}), imported by aceval import xsens --trials",
            lambda path: xsens_samples(path, rate),
            not_an_export,
            trim_to_shared,
        ),
        out,
    )
    for line in disagreements(Path(src), read_lab_sensors(sensors_path)):
        report.note(line)
    return report


@dataclass(frozen=True)
class LabImport:
    """What a lab's import reads: its exports folder, its two sheets, the dataset's name and
    description, ``read_file`` (a path -> its sensors'
    :class:`aceval.importers.lab_trials.SensorSamples`), ``not_export`` (a path -> why it is not
    an export, '' when it is) and whether to trim a trial's sensors to the samples they share.
    """

    src: Path
    trials: Path
    sensors: Path
    name: str
    description: str
    read_file: Callable
    not_export: Callable
    trim_to_shared: bool = False


def import_lab(lab: LabImport, out: Path) -> ImportReport:
    """Write the dataset of every trial of ``lab.trials`` into ``out`` (the module docstring)."""
    report = ImportReport()
    table, tests = read_trials(lab.trials)
    sensors = read_lab_sensors(lab.sensors)
    sheets = {lab.trials.resolve(), lab.sensors.resolve()}
    trials = find_trials(lab.src, table, report, sheets, lab.not_export)
    fs_hz, read, declared = None, {}, []
    for trial in trials:
        files = tuple(trial.files)
        if files not in read:  # the segments of one recording read it once
            read[files] = read_lab_trial(trial, sensors, lab.read_file, lab.trim_to_shared, report)
        found, trial_fs, by_hand = read[files]
        if fs_hz is not None and abs(trial_fs / fs_hz - 1) > FS_TOLERANCE:
            raise FormatError(
                f"{trial.where} is sampled at {trial_fs:g} Hz, the trials before it at {fs_hz:g} "
                "Hz: a dataset has one rate; import the two rates as two datasets"
            )
        fs_hz = fs_hz or trial_fs
        trial.sensors = segment(trial, found, fs_hz)
        if by_hand and files not in declared:
            declared.append(files)
    if declared:
        check_declared_rate([read[files][0] for files in declared], fs_hz, report)
    for trial in trials:
        trial.parts = _parts(trial, fs_hz, tests)
        if tests[trial.test]["first_phase"] == "gait":
            _say_turns(trial, fs_hz, report)
    _check_statics(trials, tests)
    _check_right_axes(trials, tests, fs_hz)
    imus = _imus(trials)
    writer = DatasetWriter(out, _meta(lab, fs_hz, imus))
    repetitions = _write(writer, trials, report)
    writer.close()
    _sheets(out, tests, repetitions, imus, trials, report)
    return report


def _parts(trial: Trial, fs_hz: float, tests: dict) -> dict:
    """What of the trial is static and what motion: ``{"static": (test, slice) or absent,
    "motion": slice or None}``; FormatError when the trial does not hold what the sheet says.
    """
    found = trial.sensors
    n = min(len(f["gyr"]) for f in found.values())
    if tests[trial.test]["kind"] == "static":
        return {"static": (trial.test, slice(0, n)), "motion": None}
    starts, stops, peaks = [], [], []
    for sensor, f in found.items():
        try:
            moving = np.flatnonzero(movement_mask(f["gyr"][:n], fs_hz))
        except CalibrationError:
            peaks.append(np.degrees(np.linalg.norm(f["gyr"], axis=1).max()))
            continue
        starts.append((int(moving[0]), sensor))
        stops.append(int(moving[-1]) + 1)
    if not starts:
        raise FormatError(
            f"{trial.where}: no sensor moves (the largest peak angular velocity is "
            f"{max(peaks):.0f} deg/s, below Kong's {np.degrees(TrimParams().min_peak_rad_s):.0f} "
            "deg/s): if it is quiet standing, write static=file for it in trials.tsv"
        )
    first, sensor = min(starts)
    parts = {"motion": slice(0, n)}
    if isinstance(trial.static, float):
        k = int(round(trial.static * fs_hz))
        if k >= n or first < k:
            found_text = (
                f"it lasts {n / fs_hz:.2f} s"
                if k >= n
                else f"sensor {sensor} ({found[sensor]['row']['imu']}) moves from "
                f"{first / fs_hz:.2f} s"
            )
            raise FormatError(
                f"{trial.where}: its first {trial.static:g} s are declared quiet standing "
                f"(static), but {found_text}: write at most {max(first / fs_hz - 1, 0):.1f} "
                "(1 s before the movement), or another static source for this subject"
            )
        parts = {"static": (STANDING, slice(0, k)), "motion": slice(k, n)}
    elif trial.static == "walking":
        parts["static"] = (WALKING_VERTICAL, slice(first, max(stops)))
    return parts


#: within any TURN_WINDOW_S seconds of a walking trial the body's heading may change by at most
#: this (deg) before the import says it turns (a turn at the end of a walkway: 180 deg in about
#: 2-3 s; a straight walk's sway and a 5 deg/s gyroscope bias stay far below)
MAX_TURN_DEG, TURN_WINDOW_S = 90.0, 4.0


def _say_turns(trial: Trial, fs_hz: float, report) -> None:
    """Name a walking trial that turns: the heading of its trunk sensors (of every sensor when it
    has none; each about its mean specific force, the vertical) changes by more than
    :data:`MAX_TURN_DEG` within :data:`TURN_WINDOW_S` seconds (median over the sensors).
    """
    window, found, motion = int(TURN_WINDOW_S * fs_hz), trial.sensors, trial.parts["motion"]
    trunk = [f for f in found.values() if f["row"]["segment"] in UPPER_BODY]
    turns = []
    for f in trunk or found.values():
        acc, gyr = f["acc"][motion], f["gyr"][motion]
        if len(gyr) <= window:
            return
        vertical = acc.mean(axis=0) / np.linalg.norm(acc.mean(axis=0))
        heading = np.degrees(np.cumsum(gyr @ vertical) / fs_hz)
        turns.append(np.abs(heading[window:] - heading[:-window]).max())
    turn = float(np.median(turns))
    if turn > MAX_TURN_DEG:
        text = (
            f"{trial.where}: the body turns by {turn:.0f} deg within {TURN_WINDOW_S:g} s: a turn "
            "is not sagittal-plane motion, and Kong's plane (and aceval right-axis) gets worse "
            "with it: cut the walking trials to straight walking (or walk on a treadmill)"
        )
        report.note(text)
        report.add(trial.where, trial.subject, "", "flagged", text)


def _check_statics(trials: list[Trial], tests: dict) -> None:
    """Every sensor that a motion test calibrates has a static recording of its subject."""
    static, needed = {}, {}
    for trial in trials:
        for sensor, f in trial.sensors.items():
            key = (trial.subject, sensor)
            if trial.parts.get("static"):
                static.setdefault(key, []).append(trial)
            if f["row"]["segment"] in tests[trial.test]["calibrates"]:
                needed.setdefault(key, trial)
    subjects = {t.subject for t in trials} - {subject for subject, _ in static}
    if subjects:
        raise FormatError(
            f"subject(s) {', '.join(sorted(subjects))}: no quiet standing, so no vertical (z0, "
            "Kong Eq. 2). In trials.tsv column static, mark one of: a standing trial "
            "(static=file), the seconds of quiet standing at the start of a trial (e.g. "
            "static=5), or static=walking (the mean walking posture: a fallback, "
            "docs/your_data.md says how accurate)"
        )
    for (subject, sensor), trial in needed.items():
        if (subject, sensor) not in static:
            raise FormatError(
                f"{trial.where}: sensor {sensor} is calibrated by {trial.test!r} but subject "
                f"{subject}'s static trials have no export of it: its vertical is unknown"
            )


IMU_COLUMNS = ["sensor_set", "imu", "segment", "side", "region", "right_axis", "source"]


def _imus(trials: list[Trial]) -> pd.DataFrame:
    """imus.tsv's rows: one per (sensor_set, imu) imported, the same for every subject."""
    rows = {}
    for trial in trials:
        for f in trial.sensors.values():
            row = f["row"]
            for name in ("subject", "sensor_set", "imu"):
                value = row.get(name, "") if name != "subject" else trial.subject
                if "/" in value or "\\" in value or value.startswith("."):
                    raise FormatError(
                        f"{row['source']}: {name} {value!r} would name a folder: use letters, "
                        "digits, - and _"
                    )
            key = (row["sensor_set"], row["imu"])
            known = rows.setdefault(key, row)
            differs = [c for c in IMU_COLUMNS[2:6] if known[c] != row[c]]
            if differs:
                raise FormatError(
                    f"{row['source']} and {known['source']}: IMU {row['imu']} (set "
                    f"{row['sensor_set']}) has another {', '.join(differs)} for two subjects; "
                    "imus.tsv holds one row per IMU: give these sensors different imu names"
                )
    return pd.DataFrame(sorted(rows.values(), key=lambda row: row["line"]))[IMU_COLUMNS]


def _check_right_axes(trials, tests, fs_hz: float) -> None:
    """Refuse empty right_axis cells, each sensors.tsv line with what its own recordings propose
    (a line names one sensor: subjects who wore different sensors are judged apart).
    """
    empty = {
        f["row"]["line"]: f["row"]
        for trial in trials
        for f in trial.sensors.values()
        if not f["row"]["right_axis"]
    }
    if not empty:
        return
    from aceval.signals.right_axis import propose, recording_evidence

    units: dict[tuple, dict] = {}
    for trial in trials:
        motion = trial.parts["motion"]
        if motion is None:
            continue
        phase = tests[trial.test]["first_phase"]
        for sensor_set in {f["row"]["sensor_set"] for f in trial.sensors.values()}:
            rows = {
                f["row"]["imu"]: f
                for f in trial.sensors.values()
                if f["row"]["sensor_set"] == sensor_set
            }
            group = {
                imu: (f["acc"][motion], f["gyr"][motion], f["row"]["segment"], f["row"]["side"])
                for imu, f in rows.items()
            }
            for imu, stats in recording_evidence(group, phase, fs_hz).items():
                unit = units.setdefault(
                    (trial.subject, sensor_set, imu, trial.test),
                    {
                        "subject": trial.subject,
                        "sensor_set": sensor_set,
                        "imu": imu,
                        "segment": group[imu][2],
                        "test": trial.test,
                        "first_phase": phase,
                        "line": rows[imu]["row"]["line"],
                        "stats": [],
                    },
                )
                unit["stats"].append(stats)
    proposals = {p["key"]: p for p in propose(list(units.values()), key=lambda u: u["line"])}
    lines = []
    for line, row in sorted(empty.items()):
        p = proposals.get(line)
        said = (
            "no recording of it moves in a test that calibrates it"
            if p is None
            else f"the recordings propose {p['proposed']} ({p['verdict']}: {p['evidence']})"
            if p["proposed"]
            else f"the recordings cannot tell: {p['evidence']}"
        )
        who = f", subject {row['subject']}" if row["subject"] else ""
        lines.append(
            f"  {row['source']} ({row['imu']}, {row['segment']} {row['side']}{who}): {said}"
        )
    raise FormatError(
        "right_axis is empty for these sensors; fill in column right_axis (the sensor axis, +x "
        "-x +y -y +z -z, that points to the subject's right as worn) and import again:\n"
        + "\n".join(lines)
    )


def _meta(lab: LabImport, fs_hz: float, imus: pd.DataFrame) -> dict:
    """dataset.yaml of the import."""
    return {
        "name": lab.name,
        "description": lab.description,
        "simulated": False,
        "sampling_rate_hz": fs_hz,
        "units": {"acc": "m/s^2", "gyr": "rad/s"},
        "sensor_sets": list(dict.fromkeys(imus["sensor_set"])),
        "acc_range_g": {region: ACC_RANGE_G for region in dict.fromkeys(imus["region"])},
        "gyr_range_dps": GYR_RANGE_DPS,
    }


def _write(writer: DatasetWriter, trials, report: ImportReport) -> dict:
    """Every trial's static and motion recordings; returns each test's repetitions."""
    repetitions: dict[str, int] = {}
    generated: dict[tuple, int] = {}  # (subject, static test) -> repetitions written
    for trial in trials:
        part, written = trial.parts, []
        pieces = []
        if part.get("static"):
            test, span = part["static"]
            rep = trial.rep if test == trial.test else generated.get((trial.subject, test), 0) + 1
            generated[(trial.subject, test)] = rep
            pieces.append((test, rep, span, test == WALKING_VERTICAL))
            part["written"] = (test, rep)
        if part["motion"] is not None:
            pieces.append((trial.test, trial.rep, part["motion"], False))
        for test, rep, span, mean in pieces:
            for f in trial.sensors.values():
                acc, gyr = f["acc"][span], f["gyr"][span]
                quat = None if f["quat"] is None or mean else f["quat"][span]
                if mean:
                    fs_hz = writer.meta["sampling_rate_hz"]
                    acc, gyr = mean_posture(acc, fs_hz), mean_posture(gyr, fs_hz)
                row = f["row"]
                writer.recording(
                    trial.subject, row["sensor_set"], test, rep, row["imu"], gyr, acc, quat
                )
            repetitions[test] = max(repetitions.get(test, 0), rep)
            written.append(f"{test} R{rep}")
        for f in trial.sensors.values():
            report.add(f["file"], trial.subject, f["row"]["imu"], "imported", ", ".join(written))
    return repetitions


def verticals(trials: list[Trial]) -> list[list]:
    """verticals.tsv's rows (:mod:`aceval.data.verticals`): each motion repetition whose
    recording holds quiet standing (its first seconds, or another segment of the recording that
    is static) gets that standing's vertical, its own: the sensors may have been put on again
    between recordings. The walking fallback is not quiet standing and stays averaged.
    """
    standing = {}  # the recording's files -> its quiet standing's (test, rep)
    for trial in trials:
        if trial.parts.get("written") and trial.static != "walking":
            standing.setdefault(tuple(trial.files), trial.parts["written"])
    return [
        [trial.subject, trial.test, trial.rep, *standing[tuple(trial.files)]]
        for trial in trials
        if trial.parts["motion"] is not None
        and trial.static != "walking"
        and tuple(trial.files) in standing
    ]


def _sheets(out: Path, tests: dict, repetitions: dict, imus, trials, report) -> None:
    """tests.tsv, calibrates.tsv, subjects.tsv and imus.tsv; an IMU no test calibrates is named."""
    descriptions = {
        STANDING: ("static", "quiet standing: the first seconds of trials (trials.tsv static)"),
        WALKING_VERTICAL: (
            "static",
            "FALLBACK z0, not quiet standing: the mean walking posture (the trials' movement "
            "low-passed at 0.5 Hz; trials.tsv static=walking)",
        ),
    }
    for name, test in tests.items():
        what = "quiet standing" if test["kind"] == "static" else "motion"
        descriptions[name] = (test["kind"], f"{what}: the lab's test {name} (trials.tsv)")
    written = [t for t in descriptions if t in repetitions]
    write_sheet(
        out / "tests.tsv",
        ["test", "kind", "repetitions", "first_phase", "description"],
        [
            [
                t,
                descriptions[t][0],
                repetitions[t],
                tests.get(t, {}).get("first_phase", ""),
                descriptions[t][1],
            ]
            for t in written
        ],
    )
    calibrates = [
        [t, imu]
        for t in written
        if t in tests and tests[t]["kind"] == "motion"
        for imu in dict.fromkeys(imus.loc[imus["segment"].isin(tests[t]["calibrates"]), "imu"])
    ]
    write_sheet(out / "calibrates.tsv", ["test", "imu"], calibrates)
    own, sources = verticals(trials), {}
    for trial in trials:
        named = {None: "", "file": "standing trial", "walking": "walking (FALLBACK)"}
        source = named[trial.static] if trial.static in named else f"first {trial.static:g} s"
        if source:
            sources.setdefault(trial.subject, []).append(source)
    each = {row[0] for row in own}  # each repetition its own recording's standing
    write_sheet(
        out / "subjects.tsv",
        ["subject", "z0_source"],
        [
            [
                s,
                ", ".join(dict.fromkeys(sources.get(s, [])))
                + (" (per repetition: its own recording's)" if s in each else ""),
            ]
            for s in dict.fromkeys(t.subject for t in trials)
        ],
    )
    write_sheet(out / "imus.tsv", IMU_COLUMNS, imus.to_numpy().tolist())
    if own:
        write_sheet(out / "verticals.tsv", VERTICAL_COLUMNS, own)
        report.note(
            f"{len(own)} motion repetition(s) take the vertical of their own recording's quiet "
            "standing (verticals.tsv), not the average of all of their subject's"
        )
    calibrated = {imu for _, imu in calibrates}
    motion = {t: ", ".join(v["calibrates"]) for t, v in tests.items() if v["kind"] == "motion"}
    for row in imus[~imus["imu"].isin(calibrated)].itertuples():
        why = (
            f"no test calibrates segment {row.segment!r} ("
            + "; ".join(f"{t}: {segments}" for t, segments in motion.items())
            + f"). If it is the pelvis or lower back, write waist as its segment in {row.source} "
            "(keep your name in column imu); or add the segment to the test's calibrates column"
        )
        report.add(row.source, "", row.imu, "not calibrated", why)
        report.note(f"IMU {row.imu} ({row.source}) will not be calibrated: {why}")
