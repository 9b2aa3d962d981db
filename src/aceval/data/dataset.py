"""The on-disk dataset contract (docs/design.md, section 1): read into tidy tables, validate with a report.

A dataset is a folder with ``dataset.yaml`` and tab-separated sheets (imus, tests, calibrates,
subjects, recordings, optional ground_truth) plus one CSV per recording. Inside aceval everything
is SI: acceleration m/s^2, angular velocity rad/s. Raw files are only ever read. See
config/README.md for the user-facing description.
"""

from __future__ import annotations

import csv
import gzip
import io
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from aceval.data.rotations import AXIS_VECTORS
from aceval.data.safety import path_problem

GRAVITY = 9.81  # m/s^2: 1 g, used for unit conversion and by the simulator's physics
ACC_UNITS = {"g": GRAVITY, "m/s^2": 1.0}
GYR_UNITS = {"deg/s": np.pi / 180.0, "rad/s": 1.0}
RECORDING_COLUMNS = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
#: optional columns of a recording: the vendor's orientation estimate (scalar first, sensor -> the
#: vendor's z-up world); read only by the OpenSense peer (workflow/peers/)
QUAT_COLUMNS = ["quat_w", "quat_x", "quat_y", "quat_z"]
R_COLUMNS = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
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


@dataclass
class Recording:
    """One recording in SI units: t (s), acc (N, 3) m/s^2, gyr (N, 3) rad/s."""

    t: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    path: Path


@dataclass
class Dataset:
    """A validated dataset: dataset.yaml, the sheets as tables, and the recordings' reader."""

    root: Path
    meta: dict
    imus: pd.DataFrame  # one row per (sensor_set, imu)
    tests: pd.DataFrame
    calibrates: pd.DataFrame
    subjects: pd.DataFrame
    recordings: pd.DataFrame
    ground_truth: pd.DataFrame | None
    functional_axes: pd.DataFrame | None = (
        None  # optional sheet: Ricci-style functional calibration
    )

    @property
    def name(self) -> str:
        """The dataset's name (dataset.yaml ``name``, else the folder's)."""
        return str(self.meta.get("name", self.root.name))

    @property
    def fs_hz(self) -> float:
        """Samples per second (dataset.yaml ``sampling_rate_hz``)."""
        return float(self.meta["sampling_rate_hz"])

    @property
    def acc_scale(self) -> float:
        """Factor from the files' acceleration unit to m/s^2."""
        return ACC_UNITS[self.meta["units"]["acc"]]

    @property
    def gyr_scale(self) -> float:
        """Factor from the files' angular-velocity unit to rad/s."""
        return GYR_UNITS[self.meta["units"]["gyr"]]

    def right_axis(self, sensor_set: str, imu: str) -> str:
        """The declared right axis ('+y', ...) of an IMU."""
        return str(self.imus.loc[(sensor_set, imu), "right_axis"])

    def reference_axes(self, sensor_set: str, imu: str) -> pd.DataFrame:
        """Rows of functional_axes.tsv for this IMU's segment: ``test`` and the signed segment-frame
        ``axis``. A row for ``<segment>_<r|l>`` (side-specific) replaces one for ``<segment>``.
        """
        if self.functional_axes is None:
            return pd.DataFrame(columns=["test", "axis"])
        segment, side = self.imus.loc[(sensor_set, imu), ["segment", "side"]]
        sheet = self.functional_axes
        specific = sheet[sheet["segment"] == f"{segment}_{str(side)[:1]}"]
        general = sheet[(sheet["segment"] == segment) & ~sheet["test"].isin(specific["test"])]
        return pd.concat([specific, general])[["test", "axis"]].reset_index(drop=True)

    def first_phase(self, test: str) -> str:
        """tests.tsv ``first_phase`` of ``test`` ('-y', '+y', 'gait' or '': no direction check)."""
        return str(self.tests["first_phase"].get(test, "")) if "first_phase" in self.tests else ""

    @cached_property
    def test_kinds(self) -> dict[str, str]:
        """tests.tsv ``kind`` of each test ('static' or 'motion')."""
        return self.tests["kind"].to_dict()

    @cached_property
    def imu_regions(self) -> dict[tuple[str, str], str]:
        """``{test: 'static' | 'motion'}``."""
        return self.imus["region"].to_dict()

    def acc_limit(self, sensor_set: str, imu: str) -> float | None:
        """|acc| (m/s^2, any axis) at or above which a sample counts as clipped at the range
        declared in dataset.yaml ``acc_range_g`` for the IMU's region; None when none is declared.
        """
        acc_range = (self.meta.get("acc_range_g") or {}).get(self.imu_regions[(sensor_set, imu)])
        return SATURATION_FRACTION * float(acc_range) * GRAVITY if acc_range else None

    def static_tests(self) -> list[str]:
        """``{(sensor_set, imu): region}``."""
        return list(self.tests.index[self.tests["kind"] == "static"])

    def read_recording(self, path: str | Path) -> Recording:
        """Read one recording file (relative to the dataset) and convert it to SI. RecordingError
        (naming the file and the cause) when it cannot be read, has fewer than 2 samples or holds
        NaN, inf or non-numeric values.
        """
        full = self.root / path
        values = recording_values(full)
        if len(values) < 2:
            raise RecordingError(full, f"{len(values)} samples: a recording needs at least 2")
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():
            raise RecordingError(
                full,
                f"{int(bad.sum())} rows with NaN, inf or non-numeric values "
                f"(first at line {int(np.flatnonzero(bad)[0]) + 2})",
            )
        return Recording(
            values[:, 0], values[:, 1:4] * self.acc_scale, values[:, 4:7] * self.gyr_scale, full
        )

    def ground_truth_matrix(self, subject: str, sensor_set: str, imu: str) -> np.ndarray | None:
        """The true R (3x3, sensor -> body) of an IMU from ground_truth.tsv; None without one."""
        if self.ground_truth is None:
            return None
        try:
            row = self.ground_truth.loc[(subject, sensor_set, imu)]
        except KeyError:
            return None
        return row[R_COLUMNS].to_numpy(dtype=float).reshape(3, 3)


class RecordingError(ValueError):
    """A recording file cannot be read as the contract says. ``cause`` is the reason without the
    file name; the message names the file.
    """

    def __init__(self, path, cause: str):
        super().__init__(f"{path}: {cause}")
        self.path, self.cause = path, cause


def recording_values(path: Path) -> np.ndarray:
    """The (N, 7) values of a recording file (``RECORDING_COLUMNS``, in the file's units; a cell
    that is not a number becomes NaN). RecordingError when it is missing, unreadable or lacks a
    column.
    """
    try:
        table = pd.read_csv(path, sep=",", engine="c")
    except FileNotFoundError:
        raise RecordingError(path, "file is missing") from None
    except Exception as exc:  # pandas raises many types for a damaged or binary file
        raise RecordingError(
            path, f"cannot be read as CSV: {str(exc).splitlines()[0] if str(exc) else exc!r}"
        ) from None
    missing = [c for c in RECORDING_COLUMNS if c not in table.columns]
    if missing:
        header = ",".join(map(str, table.columns))[:60]
        hint = " (is the file comma-separated?)" if len(table.columns) == 1 else ""
        raise RecordingError(
            path, f"missing column(s) {', '.join(missing)}; the header is {header!r}{hint}"
        )
    return _numeric_values(table)


def _numeric_values(table: pd.DataFrame) -> np.ndarray:
    """The recording columns as floats; non-numeric cells become NaN (and are reported)."""
    columns = table if list(table.columns) == RECORDING_COLUMNS else table[RECORDING_COLUMNS]
    try:
        return columns.to_numpy(dtype=float)
    except (TypeError, ValueError):  # some cell is not a number
        return columns.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)


def _read_sheet(root: Path, name: str, required: list[str], report: ValidationReport):
    path = root / name
    if not path.exists():
        report.error(name, "sheet is missing")
        return None
    try:
        sheet = pd.read_csv(path, sep="\t", dtype=str, keep_default_na=False)
    except Exception as exc:  # unreadable / malformed
        report.error(name, f"cannot be read as a tab-separated sheet: {exc}")
        return None
    sheet.columns = [c.strip() for c in sheet.columns]
    missing = [c for c in required if c not in sheet.columns]
    if missing:
        report.error(
            name, f"missing column(s) {', '.join(missing)} (has {', '.join(sheet.columns)})"
        )
        return None
    return sheet.apply(lambda col: col.str.strip())


def _line(index: int) -> str:
    return f"line {index + 2}"  # header is line 1


#: the sheets' name columns: every results table is keyed by them
NAME_COLUMNS = {
    "subjects.tsv": ["subject"],
    "tests.tsv": ["test"],
    "imus.tsv": ["imu", "segment", "side", "sensor_set"],
}


def read_as_missing(names) -> set[str]:
    """The ``names`` that a CSV reader with its default settings (:func:`pandas.read_csv`, as
    every reader of aceval's results tables) takes for a missing value: '', 'NA', 'N/A', 'null',
    'nan', 'None' and the like. As a subject, test, IMU, segment or side such a name would come
    back as NaN and its rows would silently drop out of every grouping.
    """
    unique = sorted(set(names))
    text = io.StringIO()
    writer = csv.writer(text)
    writer.writerow(["position", "name"])  # a second column: an empty name is a line, not skipped
    writer.writerows(enumerate(unique))
    read = pd.read_csv(io.StringIO(text.getvalue()), dtype={"name": str})["name"]
    return {unique[k] for k in np.flatnonzero(read.isna().to_numpy())}


def _check_names(sheets: dict[str, pd.DataFrame], sensor_sets: list[str], report) -> None:
    """An error for each name of :data:`NAME_COLUMNS` (and of dataset.yaml sensor_sets) that is
    empty or :func:`read_as_missing` (an empty sensor_set of imus.tsv means every set: allowed).
    """
    for sheet, columns in NAME_COLUMNS.items():
        table = sheets[sheet]
        for column in [c for c in columns if c in table.columns]:
            values = table[column]
            missing = read_as_missing(values) - ({""} if column == "sensor_set" else set())
            for index in table.index[values.isin(missing)]:
                if values[index] == "":
                    report.error(f"{sheet} {_line(index)}", f"{column} is empty")
                    continue
                report.error(
                    f"{sheet} {_line(index)}",
                    f"{column} {values[index]!r} reads as a missing value in CSV readers "
                    "(pandas.read_csv takes '', NA, N/A, null, nan, None and the like for "
                    "missing): its rows would drop out of every results table; rename it",
                )
    for name in sorted(read_as_missing(str(s) for s in sensor_sets)):
        report.error(
            "dataset.yaml",
            f"sensor_sets: {name!r} reads as a missing value in CSV readers; rename it",
        )


#: keys of dataset.yaml that aceval reads (others are kept but get a warning: a typo disables a check)
META_KEYS = (
    "name",
    "description",
    "simulated",
    "sampling_rate_hz",
    "units",
    "sensor_sets",
    "acc_range_g",
    "gyr_range_dps",
)


def _meta_schema() -> dict:
    return yaml.safe_load((Path(__file__).parent / "schemas" / "dataset.schema.yaml").read_text())


def _check_meta(root: Path, report: ValidationReport) -> dict | None:
    """dataset.yaml against ``schemas/dataset.schema.yaml``: each violation is an error naming
    the key and the cause.
    """
    import jsonschema

    path = root / "dataset.yaml"
    if not path.exists():
        report.error("dataset.yaml", "missing")
        return None
    try:
        meta = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        report.error("dataset.yaml", f"not valid YAML: {exc}")
        return None
    if not isinstance(meta, dict):
        report.error(
            "dataset.yaml",
            f"must be a mapping of keys to values (name: ..., sampling_rate_hz: ...), "
            f"got {type(meta).__name__} {str(meta)[:60]!r}",
        )
        return None
    validator = jsonschema.Draft202012Validator(_meta_schema())
    errors = sorted(validator.iter_errors(meta), key=lambda e: list(map(str, e.absolute_path)))
    for error in errors:
        key = ".".join(map(str, error.absolute_path)) or "(top level)"
        report.error("dataset.yaml", f"{key}: {error.message}")
    for key in ("sampling_rate_hz", "gyr_range_dps"):
        value = meta.get(key)
        if isinstance(value, float) and not np.isfinite(value):
            report.error("dataset.yaml", f"{key}: {value} is not a finite number")
    for key in sorted(set(meta) - set(META_KEYS)):
        report.warning(
            "dataset.yaml", f"unknown key {key!r} is ignored (aceval reads {', '.join(META_KEYS)})"
        )
    return None if errors else meta


def _expand_imus(
    imus: pd.DataFrame, sensor_sets: list[str], report: ValidationReport
) -> pd.DataFrame:
    """One row per (sensor_set, imu). Rows with an empty or absent sensor_set apply to every set."""
    if "sensor_set" not in imus.columns:
        imus = imus.assign(sensor_set="")
    rows = []
    for index, row in imus.iterrows():
        if row["right_axis"].lower() not in RIGHT_AXIS_SPELLINGS:
            report.error(
                f"imus.tsv {_line(index)}",
                f"IMU {row['imu']}: right_axis {row['right_axis']!r} "
                f"is not one of {', '.join(AXIS_VECTORS)}",
            )
        if row["sensor_set"] and row["sensor_set"] not in sensor_sets:
            report.error(
                f"imus.tsv {_line(index)}",
                f"sensor_set {row['sensor_set']!r} is not in "
                f"dataset.yaml sensor_sets {sensor_sets}",
            )
        for sensor_set in [row["sensor_set"]] if row["sensor_set"] else sensor_sets:
            rows.append({**row.to_dict(), "sensor_set": sensor_set, "_line": _line(index)})
    expanded = pd.DataFrame(rows)
    duplicated = expanded.duplicated(["sensor_set", "imu"], keep="first")
    for _, row in expanded[duplicated].iterrows():
        report.error(
            f"imus.tsv {row['_line']}",
            f"IMU {row['imu']} is defined twice for set {row['sensor_set']}",
        )
    return expanded[~duplicated].drop(columns="_line").set_index(["sensor_set", "imu"])


def read_sheets(
    root: str | Path, report: ValidationReport | None = None
) -> tuple[Dataset | None, ValidationReport]:
    """Read and cross-check dataset.yaml and the sheets (not the recording files)."""
    root = Path(root)
    report = report or ValidationReport(str(root))
    if not root.is_dir():
        report.error(str(root), "dataset folder does not exist")
        return None, report
    meta = _check_meta(root, report)
    sheets = {name: _read_sheet(root, name, cols, report) for name, cols in SHEETS.items()}
    optional = {
        name: _read_sheet(root, name, cols, report) if (root / name).exists() else None
        for name, cols in OPTIONAL_SHEETS.items()
    }
    ground_truth, functional_axes = optional["ground_truth.tsv"], optional["functional_axes.tsv"]
    if meta is None or any(sheet is None for sheet in sheets.values()):
        return None, report
    report.dataset = str(meta.get("name", root.name))
    _check_names(sheets, meta["sensor_sets"], report)

    imus = _expand_imus(sheets["imus.tsv"], meta["sensor_sets"], report)
    regions = set(imus["region"])
    for region in sorted(set(meta.get("acc_range_g") or {}) - regions):
        report.error(
            "dataset.yaml",
            f"acc_range_g names region {region!r}, which no IMU of imus.tsv has "
            f"(regions: {', '.join(sorted(regions))}): the clipping check would be off",
        )
    tests = sheets["tests.tsv"]
    if "first_phase" not in tests.columns:  # Kong's tests by name; others unchecked
        tests = tests.assign(first_phase=tests["test"].map(KONG_FIRST_PHASE).fillna(""))
    for index, row in tests.iterrows():
        if row["kind"] not in ("static", "motion"):
            report.error(
                f"tests.tsv {_line(index)}",
                f"test {row['test']}: kind {row['kind']!r} must be static or motion",
            )
        if row["first_phase"] not in FIRST_PHASES:
            report.error(
                f"tests.tsv {_line(index)}",
                f"test {row['test']}: first_phase {row['first_phase']!r} must be "
                f"one of -y, +y, gait or empty",
            )
    subjects = sheets["subjects.tsv"]
    for sheet, table, column in (
        ("tests.tsv", tests, "test"),
        ("subjects.tsv", subjects, "subject"),
    ):
        for index in table.index[table.duplicated(column, keep="first")]:
            report.error(
                f"{sheet} {_line(index)}", f"{column} {table.loc[index, column]!r} is defined twice"
            )
    tests = tests.drop_duplicates("test").set_index("test")
    subjects = subjects.drop_duplicates("subject").set_index("subject", drop=False)
    imu_names = set(imus.index.get_level_values("imu"))

    calibrates = sheets["calibrates.tsv"]
    for index, row in calibrates.iterrows():
        where = f"calibrates.tsv {_line(index)}"
        if row["test"] not in tests.index:
            report.error(where, f"test {row['test']!r} is not defined in tests.tsv")
        elif tests.loc[row["test"], "kind"] != "motion":
            report.error(where, f"test {row['test']!r} is not a motion test")
        if row["imu"] not in imu_names:
            report.error(where, f"IMU {row['imu']!r} is not defined in imus.tsv")

    recordings = sheets["recordings.tsv"]
    _check_recording_rows(recordings, subjects.index, tests.index, imu_names, meta, report)
    recordings = recordings.assign(
        rep=pd.to_numeric(recordings["rep"], errors="coerce").astype("Int64")
    )
    key = [
        "subject",
        "sensor_set",
        "test",
        "rep",
        "imu",
    ]  # rep as a number: '01' and '1' are one repetition
    for index in recordings.index[recordings.duplicated(key, keep="first")]:
        row = recordings.loc[index]
        report.error(
            f"recordings.tsv {_line(index)}",
            "duplicate recording "
            + " ".join(map(str, row[key]))
            + " (repetitions are compared as numbers)",
        )
    recordings = recordings[~recordings.duplicated(key, keep="first")].copy()
    same_file = recordings["path"].map(os.path.normpath)
    for index in recordings.index[same_file.duplicated(keep="first")]:
        first = recordings.index[same_file == same_file[index]][0]
        report.warning(
            f"recordings.tsv {_line(index)}",
            f"path {recordings.loc[index, 'path']!r} is also the file "
            f"of {_line(first)}: one file serves two recordings",
        )

    _check_static_available(recordings, tests, calibrates, report)

    if ground_truth is not None:
        ground_truth = _check_ground_truth(ground_truth, report)
    if functional_axes is not None:
        _check_functional_axes(functional_axes, tests, imus, report)
    dataset = Dataset(
        root, meta, imus, tests, calibrates, subjects, recordings, ground_truth, functional_axes
    )
    return dataset, report


def _check_recording_rows(recordings, subjects, tests, imu_names, meta, report) -> None:
    """Each recordings.tsv row names known subject, test, IMU and set, a positive rep and a path
    that stays inside the dataset. Checked column by column; only rows with a problem are visited
    (a large sheet costs no Python loop).
    """
    known = {
        "subject": recordings["subject"].isin(subjects),
        "test": recordings["test"].isin(tests),
        "imu": recordings["imu"].isin(imu_names),
    }
    known_set = recordings["sensor_set"].isin(meta["sensor_sets"])
    good_rep = recordings["rep"].str.fullmatch(r"\d+") & (
        pd.to_numeric(recordings["rep"], errors="coerce") >= 1
    )
    problems = {path: path_problem(path) for path in recordings["path"].unique()}
    path_bad = recordings["path"].map(problems).astype(bool)
    bad = ~known_set | ~good_rep | path_bad
    for column in known.values():
        bad |= ~column
    sheets = {"subject": "subjects.tsv", "test": "tests.tsv", "imu": "imus.tsv"}
    for index in recordings.index[bad]:
        row = recordings.loc[index]
        where = f"recordings.tsv {_line(index)}"
        for column, sheet in sheets.items():
            if not known[column][index]:
                report.error(where, f"{column} {row[column]!r} is not defined in {sheet}")
        if not known_set[index]:
            report.error(
                where, f"sensor_set {row['sensor_set']!r} is not in dataset.yaml sensor_sets"
            )
        if not good_rep[index]:
            report.error(where, f"rep {row['rep']!r} must be a positive integer")
        if problems[row["path"]]:
            report.error(where, problems[row["path"]])


def _check_functional_axes(sheet, tests, imus, report) -> None:
    """functional_axes.tsv: known tests, known segments (``<segment>`` or ``<segment>_r|l``) and
    signed axes.
    """
    segments = set(imus["segment"])
    segments |= {f"{seg}_{str(side)[:1]}" for seg, side in zip(imus["segment"], imus["side"])}
    for index, row in sheet.iterrows():
        where = f"functional_axes.tsv {_line(index)}"
        if row["test"] not in tests.index:
            report.error(where, f"test {row['test']!r} is not defined in tests.tsv")
        if row["segment"] not in segments:
            report.error(
                where, f"segment {row['segment']!r} is not a segment (or segment_r/_l) of imus.tsv"
            )
        if row["axis"].lower() not in AXIS_VECTORS:
            report.error(
                where,
                f"axis {row['axis']!r} must be a signed axis, one of {', '.join(AXIS_VECTORS)}",
            )
    for index in sheet.index[sheet.duplicated(["test", "segment"], keep="first")]:
        report.error(f"functional_axes.tsv {_line(index)}", "test and segment given twice")


def _check_static_available(recordings, tests, calibrates, report) -> None:
    """Every (subject, set, IMU) recorded in a test that may calibrate it needs a static recording."""
    static = set(tests.index[tests["kind"] == "static"])
    allowed = set(map(tuple, calibrates[["test", "imu"]].to_numpy()))
    has_static = set(
        map(
            tuple,
            recordings[recordings["test"].isin(static)][
                ["subject", "sensor_set", "imu"]
            ].to_numpy(),
        )
    )
    needing = recordings[[(t, i) in allowed for t, i in zip(recordings["test"], recordings["imu"])]]
    missing = needing.drop_duplicates(["subject", "sensor_set", "imu", "test"])
    for _, row in missing.iterrows():
        if (row["subject"], row["sensor_set"], row["imu"]) not in has_static:
            report.error(
                "calibrates.tsv",
                f"subject {row['subject']}, set {row['sensor_set']}, IMU {row['imu']}: "
                f"test {row['test']} may calibrate it but there is no static test "
                f"({', '.join(sorted(static)) or 'none defined'}) recording to give z0",
            )


def _check_ground_truth(ground_truth, report):
    key = ["subject", "sensor_set", "imu"]
    for index in ground_truth.index[ground_truth.duplicated(key, keep=False)]:
        report.error(
            f"ground_truth.tsv {_line(index)}",
            "IMU "
            + " ".join(ground_truth.loc[index, key])
            + " has more than one row: which is the truth?",
        )
    ground_truth = ground_truth.drop_duplicates(key, keep=False)
    values = ground_truth[R_COLUMNS].apply(pd.to_numeric, errors="coerce")
    for index in values.index:
        R = values.loc[index].to_numpy(dtype=float).reshape(3, 3)
        where = f"ground_truth.tsv {_line(index)}"
        if not np.isfinite(R).all():
            report.error(where, "r11..r33 must be numbers")
        elif not (np.allclose(R @ R.T, np.eye(3), atol=1e-3) and np.linalg.det(R) > 0):
            report.error(
                where, "r11..r33 is not a rotation matrix (orthonormal, det +1, tolerance 1e-3)"
            )
    out = ground_truth.copy()
    out[R_COLUMNS] = values
    return out.set_index(["subject", "sensor_set", "imu"])


def recording_where(row) -> str:
    """How findings name a recording: its path and what it is (subject, set, test, rep, IMU)."""
    return f"{row['path']} ({row['subject']} {row['sensor_set']} {row['test']} R{row['rep']} {row['imu']})"


def read_checked(dataset: Dataset, row, report: ValidationReport) -> Recording | None:
    """Read one recording (a recordings.tsv row) and run every file-level check on it, adding
    findings to ``report``: the recording in SI units, or None when it has an error.
    """
    where = recording_where(row)
    path = dataset.root / row["path"]
    if not path.is_file():
        report.error(where, "file is missing")
        return None
    try:
        values = recording_values(path)
    except RecordingError as exc:
        report.error(where, exc.cause)
        return None
    errors = len(report.errors)
    check_values(dataset, row, values, report)
    if len(report.errors) > errors:
        return None
    return Recording(
        values[:, 0], values[:, 1:4] * dataset.acc_scale, values[:, 4:7] * dataset.gyr_scale, path
    )


def check_recording(dataset: Dataset, row, report: ValidationReport) -> None:
    """File-level checks of one recording, adding findings to ``report``."""
    read_checked(dataset, row, report)


def check_values(dataset: Dataset, row, values: np.ndarray, report: ValidationReport) -> None:
    """File-level checks of one recording's (N, 7) values (file units), adding findings to
    ``report``: sample count, NaN, time, sampling rate, units at rest, saturation and clipping.
    """
    where = recording_where(row)
    if len(values) < 2:
        report.error(where, f"{len(values)} samples: a recording needs at least 2")
        return
    bad = ~np.isfinite(values)
    if bad.any():
        line = int(np.flatnonzero(bad.any(axis=1))[0]) + 2
        report.error(
            where,
            f"{int(bad.any(axis=1).sum())} rows with NaN, inf or non-numeric values (first at line {line})",
        )
        return
    t = values[:, 0]
    dt = np.diff(t)
    if np.any(dt <= 0):
        line = int(np.flatnonzero(dt <= 0)[0]) + 3
        kind = "duplicate" if np.any(dt == 0) else "decreasing"
        report.error(where, f"t is not strictly increasing ({kind} time at line {line})")
        return
    fs_in_t = 1.0 / float(np.median(dt))
    if abs(fs_in_t - dataset.fs_hz) > FS_TOLERANCE * dataset.fs_hz:
        report.error(
            where,
            f"sampling rate in t is {fs_in_t:.4g} Hz, dataset.yaml declares {dataset.fs_hz:g} Hz",
        )
    duration = t[-1] - t[0]
    if duration < SHORT_RECORDING_S:
        report.warning(where, f"very short recording: {duration:.2f} s")
    acc = values[:, 1:4]
    if dataset.test_kinds[row["test"]] == "static":
        magnitude_g = float(np.median(np.linalg.norm(acc, axis=1))) * dataset.acc_scale / GRAVITY
        if not UNITS_GRAVITY_BAND[0] <= magnitude_g <= UNITS_GRAVITY_BAND[1]:
            report.error(
                where,
                f"acceleration at rest is {magnitude_g:.3g} g (expected about 1 g): "
                f"are units.acc ({dataset.meta['units']['acc']}) right?",
            )
        elif not REST_GRAVITY_BAND[0] <= magnitude_g <= REST_GRAVITY_BAND[1]:
            report.warning(
                where, f"static recording with median |acc| {magnitude_g:.3g} g: not at rest"
            )
    region = dataset.imu_regions[(row["sensor_set"], row["imu"])]
    acc_range = (dataset.meta.get("acc_range_g") or {}).get(region)
    if acc_range:
        limit = SATURATION_FRACTION * float(acc_range) * GRAVITY / dataset.acc_scale
        n_sat = int((np.abs(acc) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(
                where, f"{n_sat} samples at the accelerometer range +-{acc_range} g (saturated)"
            )
    if dataset.test_kinds[row["test"]] == "motion" and (plateau := plateau_limit(acc)) is not None:
        level_g = plateau * dataset.acc_scale / GRAVITY
        if not acc_range or level_g < SATURATION_FRACTION * float(acc_range):
            n_flat = int((np.abs(acc) >= plateau).any(axis=1).sum())
            report.warning(
                where,
                f"{n_flat} samples sit at +-{level_g:.3g} g, {PLATEAU_RUN} or more in a row: "
                f"clipped below the declared range ({acc_range or 'none'} g)? aceval leaves them out",
            )
    gyr_range = dataset.meta.get("gyr_range_dps")
    if gyr_range:
        limit = SATURATION_FRACTION * np.radians(float(gyr_range)) / dataset.gyr_scale
        n_sat = int((np.abs(values[:, 4:7]) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(
                where, f"{n_sat} samples at the gyroscope range +-{gyr_range} deg/s (saturated)"
            )


def plateau_limit(signal: np.ndarray, run: int = PLATEAU_RUN) -> float | None:
    """The |value| (in the signal's units) at which an (N, 3) signal is clipped, found from the data
    alone: the largest |value| of an axis held for ``run`` or more consecutive samples (a smooth
    signal passes its peak in one sample; a clipped one sits on the rail). The lowest such level over
    the axes, or None when no axis has a plateau at its extreme.
    """
    magnitude = np.abs(np.asarray(signal, dtype=float))
    if len(magnitude) < run:
        return None
    peak = magnitude.max(axis=0)
    at_peak = magnitude >= peak * (1 - 1e-9)
    # a window of ``run`` samples all at the peak <=> a plateau
    windows = np.lib.stride_tricks.sliding_window_view(at_peak, run, axis=0).all(axis=-1)
    clipped = windows.any(axis=0) & (peak > 0)
    return float(peak[clipped].min()) if clipped.any() else None


def known_recordings(dataset: Dataset) -> pd.DataFrame:
    """Recordings whose subject, set, test and IMU the sheets define (the rest are reported)."""
    recordings = dataset.recordings
    known = (
        recordings["subject"].isin(dataset.subjects.index)
        & recordings["test"].isin(dataset.tests.index)
        & pd.MultiIndex.from_arrays([recordings["sensor_set"], recordings["imu"]]).isin(
            dataset.imus.index
        )
    )
    return recordings[known]


def check_header(dataset: Dataset, row, report: ValidationReport) -> None:
    """The cheap file checks of one recording: it exists and its first line names every column
    of the contract (a file separated by anything but commas fails here). Its values are checked
    by :func:`read_checked` in the pass that reads them.
    """
    where = recording_where(row)
    path = dataset.root / row["path"]
    if not path.is_file():
        report.error(where, "file is missing")
        return
    try:
        opener = gzip.open if path.suffix == ".gz" else open
        with opener(path, "rt", errors="replace") as handle:
            header = handle.readline().strip()
    except (OSError, EOFError) as exc:
        report.error(where, f"cannot be read: {exc}")
        return
    columns = [c.strip().strip('"') for c in header.split(",")]
    missing = [c for c in RECORDING_COLUMNS if c not in columns]
    if missing:
        hint = " (is the file comma-separated?)" if len(columns) == 1 else ""
        report.error(
            where,
            f"missing column(s) {', '.join(missing)}; the header is {header[:60]!r}{hint}",
        )


def validate(
    root: str | Path, check_files: bool | str = True
) -> tuple[Dataset | None, ValidationReport]:
    """Validation: the sheets, then the recording files. ``check_files``: True or ``'all'`` (every
    check of every file: it is read), ``'headers'`` (only that each file exists and has the
    contract's columns: :func:`check_header`) or False. Returns the dataset (None if the sheets are
    unusable) and the report; ``report.ok`` is False when there are errors.
    """
    dataset, report = read_sheets(root)
    if dataset is not None and check_files:
        check = check_header if check_files == "headers" else check_recording
        for row in known_recordings(dataset).to_dict("records"):
            check(dataset, row, report)
    return dataset, report


def load_dataset(root: str | Path, check_files: bool = False) -> Dataset:
    """Read a dataset, raising DatasetError with the validation report when it has errors."""
    dataset, report = validate(root, check_files=check_files)
    if not report.ok:
        raise DatasetError(report.format())
    return dataset
