"""Each recording file checked as it is read (time, rate, units, NaN, clipping), and which
recordings of a dataset its sheets define.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.contract import (
    FS_TOLERANCE,
    GRAVITY,
    PLATEAU_RUN,
    QUAT_COLUMNS,
    RECORDING_COLUMNS,
    REST_GRAVITY_BAND,
    SATURATION_FRACTION,
    SHORT_RECORDING_S,
    UNITS_GRAVITY_BAND,
    Recording,
    RecordingError,
    SignalFaults,
    ValidationReport,
    file_problem,
    recording_columns,
    recording_values,
)

# ``dataset`` below is an :class:`aceval.data.dataset.Dataset` (not imported: that module reads
# its files through this one)


def recording_where(row) -> str:
    """How findings name a recording: its path and what it is (subject, set, test, rep, IMU)."""
    return f"{row['path']} ({row['subject']} {row['sensor_set']} {row['test']} R{row['rep']} {row['imu']})"


def read_checked(dataset, row, report: ValidationReport, values=None) -> Recording | None:
    """Read one recording (a recordings.tsv row) and run every file-level check on it, adding
    findings to ``report``: the recording in SI units, with what the checks of its signals found
    (``faults``: the pass that summarises it uses them, not a second run), or None when it has an
    error. ``values``: the file's (N, 7) values when the caller holds them already (a recording
    simulated in the same process, exactly as the file reads back); else the file is read.
    """
    where = recording_where(row)
    path = dataset.root / row["path"]
    if values is None:
        if problem := file_problem(path):
            report.error(where, problem)
            return None
        try:
            values = recording_values(path)
        except RecordingError as exc:
            report.error(where, exc.cause)
            return None
    errors = len(report.errors)
    faults = check_values(dataset, row, values, report)
    if len(report.errors) > errors:
        return None
    recording = as_recording(values, dataset.acc_scale, dataset.gyr_scale, path)
    recording.faults = faults
    return recording


def as_recording(values: np.ndarray, acc_scale: float, gyr_scale: float, path) -> Recording:
    """The :class:`Recording` of a file's (N, 7) values, converted to SI in place: its t, acc
    and gyr are views of the one array (a long recording is held once, not three times).
    """
    values[:, 1:4] *= acc_scale
    values[:, 4:7] *= gyr_scale
    return Recording(values[:, 0], values[:, 1:4], values[:, 4:7], path)


def check_recording(dataset, row, report: ValidationReport) -> None:
    """File-level checks of one recording, adding findings to ``report``."""
    read_checked(dataset, row, report)


def check_values(dataset, row, values: np.ndarray, report: ValidationReport):
    """File-level checks of one recording's (N, 7) values (file units), adding findings to
    ``report``: sample count, NaN, time, sampling rate, units at rest, saturation, clipping and
    the signals' faults (:func:`check_signals`: returned; None when a format check stops first).
    """
    where = recording_where(row)
    if len(values) < 2:
        report.error(where, f"{len(values)} samples: a recording needs at least 2")
        return
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        first = position(row["path"], int(np.flatnonzero(bad)[0]))
        cause = f"{int(bad.sum())} rows with NaN, inf or non-numeric values (first at {first})"
        report.error(where, cause)
        return
    t = values[:, 0]
    dt = np.diff(t)
    if np.any(dt <= 0):
        at = position(row["path"], int(np.flatnonzero(dt <= 0)[0]) + 1)
        kind = "duplicate" if np.any(dt == 0) else "decreasing"
        report.error(where, f"t is not strictly increasing ({kind} time at {at})")
        return
    check_time(dataset, row, t, dt, report)
    acc = values[:, 1:4]
    if dataset.test_kinds[row["test"]] == "static":
        magnitude_g = (
            float(np.median(np.linalg.norm(acc, axis=1))) * abs(dataset.acc_scale) / GRAVITY
        )
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
        limit = SATURATION_FRACTION * float(acc_range) * GRAVITY / abs(dataset.acc_scale)
        n_sat = int((np.abs(acc) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(
                where, f"{n_sat} samples at the accelerometer range +-{acc_range} g (saturated)"
            )
    if dataset.test_kinds[row["test"]] == "motion" and (plateau := plateau_limit(acc)) is not None:
        level_g = plateau * abs(dataset.acc_scale) / GRAVITY
        if not acc_range or level_g < SATURATION_FRACTION * float(acc_range):
            n_flat = int((np.abs(acc) >= plateau).any(axis=1).sum())
            report.warning(
                where,
                f"{n_flat} samples sit at +-{level_g:.3g} g, {PLATEAU_RUN} or more in a row: "
                f"clipped below the declared range ({acc_range or 'none'} g)? "
                + (
                    "aceval uses them (the declared range decides what is clipped)"
                    if acc_range
                    else "aceval leaves them out"
                ),
            )
    calibrating = (row["test"], row["imu"]) in dataset.calibrated
    suspect = calibrating and gyro_units_suspect(values, dataset, where, report)
    faults = check_signals(dataset, row, values, report, spikes=not suspect)
    gyr_range = dataset.meta.get("gyr_range_dps")
    if gyr_range:
        limit = SATURATION_FRACTION * np.radians(float(gyr_range)) / dataset.gyr_scale
        n_sat = int((np.abs(values[:, 4:7]) >= limit).any(axis=1).sum())
        if n_sat:
            report.warning(
                where, f"{n_sat} samples at the gyroscope range +-{gyr_range} deg/s (saturated)"
            )
    return faults


def check_time(dataset, row, t: np.ndarray, dt: np.ndarray, report: ValidationReport) -> None:
    """A recording's time ``t`` (strictly increasing; ``dt`` its steps): its sampling rate
    against dataset.yaml's (an error), a jump (:func:`check_time_jump`) and a recording shorter
    than :data:`SHORT_RECORDING_S` (warnings; a motion recording that short is left out).
    """
    where = recording_where(row)
    fs_in_t = 1.0 / float(np.median(dt))
    if abs(fs_in_t - dataset.fs_hz) > FS_TOLERANCE * dataset.fs_hz:
        report.error(
            where,
            f"sampling rate in t is {fs_in_t:.4g} Hz, dataset.yaml declares {dataset.fs_hz:g} Hz",
        )
    check_time_jump(row["path"], dt, dataset.fs_hz, where, report)
    duration = t[-1] - t[0]
    if duration < SHORT_RECORDING_S:
        motion = dataset.test_kinds[row["test"]] == "motion"
        left_out = " (a motion recording this short is left out of the calibrations)"
        report.warning(where, f"very short recording: {duration:.2f} s" + (left_out * motion))


#: a step of ``t`` longer than this many sampling intervals is a jump: samples lost, or two
#: recordings joined (none on the committed datasets: their longest step is 1.00 interval)
MAX_TIME_STEP = 5.0


def check_time_jump(path: str, dt: np.ndarray, fs_hz: float, where: str, report) -> None:
    """A warning at the largest step of a recording's time ``t`` (``dt``: its steps, s) when it
    is longer than :data:`MAX_TIME_STEP` sampling intervals of ``fs_hz``, with its line and how
    many samples that many intervals hold: the recording is not one piece (the movement trimmer,
    the pairs' time alignment and the step frequency take its samples as consecutive).
    """
    longest = int(np.argmax(dt))
    if dt[longest] * fs_hz > MAX_TIME_STEP:
        jumps = int((dt * fs_hz > MAX_TIME_STEP).sum())
        report.warning(
            where,
            f"t jumps by {dt[longest]:.3g} s at {position(path, longest + 1)} (about "
            f"{dt[longest] * fs_hz - 1:.0f} samples missing at {fs_hz:g} Hz"
            + (f"; {jumps} jumps of more than {MAX_TIME_STEP:g} samples" if jumps > 1 else "")
            + "): samples lost, or recordings joined? aceval takes the samples as consecutive",
        )


#: a channel that holds one value (exactly) for at least this share of a recording's samples, in
#: one run, while the other two channels of its sensor (accelerometer or gyroscope) are noisy
#: there, is stuck: a dead axis reading 0, or a frozen one. Noisy: a new value at
#: :data:`NOISY_SHARE` of the samples or more, and the step changing sign at :data:`NOISY_FLIPS`
#: of them or more (a smooth noise-free signal turns only at its extremes: 0.01 for a slow sine
#: at 100 Hz; the sensors' noise of the committed datasets: 0.06 or more). The condition keeps
#: noise-free signals out (a simulation with ideal sensors, a pure planar rotation), in which a
#: channel may hold 0 rightly (config/README.md: the rates)
STUCK_SHARE = 0.5
NOISY_SHARE = 0.9
NOISY_FLIPS = 0.05
#: a sample whose acceleration (any axis) is this far (g) from the mean of its two neighbours,
#: which agree within half of it, while the angular velocity runs smoothly through it (its
#: second difference below :data:`SPIKE_GYRO_DEG_S`), is a spike: no body segment accelerates by
#: that much for one sample and back without a jolt of its rotation. A foot's heel strike (16 g
#: for one sample at 204.8 Hz, gaitmap) and a thigh strap's wobble (7 g, qmt) turn the
#: gyroscope by 21 deg/s or more in that sample (config/README.md: the rates)
SPIKE_G = 4.0
SPIKE_GYRO_DEG_S = 10.0


def stuck_channel(values: np.ndarray, names) -> tuple[str, float, float] | None:
    """``(name, share, value)`` of a stuck channel of one sensor's (N, 3) ``values`` (columns
    ``names``): the one holding one value longest in a row, when that run is at least
    :data:`STUCK_SHARE` of the samples and the sensor's other two channels are noisy there
    (:data:`NOISY_SHARE`, :data:`NOISY_FLIPS`); else None. Memory: a few bytes per sample.
    """
    values = np.asarray(values)
    if len(values) < 10:
        return None
    best = None  # (name, run length, value)
    for k, name in enumerate(names):
        column = values[:, k]
        edges = np.concatenate([[-1], np.flatnonzero(column[1:] != column[:-1]), [len(values) - 1]])
        runs = np.diff(edges)
        longest = int(runs.max())
        if longest < STUCK_SHARE * len(values) or (best is not None and longest <= best[1]):
            continue
        start = int(edges[np.argmax(runs)] + 1)
        if all(_noisy(values[start : start + longest, j]) for j in range(3) if j != k):
            best = (name, longest, float(values[start, k]))
    return None if best is None else (best[0], best[1] / len(values), best[2])


def _noisy(signal: np.ndarray) -> bool:
    """A live channel's samples: a new value at :data:`NOISY_SHARE` of them or more, and the
    step changing sign at :data:`NOISY_FLIPS` of them or more.
    """
    steps = np.sign(np.diff(signal)).astype(np.int8)
    return bool(
        (steps != 0).mean() >= NOISY_SHARE and (steps[1:] * steps[:-1] < 0).mean() >= NOISY_FLIPS
    )


def acc_spikes(acc: np.ndarray, gyr: np.ndarray):
    """(N,) True at the single-sample spikes (:data:`SPIKE_G`) of an (N, 3) acceleration (m/s^2),
    with the (N, 3) angular velocity of the same sensor (rad/s). Axis by axis: a few arrays of
    one axis at a time.
    """
    out = np.zeros(len(acc), dtype=bool)
    if len(acc) < 3:
        return out
    limit = SPIKE_G * GRAVITY
    candidate = np.zeros(len(acc) - 2, dtype=bool)
    for k in range(3):
        before, after = acc[:-2, k], acc[2:, k]
        jump = np.abs(acc[1:-1, k] - (before + after) / 2)
        candidate |= (jump > limit) & (np.abs(before - after) < jump / 2)
    if candidate.any():
        at = np.flatnonzero(candidate) + 1
        rate = np.degrees(np.asarray(gyr, dtype=float)[np.stack([at - 1, at, at + 1])])
        jolt = np.linalg.norm(rate[1] - (rate[0] + rate[2]) / 2, axis=1)
        out[at] = jolt < SPIKE_GYRO_DEG_S
    return out


def vendor_up(path: Path) -> np.ndarray | None:
    """The vendor's up (unit, sensor frame) over a recording: the median direction of z of the
    vendor's z-up world seen from the sensor, from the quaternions ``quat_w..quat_z`` (sensor ->
    world, scalar first); None when the file has none (or none is an orientation).
    """
    from scipy.spatial.transform import Rotation

    path = Path(path)
    try:
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            if not set(QUAT_COLUMNS) <= set(pq.read_schema(path).names):
                return None
            quat = pq.read_table(path, columns=QUAT_COLUMNS).to_pandas()
        else:
            if not set(QUAT_COLUMNS) <= set(recording_columns(path)):
                return None
            quat = pd.read_csv(path, usecols=QUAT_COLUMNS)
    except (OSError, ValueError):
        return None
    quat = quat.apply(pd.to_numeric, errors="coerce").to_numpy(float)
    norm = np.linalg.norm(quat, axis=1)
    quat = quat[np.isfinite(norm) & (norm > 1e-6)]
    if not len(quat):
        return None
    up = Rotation.from_quat(quat, scalar_first=True).inv().apply([0.0, 0.0, 1.0])
    median = np.median(up, axis=0)
    return median / np.linalg.norm(median) if np.linalg.norm(median) > 0 else None


def check_signals(
    dataset, row, values: np.ndarray, report: ValidationReport, spikes: bool = True
) -> SignalFaults:
    """The checks of a recording's signals beyond its format, on its (N, 7) values (file units),
    each a warning naming the file and what aceval does about it: a stuck channel
    (:func:`stuck_channel`; of a static recording the accelerometer's only: a still gyroscope may
    hold its value) and, with ``spikes``, spikes (:func:`acc_spikes`, in SI: the acceleration
    the summary leaves them out of; not where the gyroscope's units are in doubt, since they
    judge its jolt). Returns what they found, for the pass that summarises the recording.
    """
    where = recording_where(row)
    static = dataset.test_kinds[row["test"]] == "static"
    found = stuck_channel(values[:, 1:4], RECORDING_COLUMNS[1:4])
    if not static and not found:
        found = stuck_channel(values[:, 4:7], RECORDING_COLUMNS[4:7])
    if found:
        name, share, value = found
        report.warning(
            where,
            f"{name} is stuck at {value:g} for {share:.0%} of the recording (one value in a row): "
            "a dead or frozen axis; aceval leaves the recording out",
        )
    spiky = (
        acc_spikes(values[:, 1:4] * dataset.acc_scale, values[:, 4:7] * dataset.gyr_scale)
        if spikes
        else np.zeros(len(values), dtype=bool)
    )
    if spiky.any():
        first = position(row["path"], int(np.flatnonzero(spiky)[0]))
        report.warning(
            where,
            f"{int(spiky.sum())} single-sample acceleration spike(s) of more than {SPIKE_G:g} g "
            f"(first at {first}): beyond what a body segment does; aceval leaves them out",
        )
    return SignalFaults(found, spiky)


#: a recording of a test that calibrates its IMU whose gyroscope peaks below the movement
#: trimmer's threshold (its default, :class:`aceval.signals.segmentation.TrimParams`: 20 deg/s;
#: none of the committed datasets' does) while its accelerometer's direction turns by at least
#: :data:`UNITS_TURN_DEG` moved, and its gyroscope reads far too little: rad/s declared deg/s
#: (57.3-fold), or a dead gyroscope. The turn: the 95th percentile of the angle of the
#: acceleration (averaged over :data:`TURN_WINDOW_S`) from its median direction. Not judged in a
#: test that does not calibrate the IMU: a sensor that the test barely turns may still move, and
#: its accelerometer turn with the linear acceleration (up to 17.9 deg on kong_sim); the rates:
#: config/README.md
NO_MOVEMENT_DEG_S = 20.0
UNITS_TURN_DEG = 5.0
TURN_WINDOW_S = 0.25


def accelerometer_turn_deg(acc: np.ndarray, fs_hz: float) -> float:
    """How far (deg) a recording's acceleration (N, 3) turns from its median direction: the 95th
    percentile over its samples, each averaged over :data:`TURN_WINDOW_S` (any units).
    """
    from scipy.ndimage import uniform_filter1d

    width = max(1, int(round(TURN_WINDOW_S * fs_hz)))
    smooth = uniform_filter1d(np.asarray(acc, dtype=float), width, axis=0, mode="nearest")
    norm = np.linalg.norm(smooth, axis=1)
    direction = smooth[norm > 0] / norm[norm > 0, None]
    if not len(direction):
        return 0.0
    median = np.median(direction, axis=0)
    median /= np.linalg.norm(median) or 1.0
    return float(np.percentile(np.degrees(np.arccos(np.clip(direction @ median, -1, 1))), 95))


def gyro_units_doubt(peak_deg_s: float, acc: np.ndarray, fs_hz: float, declared: str) -> str:
    """Why a motion recording's gyroscope units are in doubt ('' when they are not): its peak
    angular speed ``peak_deg_s`` (as declared) is below :data:`NO_MOVEMENT_DEG_S` while its
    acceleration ``acc`` (N, 3) turns by :data:`UNITS_TURN_DEG` or more
    (:func:`accelerometer_turn_deg`); ``declared``: dataset.yaml ``units.gyr``.
    """
    if peak_deg_s >= NO_MOVEMENT_DEG_S:
        return ""
    turn = accelerometer_turn_deg(acc, fs_hz)
    if turn < UNITS_TURN_DEG:
        return ""
    other = "rad/s" if declared == "deg/s" else "deg/s"
    as_other = peak_deg_s * (180.0 / np.pi if declared == "deg/s" else np.pi / 180.0)
    return (
        f"the accelerometer turns {turn:.0f} deg while the gyroscope peaks at {peak_deg_s:.3g} "
        f"deg/s, below the {NO_MOVEMENT_DEG_S:g} deg/s of any movement: are units.gyr "
        f"({declared}) right? Read as {other}, the peak is {as_other:.3g} deg/s (or the "
        "gyroscope is dead)"
    )


def gyro_units_suspect(values: np.ndarray, dataset, where: str, report) -> bool:
    """True, with a warning, when a motion recording's (N, 7) ``values`` (file units) put its
    gyroscope's units in doubt (:func:`gyro_units_doubt`).
    """
    peak_deg_s = np.degrees(np.linalg.norm(values[:, 4:7], axis=1).max() * dataset.gyr_scale)
    doubt = gyro_units_doubt(
        float(peak_deg_s), values[:, 1:4], dataset.fs_hz, dataset.meta["units"]["gyr"]
    )
    if doubt:
        report.warning(where, f"{doubt}. aceval finds no movement in it and leaves it out")
    return bool(doubt)


def position(path: str, index: int) -> str:
    """Where sample ``index`` (0-based) of a recording is: its line in a CSV (the header is line
    1), its row (1-based) in a Parquet table.
    """
    return f"row {index + 1}" if str(path).endswith(".parquet") else f"line {index + 2}"


def plateau_limit(signal: np.ndarray, run: int = PLATEAU_RUN) -> float | None:
    """The |value| (in the signal's units) at which an (N, 3) signal is clipped, found from the data
    alone: the largest |value| of an axis held for ``run`` or more consecutive samples (a smooth
    signal passes its peak in one sample; a clipped one sits on the rail). The lowest such level over
    the axes, or None when no axis has a plateau at its extreme. Axis by axis, from the runs of
    samples at the peak (a few bytes per sample).
    """
    signal = np.asarray(signal, dtype=float)
    if len(signal) < run:
        return None
    levels = []
    for k in range(signal.shape[1]):
        magnitude = np.abs(signal[:, k])
        peak = magnitude.max()
        at_peak = (magnitude >= peak * (1 - 1e-9)).astype(np.int8)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], at_peak, [0]])))
        if peak > 0 and (edges[1::2] - edges[::2]).max(initial=0) >= run:
            levels.append(float(peak))
    return min(levels) if levels else None


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
    if problem := file_problem(path):
        report.error(where, problem)
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
