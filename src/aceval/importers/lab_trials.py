"""One trial of a lab's exports read, whatever the vendor: each file's sensors (a reader of the
format gives :class:`SensorSamples`), matched to the sensor sheet, their rates agreed, their
samples synchronised by the sample index they share (a packet counter, a time column, or the
row), lost samples and time jumps reported with their sizes, and the trial cut to its segment.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aceval.data.contract import FS_TOLERANCE
from aceval.importers.lab_sheets import Trial, subject_sensors
from aceval.importers.shared import FormatError, ImportReport

#: how many lost-sample gaps a message lists before it counts the rest
LISTED_GAPS = 5


@dataclass
class SensorSamples:
    """One sensor's samples in one file (SI: acc m/s^2, gyr rad/s, (N, 3)): ``quat`` (N, 4,
    scalar first) or None, ``index`` (N,) the sample number it shares with the trial's other
    sensors (a packet counter unwrapped, a time stamp times the rate, or the row), ``rates``
    where the file says its rate (``{'its rate line': 100.0, ...}``), ``declared``: the rate is
    only the one given by hand (``--rate``, a mapping's ``rate``), and ``clock`` what ``index``
    is (for the messages: 'PacketCounter', 'time column', 'row').
    """

    sensor: str
    path: Path
    acc: np.ndarray
    gyr: np.ndarray
    quat: np.ndarray | None
    index: np.ndarray
    rates: dict
    declared: bool
    clock: str


def agreed_rate(rates: dict, path) -> float:
    """The rate of a file from where it is given (``{where: Hz}``): they must agree within the
    contract's 2 %; FormatError saying what was found and what to do.
    """
    if not rates:
        raise FormatError(
            f"{path}: its sampling rate is given nowhere (no rate line, no time stamps): give it "
            "with --rate (e.g. --rate 100)"
        )
    values = list(rates.values())
    if max(values) / min(values) - 1 > FS_TOLERANCE:
        raise FormatError(
            f"{path}: the sampling rate disagrees: "
            + ", ".join(f"{where} {hz:.4g} Hz" for where, hz in rates.items())
            + " (more than 2 % apart): check --rate, or the export"
        )
    return values[0]


def read_lab_trial(
    trial: Trial,
    sensors,
    read_file: Callable[[Path], list[SensorSamples]],
    trim_to_shared: bool,
    report: ImportReport,
) -> tuple[dict, float, bool]:
    """``({sensor_id: {acc, gyr, quat, row, file}}, fs_hz, declared)`` of one trial: its files
    read by ``read_file``, the sensors the sheet names for its subject kept (the others named and
    skipped), their rates agreed, their samples synchronised; ``declared``: the rate was only
    given by hand.
    """
    rows = subject_sensors(sensors, trial.subject)
    found: dict[str, SensorSamples] = {}
    rates: dict[str, float] = {}
    for path in trial.files:
        for samples in read_file(path):
            sensor = samples.sensor.upper()
            if sensor not in rows:
                report.add(path.name, trial.subject, sensor, "skipped", "sensor not in sensors.tsv")
                report.note(
                    f"{path}: sensor {sensor} is not in sensors.tsv for {trial.subject}: skipped"
                )
                continue
            if sensor in found:
                raise FormatError(
                    f"{trial.where}: two exports of sensor {sensor}: {found[sensor].path}, {path}"
                )
            found[sensor], rates[sensor] = samples, agreed_rate(samples.rates, path)
    if not found:
        raise FormatError(
            f"{trial.where}: none of its {len(trial.files)} export(s) is of a sensor that "
            f"sensors.tsv lists for subject {trial.subject}"
        )
    if max(rates.values()) / min(rates.values()) - 1 > FS_TOLERANCE:
        listed = ", ".join(f"{s} {r:g} Hz" for s, r in rates.items())
        raise FormatError(f"{trial.where}: its sensors were sampled at different rates ({listed})")
    _refuse_gaps(trial, found.values())
    kept = synchronised(trial, found, trim_to_shared, report)
    for sensor in rows:
        if sensor not in found:
            imu = rows[sensor]["imu"]
            report.add(trial.where, trial.subject, imu, "missing", f"no export of sensor {sensor}")
            report.note(
                f"{trial.where}: no export of sensor {sensor} ({imu}): its IMU is missing there"
            )
    out = {
        s: {
            "acc": found[s].acc[k],
            "gyr": found[s].gyr[k],
            "quat": None if found[s].quat is None else found[s].quat[k],
            "row": rows[s],
            "file": found[s].path.name,
        }
        for s, k in kept.items()
    }
    declared = all(f.declared for f in found.values())
    return out, next(iter(rates.values())), declared


def _refuse_gaps(trial: Trial, found) -> None:
    """FormatError listing every file whose sample index does not step by one: lost samples
    (how many lost at which sample, the largest and the total) or a clock that goes back.
    """
    lines = []
    for samples in found:
        steps = np.diff(samples.index)
        bad = np.flatnonzero(steps != 1)
        if len(bad) == 0:
            continue
        lost = steps[bad] - 1
        listed = ", ".join(
            f"{int(n)} lost after sample {int(k) + 1}"
            if n > 0
            else f"back by {-int(n) - 1} after sample {int(k) + 1}"
            for n, k in zip(lost[:LISTED_GAPS], bad[:LISTED_GAPS])
        )
        more = f", and {len(bad) - LISTED_GAPS} more" if len(bad) > LISTED_GAPS else ""
        lines.append(
            f"  {samples.path.name} ({samples.sensor}): {len(bad)} jump(s) of its "
            f"{samples.clock}, {int(lost[lost > 0].sum())} sample(s) lost in all (the largest "
            f"gap {max(int(lost.max()), 0)}): {listed}{more}"
        )
    if lines:
        raise FormatError(
            f"{trial.where}: samples are lost or the clock jumps (a dataset's recordings are "
            "evenly sampled): re-export the trial with lost samples filled, or cut it with "
            "start_s/end_s in trials.tsv to a part without gaps:\n" + "\n".join(lines)
        )


def synchronised(trial: Trial, found: dict, trim: bool, report: ImportReport) -> dict:
    """``{sensor: row selection}``: the samples all the trial's sensors share by their index
    (all of them, or trimmed to the common range with ``trim``); FormatError with each sensor's
    range otherwise.
    """
    ranges = {s: (int(f.index[0]), int(f.index[-1])) for s, f in found.items()}
    everything = {s: slice(None) for s in found}
    if len(set(ranges.values())) == 1:
        return everything
    clock = next(iter(found.values())).clock
    first, last = max(a for a, _ in ranges.values()), min(b for _, b in ranges.values())
    common = max(set(ranges.values()), key=list(ranges.values()).count)
    others = sum(r == common for r in ranges.values())
    listed = "; ".join(
        f"{s}: {b - a + 1} samples ({clock} {a}-{b})"
        for s, (a, b) in ranges.items()
        if (a, b) != common or others == 1
    )
    if others > 1:
        listed += f"; the other {others}: {common[1] - common[0] + 1} ({common[0]}-{common[1]})"
    if first > last:
        raise FormatError(
            f"{trial.where}: its sensors share no sample ({listed}): they were not recorded "
            "together (a trial is one synchronised recording)"
        )
    if not trim:
        raise FormatError(
            f"{trial.where}: its sensors do not cover the same samples ({listed}). Pass "
            f"--trim-to-shared to keep the {last - first + 1} samples all of them share, or "
            "re-export the trial"
        )
    cut = {s: (first - a, b - last) for s, (a, b) in ranges.items() if (a, b) != (first, last)}
    report.note(
        f"{trial.where}: trimmed to the {last - first + 1} samples all sensors share ("
        + ", ".join(f"{s}: {a} at the start, {b} at the end" for s, (a, b) in cut.items())
        + ")"
    )
    return {s: (f.index >= first) & (f.index <= last) for s, f in found.items()}


def segment(trial: Trial, found: dict, fs_hz: float) -> dict:
    """The trial's sensors cut to its segment (``trial.span``, seconds from the first sample);
    FormatError when the segment ends after the trial.
    """
    if trial.span is None:
        return found
    n = min(len(f["acc"]) for f in found.values())
    start, stop = (int(round(t * fs_hz)) for t in trial.span)
    if stop > n:
        raise FormatError(
            f"{trial.where}: end_s {trial.span[1]:g} is after the trial's last sample "
            f"({n / fs_hz:.2f} s at {fs_hz:g} Hz)"
        )
    cut = slice(start, stop)
    return {
        s: {**f, "acc": f["acc"][cut], "gyr": f["gyr"][cut]}
        | {"quat": None if f["quat"] is None else f["quat"][cut]}
        for s, f in found.items()
    }


#: a rate given by hand is refused when the recordings imply one more than this factor away
#: (measured false alarms and catches: config/README.md, the table of checks)
RATE_MISMATCH = 1.25
#: the factor between a gyroscope's deg/s and rad/s: an implied rate that far off is a unit error
DEG_PER_RAD = float(np.degrees(1.0))


def check_declared_rate(recordings: list[dict], fs_hz: float, report: ImportReport) -> None:
    """Check a rate given by hand against the recordings (:mod:`aceval.signals.rate_check`):
    FormatError when the rate their gyroscopes and accelerometers agree at is more than
    :data:`RATE_MISMATCH` times off, a note saying what was found otherwise. ``recordings``:
    each recording's ``{sensor: {acc, gyr, ...}}`` as read at ``fs_hz``.
    """
    from aceval.signals.rate_check import combined_rate, implied_rate

    evidence = [
        implied_rate([(f["acc"], f["gyr"]) for f in found.values()], fs_hz) for found in recordings
    ]
    implied = combined_rate(evidence)
    judged = [e for e in evidence if np.isfinite(e.implied_hz)]
    if not judged:
        report.note(
            f"the rate given by hand ({fs_hz:g} Hz) could not be checked against the recordings "
            "(no walking or other periodic movement in them)"
        )
        return
    strides = np.nanmedian([e.stride_hz for e in judged])
    found = (
        f"the gyroscopes and accelerometers of {len(judged)} of {len(recordings)} recording(s) "
        f"agree at {implied:.3g} Hz (median over {sum(e.n_sensors for e in judged)} sensors; "
        f"their movement repeats (a stride, or a step) {strides:.2f} times a second at "
        f"{fs_hz:g} Hz, {strides * implied / fs_hz:.2f} at {implied:.3g} Hz)"
    )
    factor = max(implied / fs_hz, fs_hz / implied)
    if factor > RATE_MISMATCH:
        units = (
            f" Or the gyroscope's units: {factor:.3g} is near {DEG_PER_RAD:.1f}, the degrees in a "
            "radian (rad/s read as deg/s, or the reverse: check the mapping's or the exports' "
            "units)"
            if abs(np.log(factor / DEG_PER_RAD)) < np.log(RATE_MISMATCH)
            else ""
        )
        raise FormatError(
            f"the rate given by hand, {fs_hz:g} Hz, does not fit the recordings: {found}. Check "
            "the rate the exports were recorded at (the device's settings) and give that one."
            + units
        )
    report.note(f"the rate given by hand, {fs_hz:g} Hz, fits the recordings: {found}")
