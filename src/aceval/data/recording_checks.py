"""Each recording file checked as it is read (time, rate, units, NaN, clipping), and which
recordings of a dataset its sheets define.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.data.contract import (
    FS_TOLERANCE,
    GRAVITY,
    PLATEAU_RUN,
    RECORDING_COLUMNS,
    REST_GRAVITY_BAND,
    SATURATION_FRACTION,
    SHORT_RECORDING_S,
    UNITS_GRAVITY_BAND,
    Recording,
    RecordingError,
    ValidationReport,
    recording_columns,
    recording_values,
)

# ``dataset`` below is an :class:`aceval.data.dataset.Dataset` (not imported: that module reads
# its files through this one)


def recording_where(row) -> str:
    """How findings name a recording: its path and what it is (subject, set, test, rep, IMU)."""
    return f"{row['path']} ({row['subject']} {row['sensor_set']} {row['test']} R{row['rep']} {row['imu']})"


def read_checked(dataset, row, report: ValidationReport) -> Recording | None:
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


def check_recording(dataset, row, report: ValidationReport) -> None:
    """File-level checks of one recording, adding findings to ``report``."""
    read_checked(dataset, row, report)


def check_values(dataset, row, values: np.ndarray, report: ValidationReport) -> None:
    """File-level checks of one recording's (N, 7) values (file units), adding findings to
    ``report``: sample count, NaN, time, sampling rate, units at rest, saturation and clipping.
    """
    where = recording_where(row)
    if len(values) < 2:
        report.error(where, f"{len(values)} samples: a recording needs at least 2")
        return
    bad = ~np.isfinite(values)
    if bad.any():
        first = position(row["path"], int(np.flatnonzero(bad.any(axis=1))[0]))
        report.error(
            where,
            f"{int(bad.any(axis=1).sum())} rows with NaN, inf or non-numeric values (first at {first})",
        )
        return
    t = values[:, 0]
    dt = np.diff(t)
    if np.any(dt <= 0):
        at = position(row["path"], int(np.flatnonzero(dt <= 0)[0]) + 1)
        kind = "duplicate" if np.any(dt == 0) else "decreasing"
        report.error(where, f"t is not strictly increasing ({kind} time at {at})")
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


def position(path: str, index: int) -> str:
    """Where sample ``index`` (0-based) of a recording is: its line in a CSV (the header is line
    1), its row (1-based) in a Parquet table.
    """
    return f"row {index + 1}" if str(path).endswith(".parquet") else f"line {index + 2}"


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
    # a window of ``run`` samples all at the peak <=> a plateau (window sums from a cumulative sum)
    count = np.concatenate([np.zeros((1, magnitude.shape[1]), int), np.cumsum(at_peak, axis=0)])
    clipped = ((count[run:] - count[:-run]) == run).any(axis=0) & (peak > 0)
    return float(peak[clipped].min()) if clipped.any() else None


def known_recordings(dataset) -> pd.DataFrame:
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


def check_header(dataset, row, report: ValidationReport) -> None:
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
        columns = recording_columns(path)
    except (OSError, EOFError, ValueError) as exc:
        report.error(where, f"cannot be read: {exc}")
        return
    missing = [c for c in RECORDING_COLUMNS if c not in columns]
    if missing:
        hint = " (is the file comma-separated?)" if len(columns) == 1 else ""
        header = ",".join(columns)
        report.error(
            where,
            f"missing column(s) {', '.join(missing)}; the header is {header[:60]!r}{hint}",
        )
