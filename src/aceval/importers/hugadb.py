"""HuGaDB text files (Chereshnev & Kertesz-Farkas 2017) -> the dataset contract.

Format (../shared/data/README.md): three ``#`` header lines (#Activity, #ActivityID, #Date), a
line of 39 column names (36 inertial: RF RS RT LF LS LT x acc/gyro x xyz, in either spelling
``acc_rf_x`` or ``RF_acc_x``; 2 EMG; the activity ID), then tab-separated int16 samples.

Rules (each documented here and in config/README.md "Real datasets"):

* Units: accelerometer 16384 counts per g (+-2 g), gyroscope 16.4 counts per deg/s (+-2000 deg/s);
  written in m/s^2 and rad/s. The files have no time stamps: ``t = i / 58 Hz`` (the dataset's
  totals give 56-60 Hz; the trimmer's 0.5 s and 1 s windows are insensitive to that spread).
* IMUs keep HuGaDB's codes (RT RS RF LT LS LF). The boards sit with x along the segment pointing
  distally (x reads about -1 g at rest) and z out of the skin, so y = z x x points to the
  subject's left: ``right_axis = -y`` for all six (checked against the shank's swing-phase
  rotation in tests/test_importers.py).
* One subject per file (``v1_walking_01_00``...): each file is a separate session, so the sensors
  were put on again. ``various`` files: every standing run (activity 8) longer than 2 s, less
  0.5 s at each end, is a T0 repetition; every standing-up (7) run with the sitting-down (6) run
  that follows it, and the standing between, is a T3 repetition. Walking files: 5 T6 repetitions
  of equal numbers of whole strides (:func:`aceval.importers.shared.walking_bouts`, strides from
  the right shank's angular speed). Turns cannot be told apart without a trunk sensor and are
  kept.
* No standing in the walking files: z0 cannot come from T0. A separate static test ``T0w``
  holds the walking bouts low-passed at 0.5 Hz, below the stride frequency (about 0.9 Hz): the
  specific force of the mean walking posture, not of quiet standing (the thigh is flexed and the
  shank inclined on average). It is a FLAGGED FALLBACK: its calibrations carry ``z0_tests = T0w``
  and the report says so.
* Accelerometer clipping at +-2 g is counted per IMU and file and reported (import_report.tsv,
  validation warnings); ``aceval calibrate`` leaves clipped samples out of Kong's scatter.
* Corrupted gyroscopes (participant 03 per the README, and others: see the import report): an IMU
  whose gyroscope exceeds 1000 deg/s at its 99.5th percentile (twice the fastest segment rotation
  of normal walking) or sits at the int16 limits in >= 1 % of its samples is left out of that
  file's dataset, with the cause in import_report.tsv.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.contract import GRAVITY
from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers.shared import (
    FormatError,
    ImportReport,
    mean_posture,
    stride_peaks,
    stride_spans,
    walking_bouts,
)

ACC_COUNTS_PER_G = 16384.0
GYR_COUNTS_PER_DPS = 16.4
SAMPLING_RATE_HZ = 58.0
INT16_LIMITS = (-32768, 32767)
MAX_PLAUSIBLE_GYRO_DPS = 1000.0
MAX_GYRO_CLIPPED_FRACTION = 0.01
MIN_STANDING_S = 2.0
EDGE_S = 0.5
#: HuGaDB code -> (segment, side)
SENSORS = {
    "RT": ("thigh", "right"),
    "RS": ("shank", "right"),
    "RF": ("foot", "right"),
    "LT": ("thigh", "left"),
    "LS": ("shank", "left"),
    "LF": ("foot", "left"),
}
RIGHT_AXIS = "-y"
WALKING, SITTING_DOWN, STANDING_UP, STANDING = 1, 6, 7, 8
#: Kong Table 2 for these segments: T3 may calibrate thighs; T6 every lower-limb IMU
CALIBRATES = {"T3": ["RT", "LT"], "T6": list(SENSORS)}
TESTS = {
    "T0": ("static", "quiet standing (HuGaDB activity 8), 0.5 s cut at each end"),
    "T0w": (
        "static",
        "FALLBACK z0, not quiet standing: the T6 walking bouts low-passed at 0.5 Hz (mean "
        "walking posture); the walking files have no standing",
    ),
    "T3": ("motion", "standing up (activity 7), standing, sitting down (activity 6)"),
    "T6": ("motion", "walking (activity 1), bouts of equal numbers of whole strides"),
}
N_COLUMNS = 39
_NAME = re.compile(r"(?:(acc|gyro)_(rf|rs|rt|lf|ls|lt)|(rf|rs|rt|lf|ls|lt)_(acc|gyro))_([xyz])")
_FILE = re.compile(r"HuGaDB_v(\d+)_([a-z]+)_(\d+)_(\d+)(?:-\w+)?\.txt")


@dataclass
class HugadbFile:
    """One HuGaDB file: its date, the activity ID of each sample and the raw int16 counts."""

    path: Path
    date: str
    activity: np.ndarray  # (N,) int
    counts: dict  # sensor code -> (acc (N, 3) counts, gyr (N, 3) counts)

    def acc(self, sensor: str) -> np.ndarray:
        """m/s^2"""
        return self.counts[sensor][0] / ACC_COUNTS_PER_G * GRAVITY

    def gyr(self, sensor: str) -> np.ndarray:
        """rad/s"""
        return np.radians(self.counts[sensor][1] / GYR_COUNTS_PER_DPS)


def _canonical(name: str) -> str:
    """'acc_rf_x' and 'RF_acc_x' -> 'RF_acc_x'; other names lower-cased."""
    match = _NAME.fullmatch(name.strip().lower())
    if not match:
        return name.strip().lower()
    kind, sensor = (
        (match.group(1), match.group(2)) if match.group(1) else (match.group(4), match.group(3))
    )
    return f"{sensor.upper()}_{kind}_{match.group(5)}"


EXPECTED = [
    f"{s}_{k}_{a}"
    for s in ["RF", "RS", "RT", "LF", "LS", "LT"]
    for k in ("acc", "gyro")
    for a in "xyz"
]


def read_hugadb(path: str | Path) -> HugadbFile:
    """Read one HuGaDB file; FormatError names the file, the line and the cause."""
    path = Path(path)
    with open(path, encoding="utf-8", errors="replace") as handle:
        header = [handle.readline() for _ in range(4)]
    for number, tag in enumerate(("#Activity", "#ActivityID", "#Date"), start=1):
        if not header[number - 1].startswith(tag):
            raise FormatError(
                f"{path}: line {number}: expected a header line starting with {tag!r}, "
                f"found {header[number - 1][:40]!r} (is this a HuGaDB file?)"
            )
    names = [_canonical(c) for c in header[3].rstrip("\r\n").split("\t") if c.strip()]
    missing = [c for c in EXPECTED + ["act"] if c not in names]
    if len(names) != N_COLUMNS or missing:
        raise FormatError(
            f"{path}: line 4: expected {N_COLUMNS} column names including the 36 inertial "
            f"columns and 'act'; found {len(names)}"
            + (f", missing {', '.join(missing[:4])}" if missing else "")
        )
    try:
        table = pd.read_csv(
            path, sep="\t", skiprows=4, header=None, names=names, engine="c", dtype=str
        )
    except pd.errors.ParserError as exc:
        found = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
        where = (
            f"line {found.group(2)}: {found.group(3)} fields, expected {found.group(1)}"
            if found
            else str(exc)
        )
        raise FormatError(f"{path}: {where} (a truncated or garbled file?)") from exc
    values = table.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise FormatError(
            f"{path}: line {first + 5}: {int(bad.sum())} row(s) with missing or non-numeric values "
            f"(a truncated or garbled file?)"
        )
    if len(values) == 0:
        raise FormatError(f"{path}: no samples after the header")
    inertial = values[:, [names.index(c) for c in EXPECTED]]
    outside = (
        (inertial < INT16_LIMITS[0])
        | (inertial > INT16_LIMITS[1])
        | (inertial != np.round(inertial))
    )
    if outside.any():
        first = int(np.flatnonzero(outside.any(axis=1))[0])
        raise FormatError(f"{path}: line {first + 5}: inertial values must be int16 counts")
    counts = {
        s: (inertial[:, 6 * k : 6 * k + 3], inertial[:, 6 * k + 3 : 6 * k + 6])
        for k, s in enumerate(["RF", "RS", "RT", "LF", "LS", "LT"])
    }
    return HugadbFile(
        path, header[2][len("#Date") :].strip(), values[:, names.index("act")].astype(int), counts
    )


def gyro_fault(gyr_counts: np.ndarray) -> str:
    """'' when the gyroscope is plausible, else the cause (see the module's rules)."""
    clipped = clipped_fraction(gyr_counts)
    p995 = float(np.percentile(np.abs(gyr_counts), 99.5)) / GYR_COUNTS_PER_DPS
    causes = []
    if p995 > MAX_PLAUSIBLE_GYRO_DPS:
        causes.append(f"99.5th percentile {p995:.0f} deg/s > {MAX_PLAUSIBLE_GYRO_DPS:.0f}")
    if clipped >= MAX_GYRO_CLIPPED_FRACTION:
        causes.append(f"{clipped:.1%} of samples at the int16 limits")
    return "corrupted gyroscope: " + "; ".join(causes) if causes else ""


def clipped_fraction(counts: np.ndarray) -> float:
    """Fraction of samples (N, 3) with any axis at the int16 limits."""
    return float(((counts <= INT16_LIMITS[0]) | (counts >= INT16_LIMITS[1])).any(axis=1).mean())


def _runs(activity: np.ndarray) -> list[tuple[int, int, int]]:
    """(activity, start, stop) of each run of equal activity IDs (half-open)."""
    edges = np.flatnonzero(np.diff(activity)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [len(activity)]])
    return [(int(activity[a]), int(a), int(b)) for a, b in zip(starts, stops)]


def protocol_ranges(
    data: HugadbFile, fs_hz: float = SAMPLING_RATE_HZ
) -> dict[str, list[tuple[int, int]]]:
    """Sample ranges of each test's repetitions in one file (the module's rules)."""
    runs = _runs(data.activity)
    edge, shortest = int(EDGE_S * fs_hz), int(MIN_STANDING_S * fs_hz)
    ranges: dict[str, list] = {}
    standing = [(a + edge, b - edge) for act, a, b in runs if act == STANDING and b - a >= shortest]
    if standing:
        ranges["T0"] = standing
    cycles = []
    for k, (act, start, _) in enumerate(runs):
        if act != STANDING_UP:
            continue
        following = [r for r in runs[k + 1 : k + 3] if r[0] == SITTING_DOWN]
        if following:
            cycles.append((start, following[0][2]))
    if cycles:
        ranges["T3"] = cycles
    walking = [(a, b) for act, a, b in runs if act == WALKING]
    bouts = []
    for a, b in walking:
        peaks = stride_peaks(data.gyr("RS")[a:b], fs_hz)
        bouts += [(a + lo, a + hi) for lo, hi in walking_bouts(stride_spans(peaks))]
    if bouts:
        ranges["T6"] = bouts
        if "T0" not in ranges:
            ranges["T0w"] = bouts
    return ranges


def dataset_meta() -> dict:
    """dataset.yaml of an imported HuGaDB dataset."""
    return {
        "name": "hugadb",
        "description": "HuGaDB (Chereshnev & Kertesz-Farkas 2017), recorded data; "
        "imported by aceval import hugadb; walking sessions use the flagged T0w fallback for z0",
        "simulated": False,
        "sampling_rate_hz": SAMPLING_RATE_HZ,
        "units": {"acc": "m/s^2", "gyr": "rad/s"},
        "acc_at_rest": "up",  # the importer writes specific force
        "sensor_sets": ["legs"],
        "acc_range_g": {"lower_body": 2.0},
        "gyr_range_dps": 2000.0,
    }


def import_hugadb(src: str | Path, out: Path) -> ImportReport:
    """Convert every ``HuGaDB_*.txt`` in ``src`` into a dataset at ``out`` (an empty folder)."""
    src = Path(src)
    files = sorted(src.glob("HuGaDB_*.txt"))
    if not files:
        raise FormatError(
            f"{src}: no HuGaDB_*.txt files (get HuGaDB from "
            "https://github.com/romanchereshnev/HuGaDB and point SRC at its Data folder)"
        )
    writer = DatasetWriter(out, dataset_meta())
    report = ImportReport()
    subjects, repetitions = [], {}
    for path in files:
        match = _FILE.fullmatch(path.name)
        if not match:
            report.add(
                path.name,
                "",
                "",
                "skipped",
                "file name is not HuGaDB_v<version>_<kind>_<participant>_<counter>.txt",
            )
            continue
        subject = path.name[len("HuGaDB_") :].split("-")[0].removesuffix(".txt")
        data = read_hugadb(path)
        ranges = protocol_ranges(data)
        if not any(test in ranges for test in CALIBRATES):
            report.add(
                path.name,
                subject,
                "",
                "skipped",
                "no standing-up/sitting-down cycle and no walking bout",
            )
            continue
        written = _write_session(writer, report, path, subject, data, ranges, repetitions)
        if written:
            subjects.append(
                [
                    subject,
                    match.group(3),
                    data.date,
                    path.name,
                    "T0" if "T0" in ranges else "T0w (fallback)",
                ]
            )
            report.add(
                path.name,
                subject,
                "",
                "imported",
                "; ".join(f"{test} x{len(spans)}" for test, spans in ranges.items())
                + f"; {written} of 6 IMUs",
            )
        else:
            report.add(path.name, subject, "", "skipped", "no IMU left")
    tests = {t: v for t, v in TESTS.items() if t in repetitions}
    writer.protocol_sheets(tests, repetitions, {t: CALIBRATES[t] for t in CALIBRATES if t in tests})
    writer.close()
    write_sheet(
        out / "subjects.tsv",
        ["subject", "participant", "date", "source_file", "z0_source"],
        subjects,
    )
    write_sheet(
        out / "imus.tsv",
        ["imu", "segment", "side", "region", "right_axis"],
        [
            [imu, segment, side, "lower_body", RIGHT_AXIS]
            for imu, (segment, side) in SENSORS.items()
        ],
    )
    return report


def _write_session(writer, report, path, subject, data, ranges, repetitions: dict) -> int:
    """Every usable IMU's recordings of one session (each test's spans as repetitions; a walking
    session's T0w as its mean posture), the gyroscope faults excluded and clipping flagged in
    the report; ``repetitions`` (test -> most repetitions) updated. Returns the IMUs written.
    """
    written = 0
    for imu in SENSORS:
        acc_counts, gyr_counts = data.counts[imu]
        fault = gyro_fault(gyr_counts)
        if fault:
            report.add(path.name, subject, imu, "excluded", fault)
            continue
        clipped = clipped_fraction(acc_counts)
        if clipped > 0:
            report.add(
                path.name,
                subject,
                imu,
                "flagged",
                f"{clipped:.1%} of samples clipped at +-2 g "
                "(left out of Kong's scatter by aceval calibrate)",
            )
        acc, gyr = data.acc(imu), data.gyr(imu)
        for test, spans in ranges.items():
            if test in CALIBRATES and imu not in CALIBRATES[test]:
                continue
            for rep, (a, b) in enumerate(spans, start=1):
                if test == "T0w":
                    gyr_part = mean_posture(gyr[a:b], SAMPLING_RATE_HZ)
                    acc_part = mean_posture(acc[a:b], SAMPLING_RATE_HZ)
                else:
                    gyr_part, acc_part = gyr[a:b], acc[a:b]
                writer.recording(subject, "legs", test, rep, imu, gyr_part, acc_part)
                repetitions[test] = max(repetitions.get(test, 0), rep)
        written += 1
    return written
