"""A lab's Xsens MT Manager exports -> the dataset contract: many subjects and trials in one call,
from two sheets (config/README.md, "A lab's Xsens exports"; docs/your_data.md walks through it).

``trials.tsv`` (tab-separated; one row per trial, or per file of a trial):

* ``subject``; ``trial`` (or ``file``): a path under the exports folder, a folder or the start
  of file names (``P01/walk_01`` matches ``P01/walk_01-000_00B4A1B2.txt``: it must be followed
  by ``-``, ``_``, ``.`` or ``/``);
* ``test``: the lab's name of the condition. The trials of one subject and test are its
  repetitions, in sheet order, or as column ``rep`` numbers them;
* ``static`` (optional): where the subject's vertical (z0, Kong Eq. 2) comes from. ``file``: the
  whole trial is quiet standing (a static test named by ``test``); a number N: the trial's first
  N seconds are quiet standing (static test ``standing``), the rest is ``test``; ``walking``: no
  quiet standing, the vertical of the mean walking posture (static test ``walking_vertical``, the
  trial's movement low-passed at 0.5 Hz: a fallback, see :mod:`aceval.importers.shared`);
* ``first_phase`` (optional, as tests.tsv: ``gait`` for walking) and ``calibrates`` (optional:
  the segments the test calibrates, comma-separated; for ``gait`` by default thigh, shank, foot
  and waist: Kong Table 2's walking segments and the pelvis, as the NeuRA and qmt imports).

``sensors.tsv`` (one row per sensor, or per subject and sensor): ``sensor_id segment side``,
optionally ``imu`` (the lab's name; default segment and side, ``shank_r``), ``sensor_set``
(``main``), ``region`` (``upper_body`` for head, chest and waist, else ``lower_body``),
``right_axis`` (empty: the import proposes one from the recordings and stops) and ``subject``
(a row without one applies to every subject). ``segment`` is Kong's vocabulary (head chest
waist thigh shank foot): a segment no test calibrates is named on screen, not dropped silently.

Exports: MT Manager text files (``//`` header lines, comma- or tab-separated; Acc m/s^2, Gyr
rad/s; :func:`aceval.importers.xsens.read_mt_export`), the sensor ID from the file name
(``_<8 hex>.txt``) or the header's ``DeviceId``, the rate from ``// Update Rate``, SampleTimeFine
or ``--rate`` (checked against each other). The files of a trial must share their PacketCounter
range (one synchronised recording), or be trimmed to the samples they share (``--trim-to-shared``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.contract import FS_TOLERANCE
from aceval.data.errors import CalibrationError
from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers.lab_sheets import (
    STANDING,
    UPPER_BODY,
    WALKING_VERTICAL,
    Trial,
    find_trials,
    read_lab_sensors,
    read_trials,
    subject_sensors,
)
from aceval.importers.shared import FormatError, ImportReport, mean_posture
from aceval.importers.xsens import (
    ACC_RANGE_G,
    GYR_RANGE_DPS,
    QUATERNION,
    export_rate,
    read_mt_export,
    sensor_id_of,
    unwrapped_counter,
)
from aceval.signals.segmentation import TrimParams, movement_mask


def import_xsens_lab(
    src: str | Path,
    out: Path,
    trials_path: str | Path,
    sensors_path: str | Path,
    name: str = "xsens_lab",
    rate: float | None = None,
    trim_to_shared: bool = False,
) -> ImportReport:
    """Write the dataset of every trial of ``trials_path`` (exports under ``src``) into ``out``."""
    src, report = Path(src), ImportReport()
    table, tests = read_trials(trials_path)
    sensors = read_lab_sensors(sensors_path)
    trials = find_trials(
        src, table, report, {Path(trials_path).resolve(), Path(sensors_path).resolve()}
    )
    fs_hz = None
    for trial in trials:
        trial.sensors, trial_fs = _read_trial(trial, sensors, rate, trim_to_shared, report)
        if fs_hz is not None and abs(trial_fs / fs_hz - 1) > FS_TOLERANCE:
            raise FormatError(
                f"{trial.where} is sampled at {trial_fs:g} Hz, the trials before it at {fs_hz:g} "
                "Hz: a dataset has one rate; import the two rates as two datasets"
            )
        fs_hz = fs_hz or trial_fs
    for trial in trials:
        trial.parts = _parts(trial, fs_hz, tests)
        if tests[trial.test]["first_phase"] == "gait":
            _say_turns(trial, fs_hz, report)
    _check_statics(trials, tests)
    _check_right_axes(trials, tests, fs_hz)
    imus = _imus(trials)
    writer = DatasetWriter(out, _meta(name, src, fs_hz, imus))
    repetitions = _write(writer, trials, report)
    writer.close()
    _sheets(out, tests, repetitions, imus, trials, report)
    return report


def _read_trial(trial: Trial, sensors, rate, trim_to_shared: bool, report: ImportReport):
    """``({sensor_id: {acc, gyr, quat, row, file}}, fs_hz)`` of one trial: its exports read, their
    rates checked and their samples synchronised by PacketCounter.
    """
    rows = subject_sensors(sensors, trial.subject)
    tables, rates, paths = {}, {}, {}
    for path in trial.files:
        header, table = read_mt_export(path)
        sensor = sensor_id_of(path, header)
        if sensor not in rows:
            report.add(path.name, trial.subject, sensor, "skipped", "sensor not in sensors.tsv")
            report.note(
                f"{path}: sensor {sensor} is not in sensors.tsv for {trial.subject}: skipped"
            )
            continue
        if sensor in tables:
            raise FormatError(
                f"{trial.where}: two exports of sensor {sensor}: {paths[sensor]}, {path}"
            )
        rates[sensor], tables[sensor], paths[sensor] = (
            export_rate(header, table, path, rate),
            table,
            path,
        )
    if not tables:
        raise FormatError(
            f"{trial.where}: none of its {len(trial.files)} export(s) is of a sensor that "
            f"sensors.tsv lists for subject {trial.subject}"
        )
    if max(rates.values()) / min(rates.values()) - 1 > FS_TOLERANCE:
        listed = ", ".join(f"{s} {r:g} Hz" for s, r in rates.items())
        raise FormatError(f"{trial.where}: its sensors were sampled at different rates ({listed})")
    tables = _synchronised(trial, tables, paths, trim_to_shared, report)
    for sensor in rows:
        if sensor not in tables:
            imu = rows[sensor]["imu"]
            report.add(trial.where, trial.subject, imu, "missing", f"no export of sensor {sensor}")
            report.note(
                f"{trial.where}: no export of sensor {sensor} ({imu}): its IMU is missing there"
            )
    found = {
        s: {
            "acc": t[["Acc_X", "Acc_Y", "Acc_Z"]].to_numpy(float),
            "gyr": t[["Gyr_X", "Gyr_Y", "Gyr_Z"]].to_numpy(float),
            "quat": t[QUATERNION].to_numpy(float) if set(QUATERNION) <= set(t) else None,
            "row": rows[s],
            "file": paths[s].name,
        }
        for s, t in tables.items()
    }
    return found, next(iter(rates.values()))


def _synchronised(trial: Trial, tables: dict, paths: dict, trim: bool, report) -> dict:
    """The trial's tables on the samples they share by PacketCounter (all of them, or trimmed to
    the common range with ``trim``); FormatError with each sensor's range otherwise.
    """
    counters = {s: unwrapped_counter(t, paths[s]) for s, t in tables.items()}
    ranges = {s: (int(c[0]), int(c[-1])) for s, c in counters.items()}
    if len(set(ranges.values())) == 1:
        return tables
    first, last = max(a for a, _ in ranges.values()), min(b for _, b in ranges.values())
    common = max(set(ranges.values()), key=list(ranges.values()).count)
    others = sum(r == common for r in ranges.values())
    listed = "; ".join(
        f"{s}: {b - a + 1} samples (PacketCounter {a}-{b})"
        for s, (a, b) in ranges.items()
        if (a, b) != common or others == 1
    )
    if others > 1:
        listed += f"; the other {others}: {common[1] - common[0] + 1} ({common[0]}-{common[1]})"
    if first > last:
        raise FormatError(
            f"{trial.where}: its sensors share no sample ({listed}): they were not recorded "
            "together (a trial is one synchronised recording)"
        )
    if not trim:
        raise FormatError(
            f"{trial.where}: its sensors do not cover the same samples ({listed}). Pass "
            f"--trim-to-shared to keep the {last - first + 1} samples all of them share, or "
            "re-export the trial"
        )
    cut = {s: (first - a, b - last) for s, (a, b) in ranges.items() if (a, b) != (first, last)}
    report.note(
        f"{trial.where}: trimmed to the {last - first + 1} samples all sensors share ("
        + ", ".join(f"{s}: {a} at the start, {b} at the end" for s, (a, b) in cut.items())
        + ")"
    )
    return {
        s: t[(counters[s] >= first) & (counters[s] <= last)].reset_index(drop=True)
        for s, t in tables.items()
    }


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


def _meta(name: str, src: Path, fs_hz: float, imus: pd.DataFrame) -> dict:
    """dataset.yaml of the import."""
    return {
        "name": name,
        "description": f"Xsens MT Manager exports ({src.name}), imported by aceval import xsens "
        "--trials",
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
    sources = {}
    for trial in trials:
        named = {None: "", "file": "standing trial", "walking": "walking (FALLBACK)"}
        source = named[trial.static] if trial.static in named else f"first {trial.static:g} s"
        if source:
            sources.setdefault(trial.subject, []).append(source)
    write_sheet(
        out / "subjects.tsv",
        ["subject", "z0_source"],
        [
            [s, ", ".join(dict.fromkeys(sources.get(s, [])))]
            for s in dict.fromkeys(t.subject for t in trials)
        ],
    )
    write_sheet(out / "imus.tsv", IMU_COLUMNS, imus.to_numpy().tolist())
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
