"""The on-disk dataset contract (DESIGN.md section 1): read into tidy tables, validate with a report.

A dataset is a folder with ``dataset.yaml`` and tab-separated sheets (imus, tests, calibrates,
subjects, recordings, optional ground_truth) plus one CSV per recording. Inside aceval everything
is SI: acceleration m/s^2, angular velocity rad/s. Raw files are only ever read. See
config/README.md for the user-facing description.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from .rotations import AXIS_VECTORS

GRAVITY = 9.81  # m/s^2: 1 g, used for unit conversion and by the simulator's physics
ACC_UNITS = {"g": GRAVITY, "m/s^2": 1.0}
GYR_UNITS = {"deg/s": np.pi / 180.0, "rad/s": 1.0}
RECORDING_COLUMNS = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
R_COLUMNS = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
SHEETS = {
    "imus.tsv": ["imu", "segment", "side", "region", "right_axis"],
    "tests.tsv": ["test", "kind", "repetitions"],
    "calibrates.tsv": ["test", "imu"],
    "subjects.tsv": ["subject"],
    "recordings.tsv": ["subject", "sensor_set", "test", "rep", "imu", "path"],
}
OPTIONAL_SHEETS = {"ground_truth.tsv": ["subject", "sensor_set", "imu", *R_COLUMNS],
                   "functional_axes.tsv": ["test", "segment", "axis"]}
#: median |acc| (g) of a static recording: outside the wide band the declared units are wrong (an
#: error: g and m/s^2 differ 9.81-fold); outside the narrow one the subject was not at rest (a
#: warning: e.g. a fallback static test taken from walking)
UNITS_GRAVITY_BAND = (0.5, 2.0)
REST_GRAVITY_BAND = (0.8, 1.2)
#: a sample within this fraction of the declared range counts as saturated
SATURATION_FRACTION = 0.999
#: recordings shorter than this (s) get a warning
SHORT_RECORDING_S = 1.0
#: sampling interval in t may differ from 1/sampling_rate_hz by this fraction
FS_TOLERANCE = 0.02


class DatasetError(ValueError):
    """The dataset does not satisfy the contract; the message is the validation report."""


@dataclass
class Finding:
    level: str  # "error" | "warning"
    where: str  # sheet or file, with line
    cause: str

    def __str__(self) -> str:
        return f"{self.level.upper():7s} {self.where}: {self.cause}"


@dataclass
class ValidationReport:
    dataset: str
    findings: list[Finding] = field(default_factory=list)

    def error(self, where, cause):
        self.findings.append(Finding("error", where, cause))

    def warning(self, where, cause):
        self.findings.append(Finding("warning", where, cause))

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "warning"]

    @property
    def ok(self) -> bool:
        return not self.errors

    def format(self) -> str:
        head = (f"dataset {self.dataset}: {len(self.errors)} error(s), "
                f"{len(self.warnings)} warning(s)")
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
    root: Path
    meta: dict
    imus: pd.DataFrame  # one row per (sensor_set, imu)
    tests: pd.DataFrame
    calibrates: pd.DataFrame
    subjects: pd.DataFrame
    recordings: pd.DataFrame
    ground_truth: pd.DataFrame | None
    functional_axes: pd.DataFrame | None = None  # optional sheet: Ricci-style functional calibration

    @property
    def name(self) -> str:
        return str(self.meta.get("name", self.root.name))

    @property
    def fs_hz(self) -> float:
        return float(self.meta["sampling_rate_hz"])

    @property
    def acc_scale(self) -> float:
        return ACC_UNITS[self.meta["units"]["acc"]]

    @property
    def gyr_scale(self) -> float:
        return GYR_UNITS[self.meta["units"]["gyr"]]

    def right_axis(self, sensor_set: str, imu: str) -> str:
        return str(self.imus.loc[(sensor_set, imu), "right_axis"])

    def reference_axes(self, sensor_set: str, imu: str) -> pd.DataFrame:
        """Rows of functional_axes.tsv for this IMU's segment: ``test`` and the signed segment-frame
        ``axis``. A row for ``<segment>_<r|l>`` (side-specific) replaces one for ``<segment>``."""
        if self.functional_axes is None:
            return pd.DataFrame(columns=["test", "axis"])
        segment, side = self.imus.loc[(sensor_set, imu), ["segment", "side"]]
        sheet = self.functional_axes
        specific = sheet[sheet["segment"] == f"{segment}_{str(side)[:1]}"]
        general = sheet[(sheet["segment"] == segment) & ~sheet["test"].isin(specific["test"])]
        return pd.concat([specific, general])[["test", "axis"]].reset_index(drop=True)

    @cached_property
    def test_kinds(self) -> dict[str, str]:
        return self.tests["kind"].to_dict()

    @cached_property
    def imu_regions(self) -> dict[tuple[str, str], str]:
        return self.imus["region"].to_dict()

    def acc_limit(self, sensor_set: str, imu: str) -> float | None:
        """|acc| (m/s^2, any axis) at or above which a sample counts as clipped at the range
        declared in dataset.yaml ``acc_range_g`` for the IMU's region; None when none is declared."""
        acc_range = (self.meta.get("acc_range_g") or {}).get(self.imu_regions[(sensor_set, imu)])
        return SATURATION_FRACTION * float(acc_range) * GRAVITY if acc_range else None

    def static_tests(self) -> list[str]:
        return list(self.tests.index[self.tests["kind"] == "static"])

    def read_recording(self, path: str | Path) -> Recording:
        """Read one recording file (relative to the dataset) and convert it to SI."""
        full = self.root / path
        table = _read_recording_table(full)
        values = _numeric_values(table)
        return Recording(values[:, 0], values[:, 1:4] * self.acc_scale, values[:, 4:7] * self.gyr_scale, full)

    def ground_truth_matrix(self, subject: str, sensor_set: str, imu: str) -> np.ndarray | None:
        if self.ground_truth is None:
            return None
        try:
            row = self.ground_truth.loc[(subject, sensor_set, imu)]
        except KeyError:
            return None
        return row[R_COLUMNS].to_numpy(dtype=float).reshape(3, 3)


def _read_recording_table(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, sep=",", engine="c")


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
        report.error(name, f"missing column(s) {', '.join(missing)} (has {', '.join(sheet.columns)})")
        return None
    return sheet.apply(lambda col: col.str.strip())


def _line(index: int) -> str:
    return f"line {index + 2}"  # header is line 1


def _check_meta(root: Path, report: ValidationReport) -> dict | None:
    path = root / "dataset.yaml"
    if not path.exists():
        report.error("dataset.yaml", "missing")
        return None
    try:
        meta = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        report.error("dataset.yaml", f"not valid YAML: {exc}")
        return None
    ok = True
    fs = meta.get("sampling_rate_hz")
    if not isinstance(fs, (int, float)) or fs <= 0:
        report.error("dataset.yaml", f"sampling_rate_hz must be a positive number, got {fs!r}")
        ok = False
    units = meta.get("units") or {}
    if units.get("acc") not in ACC_UNITS:
        report.error("dataset.yaml", f"units.acc must be one of {list(ACC_UNITS)}, got {units.get('acc')!r}")
        ok = False
    if units.get("gyr") not in GYR_UNITS:
        report.error("dataset.yaml", f"units.gyr must be one of {list(GYR_UNITS)}, got {units.get('gyr')!r}")
        ok = False
    sets = meta.get("sensor_sets")
    if not isinstance(sets, list) or not sets:
        report.error("dataset.yaml", f"sensor_sets must be a non-empty list, got {sets!r}")
        ok = False
    return meta if ok else None


def _expand_imus(imus: pd.DataFrame, sensor_sets: list[str], report: ValidationReport) -> pd.DataFrame:
    """One row per (sensor_set, imu). Rows with an empty or absent sensor_set apply to every set."""
    if "sensor_set" not in imus.columns:
        imus = imus.assign(sensor_set="")
    rows = []
    for index, row in imus.iterrows():
        if row["right_axis"].lower() not in AXIS_VECTORS and row["right_axis"].lower() not in "xyz":
            report.error(f"imus.tsv {_line(index)}", f"IMU {row['imu']}: right_axis {row['right_axis']!r} "
                         f"is not one of {', '.join(AXIS_VECTORS)}")
        if row["sensor_set"] and row["sensor_set"] not in sensor_sets:
            report.error(f"imus.tsv {_line(index)}", f"sensor_set {row['sensor_set']!r} is not in "
                         f"dataset.yaml sensor_sets {sensor_sets}")
        for sensor_set in ([row["sensor_set"]] if row["sensor_set"] else sensor_sets):
            rows.append({**row.to_dict(), "sensor_set": sensor_set, "_line": _line(index)})
    expanded = pd.DataFrame(rows)
    duplicated = expanded.duplicated(["sensor_set", "imu"], keep="first")
    for _, row in expanded[duplicated].iterrows():
        report.error(f"imus.tsv {row['_line']}", f"IMU {row['imu']} is defined twice for set {row['sensor_set']}")
    return expanded[~duplicated].drop(columns="_line").set_index(["sensor_set", "imu"])


def read_sheets(root: str | Path, report: ValidationReport | None = None) -> tuple[Dataset | None, ValidationReport]:
    """Read and cross-check dataset.yaml and the sheets (not the recording files)."""
    root = Path(root)
    report = report or ValidationReport(str(root))
    if not root.is_dir():
        report.error(str(root), "dataset folder does not exist")
        return None, report
    meta = _check_meta(root, report)
    sheets = {name: _read_sheet(root, name, cols, report) for name, cols in SHEETS.items()}
    optional = {name: _read_sheet(root, name, cols, report) if (root / name).exists() else None
                for name, cols in OPTIONAL_SHEETS.items()}
    ground_truth, functional_axes = optional["ground_truth.tsv"], optional["functional_axes.tsv"]
    if meta is None or any(sheet is None for sheet in sheets.values()):
        return None, report
    report.dataset = str(meta.get("name", root.name))

    imus = _expand_imus(sheets["imus.tsv"], meta["sensor_sets"], report)
    tests = sheets["tests.tsv"]
    for index, row in tests.iterrows():
        if row["kind"] not in ("static", "motion"):
            report.error(f"tests.tsv {_line(index)}", f"test {row['test']}: kind {row['kind']!r} must be static or motion")
    subjects = sheets["subjects.tsv"]
    for sheet, table, column in (("tests.tsv", tests, "test"), ("subjects.tsv", subjects, "subject")):
        for index in table.index[table.duplicated(column, keep="first")]:
            report.error(f"{sheet} {_line(index)}", f"{column} {table.loc[index, column]!r} is defined twice")
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
    for index, row in recordings.iterrows():
        where = f"recordings.tsv {_line(index)}"
        for column, known, sheet in (("subject", subjects.index, "subjects.tsv"), ("test", tests.index, "tests.tsv"),
                                     ("imu", imu_names, "imus.tsv")):
            if row[column] not in known:
                report.error(where, f"{column} {row[column]!r} is not defined in {sheet}")
        if row["sensor_set"] not in meta["sensor_sets"]:
            report.error(where, f"sensor_set {row['sensor_set']!r} is not in dataset.yaml sensor_sets")
        if not row["rep"].isdigit():
            report.error(where, f"rep {row['rep']!r} must be a positive integer")
    key = ["subject", "sensor_set", "test", "rep", "imu"]
    for index in recordings.index[recordings.duplicated(key, keep="first")]:
        row = recordings.loc[index]
        report.error(f"recordings.tsv {_line(index)}", "duplicate recording " + " ".join(row[key]))
    recordings = recordings[~recordings.duplicated(key, keep="first")].copy()
    recordings["rep"] = pd.to_numeric(recordings["rep"], errors="coerce").astype("Int64")

    _check_static_available(recordings, tests, calibrates, report)

    if ground_truth is not None:
        ground_truth = _check_ground_truth(ground_truth, report)
    if functional_axes is not None:
        _check_functional_axes(functional_axes, tests, imus, report)
    dataset = Dataset(root, meta, imus, tests, calibrates, subjects, recordings, ground_truth, functional_axes)
    return dataset, report


def _check_functional_axes(sheet, tests, imus, report) -> None:
    """functional_axes.tsv: known tests, known segments (``<segment>`` or ``<segment>_r|l``) and
    signed axes."""
    segments = set(imus["segment"])
    segments |= {f"{seg}_{str(side)[:1]}" for seg, side in zip(imus["segment"], imus["side"])}
    for index, row in sheet.iterrows():
        where = f"functional_axes.tsv {_line(index)}"
        if row["test"] not in tests.index:
            report.error(where, f"test {row['test']!r} is not defined in tests.tsv")
        if row["segment"] not in segments:
            report.error(where, f"segment {row['segment']!r} is not a segment (or segment_r/_l) of imus.tsv")
        if row["axis"].lower() not in AXIS_VECTORS:
            report.error(where, f"axis {row['axis']!r} must be a signed axis, one of {', '.join(AXIS_VECTORS)}")
    for index in sheet.index[sheet.duplicated(["test", "segment"], keep="first")]:
        report.error(f"functional_axes.tsv {_line(index)}", "test and segment given twice")


def _check_static_available(recordings, tests, calibrates, report) -> None:
    """Every (subject, set, IMU) recorded in a test that may calibrate it needs a static recording."""
    static = set(tests.index[tests["kind"] == "static"])
    allowed = set(map(tuple, calibrates[["test", "imu"]].to_numpy()))
    has_static = set(map(tuple, recordings[recordings["test"].isin(static)][["subject", "sensor_set", "imu"]].to_numpy()))
    needing = recordings[[(t, i) in allowed for t, i in zip(recordings["test"], recordings["imu"])]]
    missing = needing.drop_duplicates(["subject", "sensor_set", "imu", "test"])
    for _, row in missing.iterrows():
        if (row["subject"], row["sensor_set"], row["imu"]) not in has_static:
            report.error("calibrates.tsv", f"subject {row['subject']}, set {row['sensor_set']}, IMU {row['imu']}: "
                         f"test {row['test']} may calibrate it but there is no static test "
                         f"({', '.join(sorted(static)) or 'none defined'}) recording to give z0")


def _check_ground_truth(ground_truth, report):
    values = ground_truth[R_COLUMNS].apply(pd.to_numeric, errors="coerce")
    for index in values.index:
        R = values.loc[index].to_numpy(dtype=float).reshape(3, 3)
        where = f"ground_truth.tsv {_line(index)}"
        if not np.isfinite(R).all():
            report.error(where, "r11..r33 must be numbers")
        elif not (np.allclose(R @ R.T, np.eye(3), atol=1e-3) and np.linalg.det(R) > 0):
            report.error(where, "r11..r33 is not a rotation matrix (orthonormal, det +1, tolerance 1e-3)")
    out = ground_truth.copy()
    out[R_COLUMNS] = values
    return out.set_index(["subject", "sensor_set", "imu"])


def check_recording(dataset: Dataset, row, report: ValidationReport) -> None:
    """File-level checks of one recording, adding findings to ``report``."""
    where = f"{row['path']} ({row['subject']} {row['sensor_set']} {row['test']} R{row['rep']} {row['imu']})"
    path = dataset.root / row["path"]
    if not path.is_file():
        report.error(where, "file is missing")
        return
    try:
        table = _read_recording_table(path)
    except Exception as exc:
        report.error(where, f"cannot be read as CSV: {exc}")
        return
    missing = [c for c in RECORDING_COLUMNS if c not in table.columns]
    if missing:
        report.error(where, f"missing column(s) {', '.join(missing)}")
        return
    values = _numeric_values(table)
    if len(values) < 2:
        report.error(where, f"{len(values)} samples: a recording needs at least 2")
        return
    bad = ~np.isfinite(values)
    if bad.any():
        line = int(np.flatnonzero(bad.any(axis=1))[0]) + 2
        report.error(where, f"{int(bad.any(axis=1).sum())} rows with NaN, inf or non-numeric values (first at line {line})")
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
        report.error(where, f"sampling rate in t is {fs_in_t:.4g} Hz, dataset.yaml declares {dataset.fs_hz:g} Hz")
    duration = t[-1] - t[0]
    if duration < SHORT_RECORDING_S:
        report.warning(where, f"very short recording: {duration:.2f} s")
    acc = values[:, 1:4]
    if dataset.test_kinds[row["test"]] == "static":
        magnitude_g = float(np.median(np.linalg.norm(acc, axis=1))) * dataset.acc_scale / GRAVITY
        if not UNITS_GRAVITY_BAND[0] <= magnitude_g <= UNITS_GRAVITY_BAND[1]:
            report.error(where, f"acceleration at rest is {magnitude_g:.3g} g (expected about 1 g): "
                         f"are units.acc ({dataset.meta['units']['acc']}) right?")
        elif not REST_GRAVITY_BAND[0] <= magnitude_g <= REST_GRAVITY_BAND[1]:
            report.warning(where, f"static recording with median |acc| {magnitude_g:.3g} g: not at rest")
    region = dataset.imu_regions[(row["sensor_set"], row["imu"])]
    acc_range = (dataset.meta.get("acc_range_g") or {}).get(region)
    if acc_range:
        limit = SATURATION_FRACTION * float(acc_range) * GRAVITY / dataset.acc_scale
        n_sat = int((np.abs(acc) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(where, f"{n_sat} samples at the accelerometer range +-{acc_range} g (saturated)")
    gyr_range = dataset.meta.get("gyr_range_dps")
    if gyr_range:
        limit = SATURATION_FRACTION * np.radians(float(gyr_range)) / dataset.gyr_scale
        n_sat = int((np.abs(values[:, 4:7]) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(where, f"{n_sat} samples at the gyroscope range +-{gyr_range} deg/s (saturated)")


def known_recordings(dataset: Dataset) -> pd.DataFrame:
    """Recordings whose subject, set, test and IMU the sheets define (the rest are reported)."""
    recordings = dataset.recordings
    known = (recordings["subject"].isin(dataset.subjects.index)
             & recordings["test"].isin(dataset.tests.index)
             & pd.Series([key in dataset.imus.index for key in zip(recordings["sensor_set"], recordings["imu"])],
                         index=recordings.index))
    return recordings[known]


def validate(root: str | Path, check_files: bool = True) -> tuple[Dataset | None, ValidationReport]:
    """Full validation: sheets, then every recording file. Returns the dataset (None if the sheets
    are unusable) and the report; ``report.ok`` is False when there are errors."""
    dataset, report = read_sheets(root)
    if dataset is not None and check_files:
        for row in known_recordings(dataset).to_dict("records"):
            check_recording(dataset, row, report)
    return dataset, report


def load_dataset(root: str | Path, check_files: bool = False) -> Dataset:
    """Read a dataset, raising DatasetError with the validation report when it has errors."""
    dataset, report = validate(root, check_files=check_files)
    if not report.ok:
        raise DatasetError(report.format())
    return dataset
