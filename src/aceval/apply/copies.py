"""Body-frame copies of a dataset's recordings (d_body = R d_sensor), once the calibration of
each IMU is chosen (:mod:`aceval.apply.choice`).

The copies go into a new folder laid out like the dataset (same sheets, same relative paths,
same units), with ``applied_calibrations.tsv`` naming the calibration used for each IMU. The
input is only read. Each recording is checked as ``aceval calibrate`` checks it (an error names
the file and stops the command before anything is in place); the time column and every column
apply does not change are carried as the input's own text (a CSV) or values (Parquet, the format
of a simulated dataset: the copy is Parquet too); the vendor's orientation quaternions
and ground_truth.tsv are rotated into the new sensor frame (the body frame the calibration
estimates), so the copy validates and still has a truth. A CSV's rotated columns are written one
significant digit finer than the source's values (:func:`significant_digits`): a rotated value is
at most about as large as the sensor's largest channel, so its rounding stays within the
source's own rounding of that channel (a tenth of it in most samples). Calibrations made from
other recordings than the dataset's (:func:`recordings_fingerprint`), or any onto a copy apply
wrote (already in the body frame) but its own, are refused.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.apply.choice import CHOICE_COLUMNS, KEY, VERDICT_KINDS, ApplyError
from aceval.data.contract import FINGERPRINT, QUAT_COLUMNS, R_COLUMNS, ValidationReport
from aceval.data.dataset import Dataset
from aceval.data.recording_checks import position, read_checked
from aceval.data.safety import contained
from aceval.data.writer import write_sheet
from aceval.methods import registry

#: the sheets apply writes anew (the others are copied as they are)
REWRITTEN = {"imus.tsv", "recordings.tsv", "ground_truth.tsv"}
#: the sheet a body-frame copy carries (its recordings are already turned)
APPLIED_SHEET = "applied_calibrations.tsv"


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


def check_source(dataset: Dataset, chosen: pd.DataFrame, source: str) -> list[str]:
    """ApplyError when a subject's calibrations were made from other recordings than this
    dataset's (another dataset, files changed since, or labels exchanged: :func:`fingerprints`);
    the warnings: a file of an older aceval (no fingerprint, or one without the labels) or of a
    peer tool (a method aceval does not have; no fingerprint) cannot be checked as fully.
    """
    if FINGERPRINT not in chosen.columns or chosen[FINGERPRINT].isna().all():
        if "verdict_kind" in chosen.columns:
            return [
                f"{source} does not say which recordings its calibrations were made from (no "
                f"{FINGERPRINT} column): not checked that it is this dataset's decision"
            ]
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


def check_not_applied(dataset: Dataset, chosen: pd.DataFrame, other_dataset: bool, source) -> None:
    """ApplyError when ``dataset`` is a copy apply wrote (it holds :data:`APPLIED_SHEET`: its
    recordings are in the body frame already) and the calibrations (of the file ``source``) are
    not shown to be made from the copy itself (``other_dataset``, no fingerprint, or another
    one): applying them would turn the recordings a second time.
    """
    if not (dataset.root / APPLIED_SHEET).is_file():
        return
    fingerprinted = FINGERPRINT in chosen.columns and chosen[FINGERPRINT].notna().any()
    try:
        mine = not other_dataset and fingerprinted
        mine = mine and check_source(dataset, chosen[chosen["calibration"] != "none"], source) == []
    except ApplyError:
        mine = False
    if not mine:
        raise ApplyError(
            f"{dataset.root} is a body-frame copy written by aceval apply ({APPLIED_SHEET}): its "
            "recordings are turned already, and these calibrations were not made from it: "
            "applying them would turn them a second time. Apply to the original dataset instead"
        )


def body_frame_table(
    dataset: Dataset, path: str, R: np.ndarray, report: ValidationReport, row
) -> pd.DataFrame | None:
    """The CSV recording at ``path`` with acc and gyr in the body frame (file units, one
    significant digit more than the source's: :func:`significant_digits`) and the quaternions
    (sensor -> world) now new-sensor -> world; every other column as the input's text. None when
    the recording has an error (added to ``report``).
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
    rotated = _rotated(dataset, recording, R, quat, path)
    digits = min(17, significant_digits(text[list(rotated)]) + 1)
    for name, values in rotated.items():
        text[name] = [f"{v:.{digits}g}" for v in values.tolist()]
    return text


def significant_digits(cells: pd.DataFrame) -> int:
    """The most significant digits any of the number texts ``cells`` holds (``-0.01230`` and
    ``1.230e-2``: 4; at least 1). A rotated value is at most about as large as its sensor's
    largest channel (``|R v| = |v|``), so written with one digit more its rounding is at most the
    source's rounding of that channel.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    texts = pa.array(cells.to_numpy().ravel(), type=pa.string())
    mantissa = pc.replace_substring_regex(texts, r"[eE].*$", "")
    digits = pc.utf8_ltrim(pc.replace_substring_regex(mantissa, r"[^0-9]", ""), "0")
    return max(1, pc.max(pc.utf8_length(digits)).as_py() or 0)


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
    (:func:`chosen_calibrations` of ``method``, or :func:`decided_calibrations`: its 'none' rows
    are left out, and listed in applied_calibrations.tsv with the others); returns what to say: a
    line per IMU (which calibration, and why), the warnings (a decision's ``not within
    tolerance`` and untrusted calibrations applied, by name) and a summary. ApplyError (naming
    the file or row and the cause) when a recording to copy has an error or, once all were read,
    when ``source`` (the calibrations file's name; None: not checked) was made from other
    recordings than the dataset's (:func:`check_source`).
    """
    decided = "verdict_kind" in chosen.columns
    method = None if decided else method or registry.paper_method("kong2016")
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
    table = (chosen if decided else chosen.assign(method=method)).reindex(columns=columns)
    cells = table.astype(object).fillna("")  # an empty column reads as float
    write_sheet(out / APPLIED_SHEET, columns, cells.to_numpy().tolist())
    missing = int((chosen["calibration"] == "none").sum())
    which = "the decision's calibration of each" if decided else method
    summary = (
        f"aceval apply: {len(keep)} recordings of {len(rotations)} IMUs in the body frame ({which}); "
        + (
            f"{missing} IMU(s) not applied (listed above)"
            if decided
            else f"{missing} IMU(s) without a valid {method} calibration from all their "
            "repetitions left out (listed above)"
        )
        + (
            "; ground_truth.tsv rotated into the new frames"
            if dataset.ground_truth is not None
            else ""
        )
    )
    return _said_lines(chosen, method) + warnings + _decision_warnings(chosen) + [summary]


def _said_lines(chosen: pd.DataFrame, method: str | None) -> list[str]:
    """A line per IMU: which calibration was applied and why, or why none (``method`` None: a
    decision's, each IMU's own method, test and repetitions).
    """
    said = []
    for _, row in chosen.iterrows():
        what = f"aceval apply: {' '.join(map(str, row[KEY]))}: "
        if row["calibration"] == "none":
            said.append(what + f"not applied: {row['why']}")
        elif method is None:
            said.append(
                what + f"{row['method']} ({row['test']} {row['repetitions']}): {row['why']}"
            )
        else:
            said.append(what + f"{method} from {row['why']}")
    return said


def _decision_warnings(chosen: pd.DataFrame) -> list[str]:
    """A warning per IMU whose calibration was applied though the decision says it is not within
    the lab's tolerance or not trustworthy.
    """
    if "verdict_kind" not in chosen.columns:
        return []
    warned = chosen[chosen["calibration"].isin(VERDICT_KINDS[2:])]
    return [
        f"{' '.join(map(str, row[KEY]))}: applied, but the decision says {row['why']}"
        for _, row in warned.iterrows()
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
