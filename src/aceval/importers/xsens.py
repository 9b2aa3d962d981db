"""Xsens MT Manager text exports -> the dataset contract (one trial: standing, then walking).

An export has ``//`` header lines (``// Update Rate: 100.0Hz`` ...), a column header line and
one row per sample, comma- or tab-separated (sniffed: MT Manager versions write either), with
at least PacketCounter, Acc_X..Z (m/s^2) and Gyr_X..Z (rad/s). A sensor sheet (tab-separated:
``sensor_id imu sensor_set segment side region right_axis``) says which sensor is which IMU;
e.g. config/real/neura_sensors.tsv for ../shared/data/neura_gaittoolbox.

Rules (documented in config/README.md "Real datasets"):

* All files of the trial must share their PacketCounter range (one synchronised recording);
  byte-identical files are reported as duplicates and only the one the sheet names is used.
* Movement is Kong's trimmer (Fig. 5) on each sensor; the trial moves from the first moving
  sample of any sensor to the last. T0 = from the start to 1 s before the movement (at least 2 s).
* T6 = the straight strides of the movement (strides from the first shank IMU of the sheet;
  a stride during which the waist sensor's heading turns by 20 deg or more is left out), grouped
  into at most 5 repetitions of equal numbers of whole strides
  (:func:`aceval.importers.shared.walking_bouts`).
* Kong Table 2: T6 may calibrate thighs, shanks and feet. The pelvis too, as in the qmt import:
  Kong calibrates it from the trunk tests T1-T3, absent here, and walking is what this recording
  has to compare methods on the pelvis with (its Kong calibration from walking is expected to be
  flagged: the pelvis does not move in a plane; the step-harmonic heading is made for it).
"""

from __future__ import annotations

import csv
import filecmp
import re
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.errors import CalibrationError
from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers import shared
from aceval.importers.lab_trials import SensorSamples, agreed_rate
from aceval.importers.shared import (
    FormatError,
    ImportReport,
    straight_strides,
    stride_peaks,
    stride_spans,
    text_encoding,
    walking_bouts,
)
from aceval.signals.segmentation import TrimParams, movement_mask

REQUIRED = ["PacketCounter", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z"]
QUATERNION = ["Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3"]
SHEET_COLUMNS = ["sensor_id", "imu", "sensor_set", "segment", "side", "region", "right_axis"]
STANDING_MARGIN_S = 1.0
MIN_STANDING_S = 2.0
#: which segments T6 (walking) may calibrate: Kong Table 2's, and the pelvis (module docstring)
T6_SEGMENTS = ("thigh", "shank", "foot", "waist")
#: Xsens MTw datasheet: +-160 m/s^2 (16 g), +-2000 deg/s
ACC_RANGE_G = 16.0
GYR_RANGE_DPS = 2000.0
_ID = re.compile(r"_([0-9A-Fa-f]{8})\.(?:txt|csv)$")
#: MT Manager's SampleTimeFine: 10 kHz ticks of a 32-bit clock; its PacketCounter: 16 bits
SAMPLE_TIME, TICKS_PER_S, TICKS_WRAP, COUNTER_WRAP = "SampleTimeFine", 10000.0, 2**32, 2**16


def read_mt_export(path: str | Path) -> tuple[dict, pd.DataFrame]:
    """(header fields, samples) of one MT Manager export, comma- or tab-separated (MT Manager
    versions write either: the separator is sniffed from the column header line and is in the
    header fields as ``separator``); FormatError names the file, the line and what was found.
    """
    path = Path(path)
    header, lines = {}, []
    with open(path, encoding=text_encoding(path), errors="replace") as handle:
        for number, line in enumerate(handle, start=1):
            if line.startswith("//"):
                key, _, value = line[2:].partition(":")
                header[key.strip()] = value.strip()
            elif line.strip():
                lines.append((number, line))
    if not lines:
        raise FormatError(
            f"{path}: no column header and no samples (is this an MT Manager export?)"
        )
    separator = _separator(path, *lines[0])
    header["separator"] = SEPARATORS[separator]
    columns = [c.strip() for c in lines[0][1].rstrip("\r\n").split(separator)]
    trailing = columns[-1] == ""  # a separator at the end of every line (some exports)
    columns = columns[:-1] if trailing else columns
    missing = [c for c in REQUIRED if c not in columns]
    if missing:
        raise FormatError(
            f"{path}: line {lines[0][0]} (read as {SEPARATORS[separator]}): missing column(s) "
            f"{', '.join(missing)}; found {', '.join(columns[:12]) or 'no names'}"
            f"{' ...' if len(columns) > 12 else ''} (an MT Manager export with Acc in m/s^2 and "
            "Gyr in rad/s is expected)"
        )
    rows = []
    for number, line in lines[1:]:
        fields = line.rstrip("\r\n").split(separator)
        if trailing and len(fields) == len(columns) + 1 and not fields[-1].strip():
            fields = fields[:-1]
        if len(fields) != len(columns):
            raise FormatError(
                f"{path}: line {number}: {len(fields)} fields, the header has {len(columns)} "
                f"(read as {SEPARATORS[separator]}; a truncated or garbled file?)"
            )
        rows.append(fields)
    table = pd.DataFrame(rows, columns=columns)
    values = table[REQUIRED].apply(pd.to_numeric, errors="coerce")
    bad = ~np.isfinite(values.to_numpy(dtype=float)).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise FormatError(
            f"{path}: line {lines[first + 1][0]}: missing or non-numeric values in {', '.join(REQUIRED)}"
        )
    if len(values) < 2:
        raise FormatError(f"{path}: fewer than 2 samples")
    if set(QUATERNION) <= set(columns):  # the orientation, where exported and complete
        quat = table[QUATERNION].apply(pd.to_numeric, errors="coerce")
        if np.isfinite(quat.to_numpy(dtype=float)).all():
            values = pd.concat([values, quat], axis=1)
    if SAMPLE_TIME in columns:  # the device's clock, where exported (MT Manager may leave it empty)
        ticks = pd.to_numeric(table[SAMPLE_TIME], errors="coerce")
        if np.isfinite(ticks.to_numpy(dtype=float)).all():
            values[SAMPLE_TIME] = ticks
    return header, values


def not_an_export(path: Path) -> str:
    """Why a file beside MT Manager exports is not one of them ('' when it is, or is named as
    one: then reading it says what is wrong with it): a file of another kind (``.mtb``, a log),
    a JSON file (a sensorspec: which sensor is on which segment) or text of another shape.
    """
    if _ID.search(path.name):
        return ""
    suffix = path.suffix.lower()
    if suffix == ".mtb":
        return "MT Manager's binary recording (.mtb): the text exports beside it are read"
    if suffix not in (".txt", ".csv"):
        return f"not a text export ({suffix or 'no'} file extension)"
    with open(path, encoding=text_encoding(path), errors="replace") as handle:
        head = handle.read(4096)
    first = next((line.strip() for line in head.splitlines() if line.strip()), "")
    if first.startswith("//") or "PacketCounter" in first:
        return ""
    if first.startswith(("{", "[")):
        return "a JSON file (a sensorspec: which sensor is on which segment?), not an export"
    return (
        f"not an MT Manager export (its first line is {first[:40]!r}; an export starts with "
        "'//' header lines or its column header)"
    )


#: the separators an MT Manager export may use, as the messages name them
SEPARATORS = {",": "comma-separated", "\t": "tab-separated"}


def _separator(path: Path, number: int, line: str) -> str:
    """The separator of the column header line, sniffed (csv.Sniffer) among :data:`SEPARATORS`;
    FormatError saying what the line holds when it is neither.
    """
    try:
        return csv.Sniffer().sniff(line, delimiters="".join(SEPARATORS)).delimiter
    except csv.Error:
        raise FormatError(
            f"{path}: line {number}: the column header is neither comma- nor tab-separated "
            f"({line.strip()[:60]!r})"
        ) from None


def export_rates(header: dict, values: pd.DataFrame) -> dict:
    """Where one export says its rate (Hz): ``{"its '// Update Rate' line": ..., "its
    SampleTimeFine": ...}`` (the second derived from the 10 kHz ticks over the PacketCounter's
    samples), each where present.
    """
    found = {}
    match = re.match(r"([\d.]+)\s*Hz", header.get("Update Rate", ""))
    if match:
        found["its '// Update Rate' line"] = float(match.group(1))
    if SAMPLE_TIME in values and len(values) > 1:
        ticks = np.diff(values[SAMPLE_TIME].to_numpy(np.int64)) % TICKS_WRAP
        samples = np.diff(values["PacketCounter"].to_numpy(np.int64)) % COUNTER_WRAP
        if ticks.sum() > 0:
            found["its SampleTimeFine"] = float(round(TICKS_PER_S * samples.sum() / ticks.sum(), 2))
    return found


def export_rate(header: dict, values: pd.DataFrame, path, rate: float | None = None) -> float:
    """Samples per second of one export: ``rate`` (``--rate``) or the ``// Update Rate: <n>Hz``
    header line, else derived from SampleTimeFine (10 kHz ticks) over the PacketCounter's samples;
    whichever of the three are there must agree within the contract's 2 %. FormatError saying
    what was found and what to do.
    """
    return agreed_rate(_rates(header, values, path, rate), path)


def _rates(header: dict, values: pd.DataFrame, path, rate: float | None) -> dict:
    """``--rate`` and where the export says its rate (:func:`export_rates`); FormatError asking
    for ``--rate`` when none is there.
    """
    found = ({"--rate": float(rate)} if rate is not None else {}) | export_rates(header, values)
    if not found:
        raise FormatError(
            f"{path}: no '// Update Rate: <n>Hz' header line and no SampleTimeFine values, so "
            "its sampling rate is unknown: give it with --rate (e.g. --rate 100)"
        )
    return found


def xsens_samples(path: Path, rate: float | None = None) -> list[SensorSamples]:
    """One MT Manager export as :class:`aceval.importers.lab_trials.SensorSamples` (its sensor
    from the file name or DeviceId, its PacketCounter unwrapped as the sample index, where it
    says its rate; ``rate``: ``--rate``).
    """
    header, values = read_mt_export(path)
    rates = _rates(header, values, path, rate)
    counter = values["PacketCounter"].to_numpy(np.int64)
    return [
        SensorSamples(
            sensor=sensor_id_of(path, header),
            path=Path(path),
            acc=values[["Acc_X", "Acc_Y", "Acc_Z"]].to_numpy(float),
            gyr=values[["Gyr_X", "Gyr_Y", "Gyr_Z"]].to_numpy(float),
            quat=values[QUATERNION].to_numpy(float) if set(QUATERNION) <= set(values) else None,
            index=counter[0] + np.concatenate([[0], np.cumsum(np.diff(counter) % COUNTER_WRAP)]),
            rates=rates,
            declared=list(rates) == ["--rate"],
            clock="PacketCounter",
        )
    ]


def sensor_id_of(path: Path, header: dict) -> str:
    """The sensor ID of an export: from its file name (``..._<8 hex>.txt``) or its header's
    ``DeviceId`` line; FormatError when neither says or they disagree.
    """
    named = _ID.search(Path(path).name)
    device = header.get("DeviceId", "").strip().upper()
    if named and device and named.group(1).upper() != device:
        raise FormatError(
            f"{path}: its name says sensor {named.group(1).upper()}, its DeviceId line {device}"
        )
    if not named and not device:
        raise FormatError(
            f"{path}: no sensor ID: name the file ..._<8-hex sensor ID>.txt (as MT Manager does) "
            "or keep its '// DeviceId' header line"
        )
    return named.group(1).upper() if named else device


def read_sensor_sheet(path: str | Path) -> pd.DataFrame:
    """The sensor sheet (``SHEET_COLUMNS``, tab-separated, ``#`` comments)."""
    return shared.read_sensor_sheet(path, SHEET_COLUMNS)


def trial_spans(
    gyr_by_imu: dict, stride_imu: str, fs_hz: float, yaw_rate: np.ndarray | None = None
) -> dict[str, list[tuple[int, int]]]:
    """T0 and T6 sample ranges of a standing-then-walking trial (the module's rules); ``yaw_rate``
    (rad/s about the vertical, e.g. of a waist sensor) leaves turning strides out.
    """
    masks = [movement_mask(gyr, fs_hz) for gyr in gyr_by_imu.values()]
    moving = np.flatnonzero(np.any(masks, axis=0))
    start, stop = int(moving[0]), int(moving[-1]) + 1
    standing_end = start - int(STANDING_MARGIN_S * fs_hz)
    spans = {}
    if standing_end >= MIN_STANDING_S * fs_hz:
        spans["T0"] = [(0, standing_end)]
    strides = [
        (start + a, start + b)
        for a, b in stride_spans(stride_peaks(gyr_by_imu[stride_imu][start:stop], fs_hz))
    ]
    if yaw_rate is not None:
        strides = straight_strides(strides, yaw_rate, fs_hz)
    bouts = walking_bouts(strides)
    if bouts:
        spans["T6"] = bouts
        first = shared.first_stretch(strides)
        spans["first_straight"] = [(first[0][0], first[-1][1])]
        spans["strides"] = first  # the truth's per-stride uncertainty reads them
    return spans


def import_xsens(
    src: str | Path,
    out: Path,
    sensors: str | Path,
    subject: str,
    name: str = "xsens",
    description: str = "",
    rate: float | None = None,
) -> tuple[ImportReport, dict]:
    """Convert one trial's exports in ``src`` (``*_<sensor id>.txt``) into a dataset at ``out``
    (``rate``: ``--rate``, see :func:`export_rate`).

    Returns the report and, for callers that add ground truth (:mod:`aceval.importers.vicon`),
    ``{"signals": {(sensor_set, imu): (gyr, acc)}, "spans": {test: ranges}, "fs_hz": ...,
    "sensor_ids": {(sensor_set, imu): id}}`` (SI units, sample ranges half-open).
    """
    src = Path(src)
    sheet = read_sensor_sheet(sensors)
    report = ImportReport()
    files, wanted = _exports(src, sheet, sensors, subject, report)
    gyr, acc, quat, fs_hz = _synchronised(src, files, wanted, rate)
    spans = _trial_spans(src, sensors, wanted, gyr, acc, fs_hz)
    meta = {
        "name": name,
        "description": description
        or f"Xsens MT Manager exports ({src.name}), imported by aceval import xsens",
        "simulated": False,
        "sampling_rate_hz": fs_hz,
        "units": {"acc": "m/s^2", "gyr": "rad/s"},
        "acc_at_rest": "up",  # the importer writes specific force
        "sensor_sets": list(dict.fromkeys(sheet["sensor_set"])),
        "acc_range_g": {region: ACC_RANGE_G for region in sorted(set(sheet["region"]))},
        "gyr_range_dps": GYR_RANGE_DPS,
    }
    writer = DatasetWriter(out, meta)
    for sensor_id, row in wanted.items():
        for test, ranges in ((t, r) for t, r in spans.items() if t in ("T0", "T6")):
            for rep, (a, b) in enumerate(ranges, start=1):
                q = None if quat[sensor_id] is None else quat[sensor_id][a:b]
                writer.recording(
                    subject,
                    row["sensor_set"],
                    test,
                    rep,
                    row["imu"],
                    gyr[sensor_id][a:b],
                    acc[sensor_id][a:b],
                    q,
                )
        report.add(
            files[sensor_id].name,
            subject,
            row["imu"],
            "imported",
            f"set {row['sensor_set']}; " + "; ".join(f"{t} x{len(spans[t])}" for t in ("T0", "T6")),
        )
    _sheets(writer, out, sheet, wanted, spans, subject)
    signals = {(row["sensor_set"], row["imu"]): (gyr[s], acc[s]) for s, row in wanted.items()}
    return report, {
        "signals": signals,
        "spans": spans,
        "fs_hz": fs_hz,
        "sensor_ids": {(r["sensor_set"], r["imu"]): s for s, r in wanted.items()},
    }


def _exports(src: Path, sheet, sensors, subject: str, report: ImportReport):
    """``(files, wanted)``: the export of each sensor id, and the sensor sheet's row of each
    sensor it names; an export of another sensor is reported skipped (naming its byte-identical
    twin, if any), a named sensor without an export is an error.
    """
    files = {m.group(1).upper(): p for p in sorted(src.glob("*.txt")) if (m := _ID.search(p.name))}
    if not files:
        raise FormatError(f"{src}: no MT Manager exports named *_<8-hex sensor id>.txt")
    wanted = {row["sensor_id"].upper(): row for row in sheet.to_dict("records")}
    for sensor_id, path in files.items():
        if sensor_id in wanted:
            continue
        twin = next(
            (s for s in wanted if s in files and filecmp.cmp(files[s], path, shallow=False)), None
        )
        report.add(
            path.name,
            subject,
            sensor_id,
            "skipped",
            f"byte-identical duplicate of {twin}" if twin else "sensor not in the sensor sheet",
        )
    absent = [s for s in wanted if s not in files]
    if absent:
        raise FormatError(f"{src}: no export for sensor(s) {', '.join(absent)} of {sensors}")
    return files, wanted


def _synchronised(src: Path, files: dict, wanted: dict, rate: float | None = None):
    """``(gyr, acc, quat, fs_hz)`` of the wanted sensors (by id; quat None when not exported:
    the Xsens orientation, scalar first, sensor -> its z-up world); FormatError unless the
    exports are one synchronised trial (the same packet counters and rate).
    """
    tables, rates = {}, set()
    for sensor_id in wanted:
        header, table = read_mt_export(files[sensor_id])
        rates.add(export_rate(header, table, files[sensor_id], rate))
        tables[sensor_id] = table
    counters = {
        s: (int(t["PacketCounter"].iloc[0]), int(t["PacketCounter"].iloc[-1]), len(t))
        for s, t in tables.items()
    }
    if len(set(counters.values())) != 1 or len(rates) != 1:
        raise FormatError(
            f"{src}: the exports are not one synchronised trial (PacketCounter first, last, "
            f"count per sensor: {counters}; rates {sorted(rates)} Hz)"
        )
    gyr = {s: t[["Gyr_X", "Gyr_Y", "Gyr_Z"]].to_numpy(float) for s, t in tables.items()}
    acc = {s: t[["Acc_X", "Acc_Y", "Acc_Z"]].to_numpy(float) for s, t in tables.items()}
    quat = {
        s: t[QUATERNION].to_numpy(float) if set(QUATERNION) <= set(t.columns) else None
        for s, t in tables.items()
    }
    return gyr, acc, quat, rates.pop()


def _trial_spans(src, sensors, wanted: dict, gyr, acc, fs_hz: float) -> dict:
    """The trial's standing (T0) and walking (T6) spans from the first shank's strides (the turn
    left out with the waist's yaw rate, when there is a waist sensor).
    """
    shanks = [s for s, row in wanted.items() if row["segment"] == "shank"]
    if not shanks:
        raise FormatError(f"{sensors}: no shank sensor to count strides with")
    waist = [s for s, row in wanted.items() if row["segment"] == "waist"]
    yaw_rate = None
    if waist:  # vertical from the first second, when the subject stands
        vertical = acc[waist[0]][: int(fs_hz)].mean(axis=0)
        yaw_rate = gyr[waist[0]] @ (vertical / np.linalg.norm(vertical))
    try:
        spans = trial_spans(gyr, shanks[0], fs_hz, yaw_rate)
    except CalibrationError as exc:
        limit = TrimParams().min_peak_rad_s
        still = [s for s, g in gyr.items() if np.linalg.norm(g, axis=1).max() < limit]
        raise FormatError(
            f"{src}: one trial of quiet standing then walking is expected, but sensor(s) "
            f"{', '.join(still)} do not move ({exc}). A lab's trials (standing apart, or no "
            "standing): aceval import xsens --trials (config/README.md)"
        ) from None
    missing = [
        what
        for test, what in (
            (
                "T0",
                f"at least {MIN_STANDING_S:g} s of quiet standing ending {STANDING_MARGIN_S:g} s "
                "before the first movement",
            ),
            ("T6", "whole straight strides of walking"),
        )
        if test not in spans
    ]
    if missing:
        raise FormatError(
            f"{src}: one trial of quiet standing then walking is expected; found no "
            f"{' and no '.join(missing)}. A lab's trials (standing apart, or no standing): "
            "aceval import xsens --trials (config/README.md)"
        )
    return spans


def _sheets(writer: DatasetWriter, out: Path, sheet, wanted: dict, spans: dict, subject) -> None:
    """tests.tsv, calibrates.tsv (T6 calibrates the T6 segments), subjects.tsv and imus.tsv."""
    t6_imus = sorted({row["imu"] for row in wanted.values() if row["segment"] in T6_SEGMENTS})
    writer.protocol_sheets(
        {
            "T0": ("static", "quiet standing before the walk"),
            "T6": ("motion", "walking, repetitions of equal numbers of whole strides"),
        },
        {test: len(r) for test, r in spans.items()},
        {"T6": t6_imus},
    )
    writer.close()
    write_sheet(out / "subjects.tsv", ["subject"], [[subject]])
    write_sheet(
        out / "imus.tsv",
        ["imu", "sensor_set", "segment", "side", "region", "right_axis"],
        sheet[["imu", "sensor_set", "segment", "side", "region", "right_axis"]].to_numpy().tolist(),
    )
