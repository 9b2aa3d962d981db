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
from aceval.data.recording_checks import read_checked
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


class ApplyError(ValueError):
    """The calibrations cannot be applied to this dataset; the message says which row and why."""


def recordings_fingerprint(dataset: Dataset, subject: str) -> str:
    """SHA-1 of a subject's recordings: each recordings.tsv row's path and the file's bytes, in
    the sheet's order. Calibrate writes it with each calibration; apply compares it with the
    dataset it is asked to change.
    """
    digest = hashlib.sha1()
    for path in dataset.recordings.loc[dataset.recordings["subject"] == subject, "path"]:
        digest.update(f"{path}\0".encode())
        try:
            digest.update((dataset.root / path).read_bytes())
        except OSError:
            digest.update(b"\0missing")
    return digest.hexdigest()


def read_calibrations(path: str | Path) -> pd.DataFrame:
    """The CSV of `aceval calibrate` at ``path``; ApplyError naming the file and the cause when it
    is missing, unreadable, binary or not such a file.
    """
    from aceval.report.results import read_tables

    try:
        calibrations = read_tables([path])
    except FileNotFoundError:
        raise ApplyError(f"{path}: file is missing") from None
    except (UnicodeDecodeError, pd.errors.ParserError, OSError) as exc:
        raise ApplyError(f"{path}: not a CSV of `aceval calibrate` ({exc})") from None
    missing = {"subject", "sensor_set", "imu", "test", "method", "n_reps", "flag"}
    missing -= set(calibrations.columns)
    if calibrations.empty or missing:
        raise ApplyError(
            f"{path} holds no calibrations"
            + (
                f" (missing column(s) {', '.join(sorted(missing))}: is it a file of "
                "`aceval calibrate`?)"
                if missing and not calibrations.empty
                else ""
            )
        )
    return calibrations


def chosen_calibrations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    method: str | None = None,
    test: str | None = None,
) -> pd.DataFrame:
    """One valid calibration per (subject, set, IMU): ``method`` (default Kong's, the registry's
    method of Kong et al. 2016), all repetitions (the largest ``n_reps``), from ``test`` or else
    the first test of calibrates.tsv that has one.
    """
    method = method or registry.paper_method("kong2016")
    valid = calibrations[(calibrations["method"] == method) & unflagged(calibrations)]
    if test is not None:
        valid = valid[valid["test"] == test]
    order = {t: k for k, t in enumerate(dict.fromkeys(dataset.calibrates["test"]))}
    valid = valid.assign(_order=valid["test"].map(order).fillna(len(order)))
    valid = valid.sort_values(["_order", "n_reps"], ascending=[True, False])
    return valid.drop_duplicates(KEY).drop(columns="_order").reset_index(drop=True)


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
    dataset's (another dataset, or files changed since: :func:`recordings_fingerprint`); the
    warnings (a file without fingerprints cannot be checked).
    """
    if FINGERPRINT not in chosen.columns:
        return [
            f"{source} has no {FINGERPRINT} column (an older aceval): not checked that it was "
            f"made from this dataset's recordings"
        ]
    for subject, stored in chosen.groupby("subject")[FINGERPRINT].first().items():
        if str(stored) != recordings_fingerprint(dataset, subject):
            raise ApplyError(
                f"{source}: the calibrations of subject {subject} were made from other recordings "
                f"than those of {dataset.root} (another dataset, or files changed since): "
                f"calibrate this dataset, or pass --other-dataset to apply them anyway"
            )
    return []


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
    quat = text[QUAT_COLUMNS].astype(float).to_numpy() if set(QUAT_COLUMNS) <= set(text) else None
    for name, values in _rotated(dataset, recording, R, quat).items():
        text[name] = [repr(v) for v in values.tolist()]
    return text


def _rotated(dataset: Dataset, recording, R: np.ndarray, quat) -> dict[str, np.ndarray]:
    """The columns apply changes, by name: acc and gyr turned into the body frame (file units),
    and the vendor's quaternions ``quat`` (N, 4) when there are any, world <- body = (world <-
    sensor)(sensor <- body).
    """
    out = {}
    for name, values, scale in (
        ("acc", recording.acc, dataset.acc_scale),
        ("gyr", recording.gyr, dataset.gyr_scale),
    ):
        rotated = values @ R.T / scale
        out |= {f"{name}_{axis}": rotated[:, k] for k, axis in enumerate("xyz")}
    if quat is not None:
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
        np.column_stack([table.column(c).to_numpy() for c in QUAT_COLUMNS])
        if set(QUAT_COLUMNS) <= set(table.column_names)
        else None
    )
    for name, values in _rotated(dataset, recording, R, quat).items():
        table = table.set_column(table.schema.get_field_index(name), name, pa.array(values))
    pq.write_table(table, target, compression="none", write_statistics=False, use_dictionary=False)
    return True


def apply_calibrations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    out: Path,
    method: str | None = None,
    test: str | None = None,
    progress=None,
    source: str | None = None,
) -> list[str]:
    """Write the body-frame copies into the empty folder ``out``; returns the warnings and a
    one-line summary. ApplyError (naming the file or row and the cause) when a recording to copy
    has an error or, once all were read, when ``source`` (the calibrations file's name; None: not
    checked) was made from other recordings than the dataset's (:func:`check_source`).
    """
    chosen = chosen_calibrations(dataset, calibrations, method, test)
    rotations = {
        tuple(row[KEY]): row[R_COLUMNS].to_numpy(float).reshape(3, 3)
        for _, row in chosen.iterrows()
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
    warnings = check_source(dataset, chosen, source) if source is not None else []
    columns = KEY + ["test", "repetitions", "method", *R_COLUMNS]
    write_sheet(out / "applied_calibrations.tsv", columns, chosen[columns].to_numpy().tolist())
    missing = recordings[KEY].drop_duplicates().shape[0] - len(rotations)
    return warnings + [
        f"aceval apply: {len(keep)} recordings of {len(rotations)} IMUs in the body frame ({method}); "
        f"{missing} IMU(s) without a valid {method} calibration left out"
        + (
            "; ground_truth.tsv rotated into the new frames"
            if dataset.ground_truth is not None
            else ""
        )
    ]


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
