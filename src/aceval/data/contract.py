"""The dataset contract's vocabulary (docs/design.md, section 1): units, columns, limits, the
validation report, and one recording file read into SI units.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.rotations import AXIS_VECTORS

GRAVITY = 9.81  # m/s^2: 1 g, used for unit conversion and by the simulator's physics
ACC_UNITS = {"g": GRAVITY, "m/s^2": 1.0}
GYR_UNITS = {"deg/s": np.pi / 180.0, "rad/s": 1.0}
#: dataset.yaml ``acc_at_rest``: where the accelerometer's reading points at rest. ``up`` (the
#: default, the contract's convention): specific force, as accelerometers report it; ``down``:
#: gravity, as some phone APIs report it (the files' acceleration is negated when read)
ACC_AT_REST = {"up": 1.0, "down": -1.0}


def acc_factor(meta: dict) -> float:
    """Factor from a dataset's file acceleration to specific force in m/s^2: the unit
    (``units.acc``) and the sign convention (``acc_at_rest``, :data:`ACC_AT_REST`).
    """
    return ACC_UNITS[meta["units"]["acc"]] * ACC_AT_REST[meta.get("acc_at_rest", "up")]


RECORDING_COLUMNS = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
#: optional columns of a recording: the vendor's orientation estimate (scalar first, sensor -> the
#: vendor's z-up world); read only by the OpenSense peer (workflow/peers/)
QUAT_COLUMNS = ["quat_w", "quat_x", "quat_y", "quat_z"]
R_COLUMNS = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
#: the column of a calibration (and of a decision's row) naming the recordings it was made from: the
#: SHA-1 of its subject's recordings (:func:`aceval.apply.copies.fingerprints`), which apply compares
FINGERPRINT = "recordings_sha1"
SHEETS = {
    "imus.tsv": ["imu", "segment", "side", "region", "right_axis"],
    "tests.tsv": ["test", "kind", "repetitions"],
    "calibrates.tsv": ["test", "imu"],
    "subjects.tsv": ["subject"],
    "recordings.tsv": ["subject", "sensor_set", "test", "rep", "imu", "path"],
}
OPTIONAL_SHEETS = {
    "ground_truth.tsv": ["subject", "sensor_set", "imu", *R_COLUMNS],
    "functional_axes.tsv": ["test", "segment", "axis"],
    "verticals.tsv": ["subject", "test", "rep", "static_test", "static_rep"],
}
#: median |acc| (g) of a static recording: outside the wide band the declared units are wrong (an
#: error: g and m/s^2 differ 9.81-fold); outside the narrow one the subject was not at rest (a
#: warning: e.g. a fallback static test taken from walking)
UNITS_GRAVITY_BAND = (0.5, 2.0)
REST_GRAVITY_BAND = (0.8, 1.2)
#: a sample within this fraction of the declared range counts as saturated
SATURATION_FRACTION = 0.999
#: imus.tsv right_axis: a signed sensor axis; a bare letter means the positive axis
RIGHT_AXIS_SPELLINGS = (*AXIS_VECTORS, "x", "y", "z")
#: tests.tsv first_phase: the body-frame rotation of the first movement phase (right-hand rule:
#: -y = the segment's top tilts forward, e.g. bowing), or ``gait`` (walking: no first phase, the
#: shanks swing forward fastest), or empty (no direction check)
FIRST_PHASES = ("-y", "+y", "gait", "")
#: first_phase of Kong's tests when tests.tsv has no first_phase column (Kong Sec. 2.2: bowing,
#: sit-to-stand flex forward first; the seated shank lift and the leg swing move forward first)
KONG_FIRST_PHASE = {"T1": "-y", "T2": "-y", "T3": "-y", "T4": "+y", "T5": "+y", "T6": "gait"}
#: a run of at least this many equal samples at a signal's largest |value| is a clipping plateau
PLATEAU_RUN = 3
#: recordings shorter than this (s) get a warning
SHORT_RECORDING_S = 1.0
#: sampling interval in t may differ from 1/sampling_rate_hz by this fraction
FS_TOLERANCE = 0.02


class DatasetError(ValueError):
    """The dataset does not satisfy the contract; the message is the validation report."""


@dataclass
class Finding:
    """One problem found by the validation: level, where (sheet or file, line) and cause."""

    level: str  # "error" | "warning"
    where: str  # sheet or file, with line
    cause: str

    def __str__(self) -> str:
        return f"{self.level.upper():7s} {self.where}: {self.cause}"


@dataclass
class ValidationReport:
    """Every finding of one validation; ``ok`` when there is no error."""

    dataset: str
    findings: list[Finding] = field(default_factory=list)

    def error(self, where, cause):
        """Record an error at ``where``."""
        self.findings.append(Finding("error", where, cause))

    def warning(self, where, cause):
        """Record a warning at ``where``."""
        self.findings.append(Finding("warning", where, cause))

    @property
    def errors(self) -> list[Finding]:
        """The error findings."""
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        """The warning findings."""
        return [f for f in self.findings if f.level == "warning"]

    @property
    def ok(self) -> bool:
        """True when there is no error."""
        return not self.errors

    def format(self) -> str:
        """The report as text: a count line, then errors, then warnings."""
        head = (
            f"dataset {self.dataset}: {len(self.errors)} error(s), {len(self.warnings)} warning(s)"
        )
        return "\n".join([head, *map(str, self.errors), *map(str, self.warnings)])

    def grouped(self, saved: str | None = None, folder: str = "", examples: int = 3) -> str:
        """The report for a screen: a count line, every error, then one line per kind of warning
        (its cause, the numbers in it left out: 48 recordings 'not at rest' are one kind) with
        how many there are, the range of each number and the places of the first ``examples``;
        a warning of its own kind keeps its line (:meth:`format` lists every finding). Where
        some were grouped, it says where each one is: in the file ``saved``, or how to write one
        (``folder``: the dataset's, for ``aceval validate``).
        """
        kinds: dict[str, list[Finding]] = {}
        for finding in self.warnings:
            kinds.setdefault(_NUMBER.sub("\0", finding.cause), []).append(finding)
        lines = [self.format().split("\n")[0], *map(str, self.errors)]
        for cause, found in kinds.items():
            if len(found) == 1:
                lines.append(str(found[0]))
                continue
            columns = zip(*([float(n) for n in _NUMBER.findall(f.cause)] for f in found))
            spans = iter(
                [f"{min(c):g}-{max(c):g}" if min(c) < max(c) else f"{c[0]:g}" for c in columns]
            )
            text = re.sub("\0", lambda _, spans=spans: next(spans), cause)
            places = "; ".join(f.where for f in found[:examples])
            more = f"; and {len(found) - examples} more" if len(found) > examples else ""
            lines.append(f"WARNING {len(found)} x: {text} (at {places}{more})")
        if folder and len(lines) < len(self.findings) + 1:
            lines.append(
                f"(every warning: {saved or f'aceval validate {folder} --findings-out FILE'})"
            )
        return "\n".join(lines)


#: a number in a finding's cause (what varies between findings of one kind)
_NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?![\w.])")


@dataclass(frozen=True)
class SignalFaults:
    """What the checks of a recording's signals found as it was read
    (:func:`aceval.data.recording_checks.read_checked`), kept for the pass that summarises it (the
    checks run once): ``stuck`` (name, share, value) of a stuck channel or None, and ``spikes``,
    the (N,) mask of single-sample acceleration spikes.
    """

    stuck: tuple[str, float, float] | None
    spikes: np.ndarray


@dataclass
class Recording:
    """One recording in SI units: t (s), acc (N, 3) m/s^2, gyr (N, 3) rad/s; ``faults``: what
    the signal checks found when it was read (None when they have not run).
    """

    t: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    path: Path
    faults: SignalFaults | None = None


class RecordingError(ValueError):
    """A recording file cannot be read as the contract says. ``cause`` is the reason without the
    file name; the message names the file.
    """

    def __init__(self, path, cause: str):
        super().__init__(f"{path}: {cause}")
        self.path, self.cause = path, cause


def file_problem(path: str | Path) -> str:
    """Why ``path`` cannot be read as a file ('' when it can): missing, a folder, not a regular
    file (a FIFO or device: reading one may block for ever), or a name the system refuses.
    """
    import stat

    from aceval.data.errors import describe_os_error

    try:
        mode = Path(path).stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "file is missing"
    except OSError as exc:
        exc.filename = None
        return f"cannot be read: {describe_os_error(exc)}"
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if not stat.S_ISREG(mode):
        return "is not a regular file (a FIFO, socket or device): aceval reads only files"
    return ""


#: the file types a recording may have (the contract: CSV, gzipped CSV or Parquet)
RECORDING_SUFFIXES = (".csv", ".csv.gz", ".parquet")


def recording_values(path: Path) -> np.ndarray:
    """The (N, 7) values of a recording file (``RECORDING_COLUMNS``, in the file's units; a cell
    that is not a number becomes NaN): CSV (gzipped when the name ends in .gz) or Parquet.
    RecordingError when it is missing, unreadable or lacks a column.
    """
    if Path(path).suffix == ".parquet":
        return _parquet_values(Path(path))
    try:
        table = pd.read_csv(path, sep=",", engine="c")
    except FileNotFoundError:
        raise RecordingError(path, "file is missing") from None
    except Exception as exc:  # pandas raises many types for a damaged or binary file
        raise RecordingError(
            path, f"cannot be read as CSV: {str(exc).splitlines()[0] if str(exc) else exc!r}"
        ) from None
    table.columns = [str(c).strip() for c in table.columns]
    if twice := duplicated_columns(table.columns):
        raise RecordingError(path, twice)
    missing = [c for c in RECORDING_COLUMNS if c not in table.columns]
    if missing:
        header = ",".join(map(str, table.columns))[:60]
        hint = " (is the file comma-separated?)" if len(table.columns) == 1 else ""
        raise RecordingError(
            path, f"missing column(s) {', '.join(missing)}; the header is {header!r}{hint}"
        )
    return _numeric_values(table)


def recording_columns(path: Path) -> list[str]:
    """The column names of a recording file, from its first line (CSV, gzipped or not) or its
    schema (Parquet): the cheap check of the validation. OSError or ValueError when unreadable.
    """
    path = Path(path)
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq  # here: its import costs every command that never reads one

        try:
            names = list(pq.read_schema(path).names)
        except Exception as exc:  # pyarrow raises its own types for a damaged file
            raise ValueError(f"cannot be read as Parquet: {exc}") from None
    else:  # what recording_values accepts (a BOM, a compression the name says), this does
        names = _csv_header(path)
    if twice := duplicated_columns(names):
        raise ValueError(twice)
    return names


def _csv_header(path: Path) -> list[str]:
    """The first line of a CSV recording as column names, read as :func:`recording_values`'
    reader reads it: a UTF-8 byte-order mark dropped, the file decompressed by its name's
    suffix (gzip, bz2, xz: the first line only, as fast as a plain file; any other compression
    pandas knows through pandas).
    """
    import bz2
    import csv
    import gzip
    import lzma

    openers = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}
    if path.suffix in (".zip", ".zst", ".tar"):
        try:
            return [str(c).strip() for c in pd.read_csv(path, sep=",", nrows=0).columns]
        except Exception as exc:  # pandas raises many types for a damaged or binary file
            raise ValueError(f"cannot be read as CSV: {str(exc).splitlines()[0]}") from None
    opener = openers.get(path.suffix, open)
    try:
        with opener(path, "rt", encoding="utf-8-sig", errors="replace", newline="") as handle:
            header = next(csv.reader(handle), [])
    except FileNotFoundError:
        raise
    except (OSError, EOFError, lzma.LZMAError, csv.Error) as exc:  # a damaged compressed file
        raise ValueError(f"cannot be read as CSV: {exc}") from None
    return [c.strip() for c in header]


def duplicated_columns(names) -> str:
    """'' when no column of the contract is named twice, else the cause (a CSV reader renames a
    second ``acc_x`` to ``acc_x.1``; a Parquet table keeps both): which one would be read is
    anyone's guess.
    """
    names = [str(n) for n in names]
    twice = sorted({c for c in RECORDING_COLUMNS if names.count(c) > 1 or f"{c}.1" in names})
    return (
        f"column(s) {', '.join(twice)} appear more than once in the header: which one holds the "
        "signal? Keep one of each"
        if twice
        else ""
    )


def _parquet_values(path: Path) -> np.ndarray:
    """:func:`recording_values` of a Parquet file: each column as float, as a CSV's (a null or a
    cell that is not a number becomes NaN, and is reported).
    """
    import pyarrow.parquet as pq
    import pyarrow.types as pa_types

    try:
        table = pq.ParquetFile(path, pre_buffer=False)  # small files: 3x faster than buffered
        names = table.schema_arrow.names
    except FileNotFoundError:
        raise RecordingError(path, "file is missing") from None
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise RecordingError(
            path, f"cannot be read as Parquet: {str(exc).splitlines()[0]}"
        ) from None
    if twice := duplicated_columns(names):
        raise RecordingError(path, twice)
    missing = [c for c in RECORDING_COLUMNS if c not in names]
    if missing:
        raise RecordingError(
            path,
            f"missing column(s) {', '.join(missing)}; the columns are {', '.join(names)[:60]!r}",
        )
    columns = table.read(columns=RECORDING_COLUMNS, use_threads=False)
    if all(pa_types.is_floating(t) or pa_types.is_integer(t) for t in columns.schema.types):
        return np.column_stack([c.to_numpy().astype(float, copy=False) for c in columns.columns])
    return _numeric_values(columns.to_pandas())  # text cells: as a CSV's


def _numeric_values(table: pd.DataFrame) -> np.ndarray:
    """The recording columns as floats; non-numeric cells become NaN (and are reported)."""
    columns = table if list(table.columns) == RECORDING_COLUMNS else table[RECORDING_COLUMNS]
    try:
        return columns.to_numpy(dtype=float)
    except (TypeError, ValueError):  # some cell is not a number
        return columns.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
