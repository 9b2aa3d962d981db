"""The on-disk dataset contract (docs/design.md, section 1): read into tidy tables, validate with a report.

A dataset is a folder with ``dataset.yaml`` and tab-separated sheets (imus, tests, calibrates,
subjects, recordings, optional ground_truth) plus one CSV per recording. Inside aceval everything
is SI: acceleration m/s^2, angular velocity rad/s. Raw files are only ever read. See
config/README.md for the user-facing description.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from aceval.data.contract import (
    FIRST_PHASES,
    GRAVITY,
    GYR_UNITS,
    KONG_FIRST_PHASE,
    OPTIONAL_SHEETS,
    R_COLUMNS,
    RIGHT_AXIS_SPELLINGS,
    SATURATION_FRACTION,
    SHEETS,
    DatasetError,
    Recording,
    RecordingError,
    ValidationReport,
    acc_factor,
    file_problem,
    recording_values,
)
from aceval.data.names import (
    check_names,
    check_places,
    check_subject_labels,
    subject_key,
    unique_subjects,
)
from aceval.data.names import sheet_line as _line
from aceval.data.protocol_checks import check_calibrates_not_empty, check_repetitions
from aceval.data.recording_checks import (
    as_recording,
    check_header,
    check_recording,
    known_recordings,
    position,
)
from aceval.data.rotations import AXIS_VECTORS
from aceval.data.safety import path_problem
from aceval.data.verticals import check_verticals


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
    verticals: pd.DataFrame | None = None  # optional sheet: a vertical per motion repetition

    @property
    def name(self) -> str:
        """The dataset's name (dataset.yaml ``name``, else the folder's)."""
        return str(self.meta.get("name", self.root.name))

    def subject_label(self, label) -> str:
        """The subjects.tsv spelling of a subject label (compared by :func:`subject_key`: '1',
        '01' and '001' are one subject); the label itself when the dataset has no such subject.
        """
        return self.subject_spellings.get(subject_key(str(label)), str(label))

    @cached_property
    def subject_spellings(self) -> dict[str, str]:
        """``{subject_key(label): label}`` of subjects.tsv."""
        return {subject_key(s): s for s in self.subjects.index}

    @property
    def fs_hz(self) -> float:
        """Samples per second (dataset.yaml ``sampling_rate_hz``)."""
        return float(self.meta["sampling_rate_hz"])

    @property
    def acc_scale(self) -> float:
        """Factor from the files' acceleration to specific force in m/s^2: the unit, and -1 for
        a dataset whose accelerometer reads gravity (dataset.yaml ``acc_at_rest: down``).
        """
        return acc_factor(self.meta)

    @property
    def gyr_scale(self) -> float:
        """Factor from the files' angular-velocity unit to rad/s."""
        return GYR_UNITS[self.meta["units"]["gyr"]]

    def right_axis(self, sensor_set: str, imu: str) -> str:
        """The declared right axis ('+y', ...) of an IMU."""
        return self.right_axes[(sensor_set, imu)]

    @cached_property
    def right_axes(self) -> dict[tuple[str, str], str]:
        """``{(sensor_set, imu): right_axis}`` (imus.tsv, read once: the pass asks per recording)."""
        return {key: str(axis) for key, axis in self.imus["right_axis"].items()}

    @cached_property
    def places(self) -> dict[tuple[str, str], tuple[str, str]]:
        """``{(sensor_set, imu): (segment, side)}`` (imus.tsv, read once)."""
        return {
            key: (str(segment), side)
            for key, segment, side in zip(self.imus.index, self.imus["segment"], self.imus["side"])
        }

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
        return self.first_phases.get(test, "")

    @cached_property
    def first_phases(self) -> dict[str, str]:
        """``{test: first_phase}`` (tests.tsv, read once; '' without the column)."""
        if "first_phase" not in self.tests:
            return {}
        return {test: str(phase) for test, phase in self.tests["first_phase"].items()}

    @cached_property
    def test_kinds(self) -> dict[str, str]:
        """``{test: 'static' | 'motion'}`` (tests.tsv ``kind``)."""
        return self.tests["kind"].to_dict()

    @cached_property
    def calibrated(self) -> set[tuple[str, str]]:
        """``{(test, imu)}``: the motion tests that may calibrate each IMU (calibrates.tsv)."""
        return set(map(tuple, self.calibrates[["test", "imu"]].to_numpy()))

    @cached_property
    def imu_regions(self) -> dict[tuple[str, str], str]:
        """``{(sensor_set, imu): region}`` (imus.tsv)."""
        return self.imus["region"].to_dict()

    def acc_limit(self, sensor_set: str, imu: str) -> float | None:
        """|acc| (m/s^2, any axis) at or above which a sample counts as clipped at the range
        declared in dataset.yaml ``acc_range_g`` for the IMU's region; None when none is declared.
        """
        acc_range = (self.meta.get("acc_range_g") or {}).get(self.imu_regions[(sensor_set, imu)])
        return SATURATION_FRACTION * float(acc_range) * GRAVITY if acc_range else None

    def static_tests(self) -> list[str]:
        """The tests of kind ``static`` (tests.tsv)."""
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
                f"(first at {position(path, int(np.flatnonzero(bad)[0]))})",
            )
        return as_recording(values, self.acc_scale, self.gyr_scale, full)

    def ground_truth_matrix(self, subject: str, sensor_set: str, imu: str) -> np.ndarray | None:
        """The true R (3x3, sensor -> body) of an IMU from ground_truth.tsv; None without one."""
        if self.ground_truth is None:
            return None
        try:
            row = self.ground_truth.loc[(subject, sensor_set, imu)]
        except KeyError:
            return None
        return row[R_COLUMNS].to_numpy(dtype=float).reshape(3, 3)


def _read_sheet(root: Path, name: str, required: list[str], report: ValidationReport, text=None):
    path = root / name if text is None else io.StringIO(text)
    if text is None and (problem := file_problem(path)):
        report.error(name, "sheet is missing" if problem == "file is missing" else problem)
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


#: keys of dataset.yaml that aceval reads (others are kept but get a warning: a typo disables a check)
META_KEYS = (
    "name",
    "description",
    "simulated",
    "sampling_rate_hz",
    "units",
    "acc_at_rest",
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
    if problem := file_problem(path):
        report.error("dataset.yaml", "missing" if problem == "file is missing" else problem)
        return None
    try:
        meta = yaml.safe_load(path.read_text(encoding="utf-8-sig"))
    except (yaml.YAMLError, UnicodeDecodeError, OSError) as exc:
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
    root: str | Path, report: ValidationReport | None = None, texts: dict | None = None
) -> tuple[Dataset | None, ValidationReport]:
    """Read and cross-check dataset.yaml and the sheets (not the recording files); ``texts``:
    sheet name -> its text, read instead of the file (a process holding part of a dataset it is
    writing: its own subjects' recordings.tsv and ground_truth.tsv rows).
    """
    root, texts = Path(root), texts or {}
    report = report or ValidationReport(str(root))
    if not root.is_dir():
        report.error(str(root), "dataset folder does not exist")
        return None, report
    meta = _check_meta(root, report)
    sheets = {
        name: _read_sheet(root, name, cols, report, texts.get(name))
        for name, cols in SHEETS.items()
    }
    optional = {
        name: _read_sheet(root, name, cols, report, texts.get(name))
        if name in texts or (root / name).exists()
        else None
        for name, cols in OPTIONAL_SHEETS.items()
    }
    ground_truth, functional_axes = optional["ground_truth.tsv"], optional["functional_axes.tsv"]
    if meta is None or any(sheet is None for sheet in sheets.values()):
        return None, report
    report.dataset = str(meta.get("name", root.name))
    check_names(sheets, meta["sensor_sets"], report)
    check_places(sheets["imus.tsv"], functional_axes, report)
    check_subject_labels(sheets["subjects.tsv"], report)

    imus = _expand_imus(sheets["imus.tsv"], meta["sensor_sets"], report)
    _check_regions(imus, meta, report)
    tests = _checked_tests(sheets["tests.tsv"], report)
    subjects = sheets["subjects.tsv"]
    for index in tests.index[tests.duplicated("test", keep="first")]:
        report.error(
            f"tests.tsv {_line(index)}", f"test {tests.loc[index, 'test']!r} is defined twice"
        )
    tests = tests.drop_duplicates("test").set_index("test")
    subjects = unique_subjects(subjects, report)
    spelling = dict(zip(subjects["subject"].map(subject_key), subjects["subject"]))
    verticals = optional["verticals.tsv"]
    for sheet in (sheets["recordings.tsv"], ground_truth, verticals):
        if sheet is not None:  # '01' in recordings.tsv is subject '1' of subjects.tsv
            sheet["subject"] = [spelling.get(subject_key(s), s) for s in sheet["subject"]]
    imu_names = set(imus.index.get_level_values("imu"))
    calibrates = sheets["calibrates.tsv"]
    _check_calibrates(calibrates, tests, imu_names, report)
    check_calibrates_not_empty(calibrates, report)
    recordings = sheets["recordings.tsv"]
    _check_recording_rows(recordings, subjects.index, tests.index, imu_names, meta, report)
    recordings = _unique_recordings(recordings, report)
    check_repetitions(recordings, tests, report)
    _check_static_available(recordings, tests, calibrates, report)
    if ground_truth is not None:
        ground_truth = _check_ground_truth(ground_truth, report)
    if functional_axes is not None:
        _check_functional_axes(functional_axes, tests, imus, report)
    if verticals is not None:
        verticals = check_verticals(verticals, tests, recordings, report)
    dataset = Dataset(
        *(root, meta, imus, tests, calibrates, subjects, recordings, ground_truth, functional_axes),
        verticals=verticals,
    )
    return dataset, report


def _check_regions(imus: pd.DataFrame, meta: dict, report: ValidationReport) -> None:
    """Every region dataset.yaml gives a range for is one an IMU has."""
    regions = set(imus["region"])
    for region in sorted(set(meta.get("acc_range_g") or {}) - regions):
        report.error(
            "dataset.yaml",
            f"acc_range_g names region {region!r}, which no IMU of imus.tsv has "
            f"(regions: {', '.join(sorted(regions))}): the clipping check would be off",
        )


def _checked_tests(tests: pd.DataFrame, report: ValidationReport) -> pd.DataFrame:
    """tests.tsv with a first_phase (Kong's tests by name when the column is missing; others
    unchecked), each test's kind and first phase checked.
    """
    if "first_phase" not in tests.columns:
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
    return tests


def _check_calibrates(calibrates, tests, imu_names, report: ValidationReport) -> None:
    """Every calibrates.tsv row names a defined motion test and a defined IMU."""
    for index, row in calibrates.iterrows():
        where = f"calibrates.tsv {_line(index)}"
        if row["test"] not in tests.index:
            report.error(where, f"test {row['test']!r} is not defined in tests.tsv")
        elif tests.loc[row["test"], "kind"] != "motion":
            report.error(where, f"test {row['test']!r} is not a motion test")
        if row["imu"] not in imu_names:
            report.error(where, f"IMU {row['imu']!r} is not defined in imus.tsv")


def _unique_recordings(recordings: pd.DataFrame, report: ValidationReport) -> pd.DataFrame:
    """recordings.tsv with ``rep`` as a number ('01' and '1' are one repetition), a repeated
    recording an error (the first kept), and a file serving two recordings an error.
    """
    recordings = recordings.assign(
        rep=pd.to_numeric(recordings["rep"], errors="coerce").astype("Int64")
    )
    key = ["subject", "sensor_set", "test", "rep", "imu"]
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
        report.error(
            f"recordings.tsv {_line(index)}",
            f"path {recordings.loc[index, 'path']!r} is also the file "
            f"of {_line(first)}: one file serves two recordings (one sensor's samples would "
            "count for another sensor, or twice); give each recording its own file",
        )
    return recordings


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
