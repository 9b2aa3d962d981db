"""``aceval apply``: body-frame copies of a dataset's recordings (d_body = R d_sensor).

The copies go into a new folder laid out like the dataset (same sheets, same relative paths,
same units), with ``applied_calibrations.tsv`` naming the calibration used for each IMU. The
input is only read. Each recording is checked as ``aceval calibrate`` checks it (an error names
the file and stops the command before anything is in place); the time column and every column
apply does not change are carried as the input's own text (a CSV) or values (Parquet, the format
of a simulated dataset: the copy is Parquet too); the vendor's orientation quaternions
and ground_truth.tsv are rotated into the new sensor frame (the body frame the calibration
estimates), so the copy validates and still has a truth. Calibrations are checked before use: a
matrix that is not a rotation, or a calibration made from other recordings than the dataset's
(:func:`recordings_fingerprint`), is refused.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.calibrate.table import unflagged
from aceval.data.contract import QUAT_COLUMNS, R_COLUMNS, ValidationReport
from aceval.data.dataset import Dataset
from aceval.data.recording_checks import position, read_checked
from aceval.data.safety import contained
from aceval.data.writer import write_sheet
from aceval.methods import registry

KEY = ["subject", "sensor_set", "imu"]
#: the calibrations column that names the recordings a calibration was made from
FINGERPRINT = "recordings_sha1"
#: largest |R R^T - I| and |det R - 1| of a matrix taken for a rotation (the calibrations CSV keeps
#: 17 digits; 1e-6 is a rotation error of about 6e-5 deg)
ROTATION_TOLERANCE = 1e-6
#: the sheets apply writes anew (the others are copied as they are)
REWRITTEN = {"imus.tsv", "recordings.tsv", "ground_truth.tsv"}
#: beside each IMU in applied_calibrations.tsv: which calibration apply used ('all repetitions',
#: 'subset' or 'none') and why
CHOICE_COLUMNS = ["calibration", "why"]


class ApplyError(ValueError):
    """The calibrations cannot be applied to this dataset; the message says which row and why."""


def fingerprints(dataset: Dataset, subject: str) -> tuple[str, str]:
    """SHA-1s of a subject's recordings, in the sheet's order: each recordings.tsv row's labels
    (subject, set, test, repetition, IMU), path and file bytes (:data:`FINGERPRINT`: what
    calibrate writes with each calibration and apply compares), and the same without the labels
    (what aceval wrote before it hashed them: such a file is told apart, not refused).
    """
    labelled, unlabelled = hashlib.sha1(), hashlib.sha1()
    rows = dataset.recordings[dataset.recordings["subject"] == subject]
    for row in rows[["subject", "sensor_set", "test", "rep", "imu", "path"]].itertuples(
        index=False
    ):
        labelled.update("\0".join(map(str, row)).encode() + b"\0")
        unlabelled.update(f"{row.path}\0".encode())
        try:
            content = (dataset.root / row.path).read_bytes()
        except OSError:
            content = b"\0missing"
        labelled.update(content)
        unlabelled.update(content)
    return labelled.hexdigest(), unlabelled.hexdigest()


def recordings_fingerprint(dataset: Dataset, subject: str) -> str:
    """The :data:`FINGERPRINT` of a subject's recordings (:func:`fingerprints`)."""
    return fingerprints(dataset, subject)[0]


def read_calibrations(path: str | Path) -> pd.DataFrame:
    """The CSV of `aceval calibrate` (or a peer's) at ``path``; ApplyError naming the file and
    the cause when it is missing, unreadable, binary or not such a file.
    """
    from aceval.data.errors import InputError
    from aceval.report.results import read_tables

    required = ["subject", "sensor_set", "imu", "test", "method", "n_reps", "flag"]
    try:
        calibrations = read_tables([path], required=required)
    except InputError as exc:
        raise ApplyError(f"{exc}: is it a file of `aceval calibrate`?") from None
    if calibrations.empty:
        raise ApplyError(f"{path} holds no calibrations")
    return calibrations


def _repetitions(label) -> frozenset:
    """``'R1+R3'`` -> {1, 3} (empty for a missing label)."""
    return (
        frozenset(part.strip() for part in str(label).split("+"))
        if label == label
        else (frozenset())
    )


def chosen_calibrations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    method: str | None = None,
    test: str | None = None,
    allow_subset: bool = False,
) -> pd.DataFrame:
    """What apply does for each (subject, set, IMU) of the dataset that a test of calibrates.tsv
    calibrates: one row with the calibration's columns and :data:`CHOICE_COLUMNS`. The
    ``method``'s (default Kong's, the registry's method of Kong et al. 2016) calibration from
    all the unit's repetitions (the union of those of its rows: a hand-deleted row is missed,
    not replaced), unflagged, from ``test`` or else the first test
    of calibrates.tsv that has one (``calibration`` 'all repetitions'); failing that, with
    ``allow_subset`` only, the largest unflagged subset of the first test that has one
    ('subset'); else 'none'. ``why`` says which and why (which tests were passed over, flagged
    what).
    """
    method = method or registry.paper_method("kong2016")
    rows = calibrations[calibrations["method"] == method]
    if test is not None:
        rows = rows[rows["test"] == test]
    rows = rows.assign(subject=rows["subject"].map(dataset.subject_label))
    tests = list(dict.fromkeys(dataset.calibrates["test"])) if test is None else [test]
    tests += sorted(set(rows["test"]) - set(tests))
    calibrated = dataset.calibrates["imu"].unique()
    wanted = dataset.recordings[dataset.recordings["imu"].isin(calibrated)][KEY].drop_duplicates()
    groups = dict(list(rows.groupby(KEY, sort=False)))
    out = []
    for key in wanted.itertuples(index=False, name=None):
        out.append(_choice(key, groups.get(key), tests, method, allow_subset))
    columns = list(dict.fromkeys([*KEY, "test", "repetitions", "n_reps", *calibrations.columns]))
    return pd.DataFrame(out, columns=[*columns, *CHOICE_COLUMNS])


def _choice(key, group, tests: list[str], method: str, allow_subset: bool) -> dict:
    """:func:`chosen_calibrations`' row of one IMU (``group``: its rows of the method, or None)."""
    passed = []
    if group is not None:
        sets = group["repetitions"].map(_repetitions)
        valid = unflagged(group)
        for test in tests:
            unit = (group["test"] == test).to_numpy()
            if not unit.any():
                continue
            everything = frozenset().union(*sets[unit])
            full = unit & (sets == everything).to_numpy()
            n = len(everything)
            if (full & valid.to_numpy()).any():
                row = group[full & valid.to_numpy()].iloc[0].to_dict()
                why = f"all {n} repetitions of {test}"
                return row | {"calibration": "all repetitions", "why": why + _passed(passed)}
            flag = group.loc[full, "flag"].astype(str)
            passed.append(
                f"{test}: its calibration from all {n} repetitions is "
                + (f"flagged {flag.iloc[0]}" if full.any() else "not in the calibrations file")
            )
        subsets = group[valid.to_numpy()].assign(
            _order=group["test"].map({t: k for k, t in enumerate(tests)})
        )
        if len(subsets):
            best = subsets.sort_values(["_order", "n_reps"], ascending=[True, False]).iloc[0]
            if allow_subset:
                row = best.drop("_order").to_dict()
                why = f"the subset {row['repetitions']} of {row['test']} (--allow-subset)"
                return row | {"calibration": "subset", "why": why + _passed(passed)}
            passed.append(
                f"an unflagged subset ({best['repetitions']} of {best['test']}) is there: "
                "--allow-subset applies the largest"
            )
    else:
        passed.append(f"no {method} calibration of it in the calibrations file")
    return dict(zip(KEY, key)) | {"calibration": "none", "why": "; ".join(passed)}


def _passed(passed: list[str]) -> str:
    return f" (passed over: {'; '.join(passed)})" if passed else ""


def check_rotations(chosen: pd.DataFrame, source: str) -> None:
    """ApplyError naming the first chosen row (subject, set, IMU, test) whose matrix is not a
    rotation: a cell that is not a number, not orthonormal, or a reflection.
    """
    for _, row in chosen.iterrows():
        what = f"{source}: {row['subject']} {row['sensor_set']} {row['imu']} {row['test']}"
        R = pd.to_numeric(row[R_COLUMNS], errors="coerce").to_numpy(float).reshape(3, 3)
        if not np.isfinite(R).all():
            raise ApplyError(f"{what}: r11..r33 are not all numbers")
        off = np.abs(R @ R.T - np.eye(3)).max()
        if off > ROTATION_TOLERANCE or abs(np.linalg.det(R) - 1) > ROTATION_TOLERANCE:
            raise ApplyError(
                f"{what}: the matrix is not a rotation (|R R^T - I| = {off:.3g}, "
                f"det {np.linalg.det(R):.6g}): was the file edited?"
            )


def check_source(dataset: Dataset, chosen: pd.DataFrame, source: str) -> list[str]:
    """ApplyError when a subject's calibrations were made from other recordings than this
    dataset's (another dataset, files changed since, or labels exchanged: :func:`fingerprints`);
    the warnings: a file of an older aceval (no fingerprint, or one without the labels) or of a
    peer tool (a method aceval does not have; no fingerprint) cannot be checked as fully.
    """
    if FINGERPRINT not in chosen.columns or chosen[FINGERPRINT].isna().all():
        foreign = sorted(set(chosen["method"]) - set(registry.own()))
        if foreign:
            whose = "a peer tool's" if set(foreign) <= set(registry.peers()) else "not aceval's"
            return [
                f"{source} holds {', '.join(foreign)} calibrations, {whose} (not made by "
                f"`aceval calibrate`): not checked that they were made from this dataset's "
                "recordings"
            ]
        return [
            f"{source} has no {FINGERPRINT} column (an older aceval): not checked that it was "
            f"made from this dataset's recordings"
        ]
    warnings = []
    for subject, stored in chosen.groupby("subject")[FINGERPRINT].first().items():
        labelled, unlabelled = fingerprints(dataset, subject)
        if str(stored) == labelled:
            continue
        if str(stored) == unlabelled:
            warnings.append(
                f"{source}: the calibrations of subject {subject} were made by an older aceval, "
                "which did not hash the recordings' labels: the same files, but that no "
                "subject, test, repetition or IMU label was changed since cannot be checked"
            )
            continue
        raise ApplyError(
            f"{source}: the calibrations of subject {subject} were made from other recordings "
            f"than those of {dataset.root} (another dataset, files changed since, or labels "
            "such as the IMUs of recordings.tsv exchanged): calibrate this dataset, or pass "
            "--other-dataset to apply them anyway"
        )
    return warnings


def body_frame_table(
    dataset: Dataset, path: str, R: np.ndarray, report: ValidationReport, row
) -> pd.DataFrame | None:
    """The CSV recording at ``path`` with acc and gyr in the body frame (file units, 17 digits)
    and the quaternions (sensor -> world) now new-sensor -> world; every other column as the
    input's text. None when the recording has an error (added to ``report``).
    """
    recording = read_checked(dataset, row, report)
    if recording is None:
        return None
    text = pd.read_csv(dataset.root / path, dtype=str, keep_default_na=False)
    text.columns = [c.strip() for c in text.columns]
    quat = (
        text[QUAT_COLUMNS].apply(pd.to_numeric, errors="coerce").to_numpy(float)
        if set(QUAT_COLUMNS) <= set(text)
        else None
    )
    for name, values in _rotated(dataset, recording, R, quat, path).items():
        text[name] = [repr(v) for v in values.tolist()]
    return text


def _rotated(dataset: Dataset, recording, R: np.ndarray, quat, path) -> dict[str, np.ndarray]:
    """The columns apply changes, by name: acc and gyr turned into the body frame (file units),
    and the vendor's quaternions ``quat`` (N, 4) when there are any, world <- body = (world <-
    sensor)(sensor <- body). ApplyError naming the file (``path``) and row when a quaternion is
    not an orientation (zero, empty or NaN).
    """
    out = {}
    for name, values, scale in (
        ("acc", recording.acc, dataset.acc_scale),
        ("gyr", recording.gyr, dataset.gyr_scale),
    ):
        rotated = values @ R.T / scale
        out |= {f"{name}_{axis}": rotated[:, k] for k, axis in enumerate("xyz")}
    if quat is not None:
        norm = np.linalg.norm(quat, axis=1)
        bad = ~(np.isfinite(norm) & (norm > 1e-6))
        if bad.any():
            raise ApplyError(
                f"{path}: {int(bad.sum())} row(s) of quat_w..quat_z are not an orientation "
                f"(zero, empty or NaN; first at {position(path, int(np.flatnonzero(bad)[0]))}): "
                "the vendor's orientation cannot be turned into the body frame; fix or drop "
                "those columns"
            )
        turned = Rotation.from_quat(quat, scalar_first=True) * Rotation.from_matrix(R).inv()
        out |= dict(zip(QUAT_COLUMNS, turned.as_quat(scalar_first=True).T))
    return out


def write_body_frame(dataset: Dataset, row, R: np.ndarray, target: Path, report) -> bool:
    """The body-frame copy of one recording (a recordings.tsv row) at ``target``, in the input's
    format: CSV (:func:`body_frame_table`) or Parquet (the changed columns in float64, the
    others as the input's). False when the recording has an error (added to ``report``).
    """
    if Path(row["path"]).suffix != ".parquet":
        table = body_frame_table(dataset, row["path"], R, report, row)
        if table is not None:
            table.to_csv(target, index=False)
        return table is not None
    import pyarrow as pa
    import pyarrow.parquet as pq

    recording = read_checked(dataset, row, report)
    if recording is None:
        return False
    table = pq.read_table(dataset.root / row["path"])
    quat = (
        np.column_stack(
            [table.column(c).to_numpy(zero_copy_only=False) for c in QUAT_COLUMNS]
        ).astype(float)
        if set(QUAT_COLUMNS) <= set(table.column_names)
        else None
    )
    for name, values in _rotated(dataset, recording, R, quat, row["path"]).items():
        table = table.set_column(table.schema.get_field_index(name), name, pa.array(values))
    pq.write_table(table, target, compression="none", write_statistics=False, use_dictionary=False)
    return True


def apply_calibrations(
    dataset: Dataset,
    chosen: pd.DataFrame,
    out: Path,
    method: str | None = None,
    progress=None,
    source: str | None = None,
) -> list[str]:
    """Write the body-frame copies into the empty folder ``out`` with the calibrations ``chosen``
    (:func:`chosen_calibrations`: its 'none' rows are left out, and listed in
    applied_calibrations.tsv with the others); returns what to say: a line per IMU (which
    calibration, and why), the warnings and a summary. ApplyError (naming the file or row and the
    cause) when a recording to copy has an error or, once all were read, when ``source`` (the
    calibrations file's name; None: not checked) was made from other recordings than the
    dataset's (:func:`check_source`).
    """
    method = method or registry.paper_method("kong2016")
    applied = chosen[chosen["calibration"] != "none"]
    rotations = {
        tuple(row[KEY]): row[R_COLUMNS].to_numpy(float).reshape(3, 3)
        for _, row in applied.iterrows()
    }
    recordings = dataset.recordings
    keep = recordings[[key in rotations for key in zip(*(recordings[k] for k in KEY))]]
    for sheet in sorted(dataset.root.glob("*")):
        if sheet.is_file() and sheet.suffix in (".tsv", ".yaml") and sheet.name not in REWRITTEN:
            shutil.copy(sheet, out / sheet.name)
    imus = pd.read_csv(dataset.root / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    imus.assign(right_axis="+y").to_csv(out / "imus.tsv", sep="\t", index=False)  # body y: right
    keep.to_csv(out / "recordings.tsv", sep="\t", index=False)
    if dataset.ground_truth is not None:
        _write_truth(dataset, rotations, out / "ground_truth.tsv")
    report = ValidationReport(dataset.name)
    for done, row in enumerate(keep.to_dict("records"), start=1):
        R = rotations[(row["subject"], row["sensor_set"], row["imu"])]
        target = contained(out, row["path"])  # never outside the output folder
        target.parent.mkdir(parents=True, exist_ok=True)
        if not write_body_frame(dataset, row, R, target, report):
            raise ApplyError("\n".join(map(str, report.errors)))
        if progress:
            progress(done, len(keep), "recordings written")
    warnings = check_source(dataset, applied, source) if source is not None else []
    columns = [*KEY, "test", "repetitions", "method", *CHOICE_COLUMNS, *R_COLUMNS]
    table = chosen.assign(method=method).reindex(columns=columns)
    cells = table.astype(object).fillna("")  # an empty column reads as float
    write_sheet(out / "applied_calibrations.tsv", columns, cells.to_numpy().tolist())
    said = [
        f"aceval apply: {' '.join(map(str, row[KEY]))}: "
        + (
            f"{method} from {row['why']}"
            if row["calibration"] != "none"
            else f"not applied: {row['why']}"
        )
        for _, row in chosen.iterrows()
    ]
    missing = int((chosen["calibration"] == "none").sum())
    return (
        said
        + warnings
        + [
            f"aceval apply: {len(keep)} recordings of {len(rotations)} IMUs in the body frame ({method}); "
            f"{missing} IMU(s) without a valid {method} calibration from all their repetitions "
            "left out (listed above)"
            + (
                "; ground_truth.tsv rotated into the new frames"
                if dataset.ground_truth is not None
                else ""
            )
        ]
    )


def _write_truth(dataset: Dataset, rotations: dict, path: Path) -> None:
    """ground_truth.tsv of the copies: the true sensor -> body R of each applied IMU times the
    calibration's inverse (the copy's sensor frame is the calibration's body frame).
    """
    rows = []
    for key, R in rotations.items():
        truth = dataset.ground_truth_matrix(*key)
        if truth is not None:
            rows.append([*key, *(f"{v:.17g}" for v in (truth @ R.T).ravel())])
    write_sheet(path, KEY + R_COLUMNS, rows)
