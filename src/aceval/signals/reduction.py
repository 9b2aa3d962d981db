"""One pass over the recordings: each file is read once, checked, and reduced to the small
statistics that every analysis needs (docs/design.md, "One pass").

* ``summaries``, one row per recording that calibrates something (:func:`summarise`): static
  tests give z0 (Kong Eq. 2); motion tests every sufficient statistic the registry's methods
  declare (:mod:`aceval.methods.sufficient`: Kong's scatter ``sum a a^T`` of the trimmed
  accelerations, Eq. 3, whose sum over repetitions is their union's; the moments of the unit
  gyroscope samples, Ricci Eq. 1-2; the step-band scatter of walking), run by their own
  ``reduce`` (this pass imports no method), and the plausibility moments of
  :mod:`aceval.signals.checks`;
  every motion recording also its place in the test among the other sensors of its set
  (:mod:`aceval.signals.signatures`). A motion recording of a test that does not calibrate its IMU gets a
  row of kind ``extra`` with its typical speed only.
* ``pairs``, one row per time-aligned recording pair of Kong's Obj 1-2 (the same IMU in the two
  sensor sets; two segments moved as one body), per signal and window: the sample count, both
  means, both centred scatters and the centred cross-moment of the overlap. The Pearson
  correlation of the pair after any two calibrations follows from these alone
  (:func:`aceval.evaluation.objectives.correlation_from_moments`): nothing reads the samples again.
* ``report``: every file problem with its file, line and cause, as ``aceval validate`` gives it.

Recordings are read grouped by test and repetition (the pairs of Obj 1-2 never cross them), so
a subject's memory is one repetition of one test at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from aceval.data.contract import SHORT_RECORDING_S, Recording, ValidationReport
from aceval.data.dataset import Dataset
from aceval.data.errors import CalibrationError, SaturatedError, TooShortError
from aceval.data.recording_checks import (
    gyro_units_doubt,
    known_recordings,
    plateau_limit,
    read_checked,
    vendor_up,
)
from aceval.data.rotations import axis_vector, vector_angle_deg
from aceval.methods import registry
from aceval.methods.moments import recording_moments, vertical_axis
from aceval.signals.alignment import aligned, pooled_lag
from aceval.signals.checks import (  # the pair moments' columns: a: first recording, b: second
    C_AA,
    C_AB,
    C_BB,
    GYRO_THIRD,
    MEAN_A,
    MEAN_B,
    MIN_STILL_S,
    STILL_COLUMNS,
    agreement_moments,
    recording_signals,
)
from aceval.signals.gait_sign import GAIT_SIGN
from aceval.signals.segmentation import TrimParams, mask_to_ranges, movement_mask
from aceval.signals.signatures import motion_signatures, sagittal_rate, speed_envelope

#: a motion recording is left out when more than this fraction of its moving samples is clipped at
#: the accelerometer range (a choice, not from the papers: the clipped samples themselves are always
#: left out of the scatter, and beyond a fifth of them the plane rests on a biased remainder)
MAX_CLIPPED_FRACTION = 0.2
#: an aligned pair sharing fewer than this share of the shorter recording is not correlated
MIN_OVERLAP = 0.5
PAIR_COLUMNS = [
    "objective",
    "subject",
    "sensor_set",
    "imu",
    "imu_b",
    "test",
    "rep",
    "lag_samples",
    "n_overlap",
    "flag",
    "signal",
    "window",
    "n",
    *MEAN_A,
    *MEAN_B,
    *C_AA,
    *C_BB,
    *C_AB,
]


@dataclass
class Reduction:
    """What one pass over a set of recordings leaves: see the module docstring."""

    summaries: pd.DataFrame
    pairs: pd.DataFrame
    report: ValidationReport


def reduce_recordings(
    dataset: Dataset,
    subject: str | None = None,
    trim: TrimParams = TrimParams(),
    tests: list[str] | None = None,
    segment_pairs: dict | None = None,
    max_lag_s: float = 0.5,
    memory: dict | None = None,
) -> Reduction:
    """Read every recording of ``subject`` (all subjects if None) once: check it, summarise it
    and reduce the Obj 1-2 pairs it belongs to. ``tests``: only these motion tests (static tests
    always); ``segment_pairs`` as in config ``objectives.segment_pairs``; ``max_lag_s``: the
    window of the time alignment of a pair (Kong Sec. 2.3); ``memory``: recordings.tsv path ->
    the file's (N, 7) values, for recordings the caller holds already (simulated in the same
    process: exactly what the file reads back); each is taken out of it as it is used.
    """
    recordings = known_recordings(dataset)
    if subject is not None:
        recordings = recordings[recordings["subject"] == subject]
    static = set(dataset.static_tests())
    if tests is not None:
        recordings = recordings[recordings["test"].isin(static | set(tests))]
    allowed = set(map(tuple, dataset.calibrates[["test", "imu"]].to_numpy()))
    findings: dict[int, list] = {}
    summaries: dict[int, dict] = {}
    pairs: list[dict] = []
    max_lag = int(round(max_lag_s * dataset.fs_hz))
    pair_imus = segment_pair_imus(dataset, segment_pairs or {})
    records = dict(zip(recordings.index, recordings.to_dict("records")))  # one conversion
    statistics = motion_statistics()
    per_test = [s for s in statistics if s.reduce_test is not None]
    walking: dict[tuple, list] = {}  # (subject, test) -> its recordings, until all are read
    unread = recordings.groupby(["subject", "test"]).size().to_dict()
    for (subj, test, rep), group in recordings.groupby(["subject", "test", "rep"], sort=False):
        loaded: dict[tuple[str, str], tuple[Recording, np.ndarray]] = {}
        by_set: dict[str, dict] = {}
        for index in group.index:
            rec = records[index]
            report = ValidationReport(dataset.name)
            is_static = rec["test"] in static
            needed = is_static or (rec["test"], rec["imu"]) in allowed
            values = memory.pop(rec["path"], None) if memory else None
            kind = (is_static, needed)
            data, moving, summary = _read(dataset, rec, report, kind, trim, statistics, values)
            findings[index] = report.findings
            if summary is not None:
                summaries[index] = summary
            if data is None:
                continue
            if moving is not None and any(
                s.test_phase == dataset.first_phase(test) for s in per_test
            ):
                usable = needed and not summaries[index]["flag"]
                segment = dataset.places[(rec["sensor_set"], rec["imu"])][0]
                walking.setdefault((subj, test), []).append(
                    (index if usable else None, data.acc, moving, segment, int(rep))
                )  # the ones not calibrated here still tell the step frequency
            if not is_static:
                mask = moving if moving is not None else np.zeros(len(data.t), dtype=bool)
                loaded[(rec["sensor_set"], rec["imu"])] = (data, mask)
                if not needed:
                    summaries[index] = _extra_row(rec, data)
                by_set.setdefault(rec["sensor_set"], {})[rec["imu"]] = (index, data)
        if test not in static and loaded:
            pairs += _pair_rows(dataset, subj, test, int(rep), loaded, pair_imus, max_lag)
            _add_signatures(dataset, test, by_set, summaries)
        unread[(subj, test)] -= len(group)
        if not unread[(subj, test)] and (subj, test) in walking:  # its last repetition: pool them
            read = walking.pop((subj, test))
            for statistic in per_test:
                if statistic.test_phase == dataset.first_phase(test):
                    statistic.reduce_test(read, dataset.fs_hz, summaries)
    report = ValidationReport(dataset.name)
    report.findings = [f for k in sorted(findings) for f in findings[k]]  # in the sheet's order
    ordered = [summaries[k] for k in sorted(summaries)]
    return Reduction(pd.DataFrame(ordered), pd.DataFrame(pairs, columns=PAIR_COLUMNS), report)


def _read(dataset, rec, report, kind, trim, statistics, values) -> tuple:
    """``(recording, moving mask, summary)`` of one recording (``kind``: (static, needed)):
    read (``values``: the file's, when the caller holds them) and checked (its problems in
    ``report``), its movement found (motion tests; None where the trimmer finds none) and, where
    an analysis ``needed`` it, its summary row (:func:`summarise`; an unreadable file's row says
    why). The recording is None where it cannot be read, the summary where it is not needed.
    """
    is_static, needed = kind
    data = read_checked(dataset, rec, report, values)
    if data is None:
        cause = {"flag": "unreadable", "message": f"{rec['path']}: {report.errors[0].cause}"}
        return None, None, _row(rec, is_static) | cause if needed else None
    moving = None
    if not is_static:
        try:
            moving = movement_mask(data.gyr, dataset.fs_hz, trim)
        except CalibrationError:
            moving = None
    summary = summarise(dataset, rec, data, moving, is_static, trim, statistics) if needed else None
    return data, moving, summary


def motion_statistics() -> list:
    """The statistics the pass computes of every motion recording: those the registry's methods
    declare (:func:`aceval.methods.registry.statistics`), then the direction checks' third
    moments (:data:`aceval.signals.checks.GYRO_THIRD`) and the walking sign cues
    (:data:`aceval.signals.gait_sign.GAIT_SIGN`).
    """
    return [*registry.statistics(), GYRO_THIRD, GAIT_SIGN]


def summarise_recordings(
    dataset: Dataset,
    subject: str | None = None,
    trim: TrimParams = TrimParams(),
    tests: list[str] | None = None,
) -> pd.DataFrame:
    """One summary row per recording of ``subject`` (all subjects if None) that some analysis
    needs (:func:`summarise`); ``tests``: only these motion tests. The recording pairs and file
    findings of the same pass are in :func:`reduce_recordings`.
    """
    return reduce_recordings(dataset, subject, trim, tests).summaries


def _extra_row(rec: dict, data: Recording) -> dict:
    """A motion recording of a test that does not calibrate its IMU (kind ``extra``): read for
    the Obj 1-2 pairs, it gives the IMU's typical speed there to :mod:`aceval.signals.signatures`.
    """
    return _row(rec, False) | {
        "kind": "extra",
        "calibrates": False,
        "gyro_p90_deg_s": typical_speed_deg_s(data.gyr),
    }


def typical_speed_deg_s(gyr: np.ndarray) -> float:
    """A recording's typical angular speed (deg/s): the 90th percentile of |gyr| (rad/s)."""
    return float(np.degrees(np.percentile(np.linalg.norm(gyr, axis=1), 90)))


def _add_signatures(dataset: Dataset, test: str, loaded: dict, summaries: dict):
    """The :mod:`aceval.signals.signatures` columns of one repetition's motion recordings, per set
    (``loaded``: set -> IMU -> (summary index, :class:`Recording`)).
    """
    walking = dataset.first_phase(test) == "gait"
    fs = dataset.fs_hz
    for sensor_set, by_imu in loaded.items():
        places = {imu: dataset.places[(sensor_set, imu)] for imu in by_imu}
        rates = {
            imu: sagittal_rate(d.t, d.gyr, fs, axis_vector(dataset.right_axis(sensor_set, imu)))
            for imu, (_, d) in by_imu.items()
        }
        found = motion_signatures(
            {imu: speed_envelope(d.t, d.gyr, fs) for imu, (_, d) in by_imu.items()},
            places,
            rates if walking else None,
        )
        for imu, (index, _) in by_imu.items():
            if index in summaries:
                summaries[index].update(found[imu])


def _row(rec: dict, is_static: bool) -> dict:
    row = {k: rec[k] for k in ["subject", "sensor_set", "test", "rep", "imu"]}
    return row | {"kind": "static" if is_static else "motion", "flag": "", "message": ""}


def summarise(
    dataset: Dataset,
    rec: dict,
    data: Recording,
    moving: np.ndarray | None,
    is_static: bool,
    trim: TrimParams = TrimParams(),
    statistics: list | None = None,
) -> dict:
    """The summary row of one recording (module docstring). Static tests: ``z0_x, z0_y, z0_z``
    and the unit moments of the accelerometer. Motion tests: ``n_samples`` kept by the trimmer
    (``moving``; None when it found no movement), ``kept``, the half-open sample ranges of those
    samples ('a:b;c:d', what the peers read too), and the columns of every statistic of
    ``statistics`` (default :func:`motion_statistics`) reduced from them (Kong's scatter
    ``s11..s33`` in m^2/s^4, ...); a statistic computed per test (the step-harmonic scatter of
    walking) is added once all repetitions of the subject's test are read. Samples clipped at
    the declared accelerometer range, or at a plateau found in the data (``n_clipped``), carry a
    wrong direction and are left out of the scatter; above :data:`MAX_CLIPPED_FRACTION` the
    recording is left out. A recording that cannot be used gets ``flag`` (the error code) and
    ``message`` naming the file.
    """
    row = _row(rec, is_static)
    try:
        if is_static:
            row.update(recording_signals(data.acc, data.gyr, None, data.faults)[0])
            row.update(zip(["z0_x", "z0_y", "z0_z"], vertical_axis(data.acc)))
            up = vendor_up(data.path)  # the vendor's orientation, when the file has one
            row["vendor_up_angle_deg"] = (
                np.nan if up is None else float(vector_angle_deg(up, -vertical_axis(data.acc)))
            )
            row["n_samples"] = len(data.acc)
            row.update(recording_moments(data.acc, dataset.fs_hz, motion=False))
            return row
        row.update(agreement_moments(data.acc, data.gyr, dataset.fs_hz))
        row["calibrates"] = True
        row["gyro_p90_deg_s"] = typical_speed_deg_s(data.gyr)
        if (duration := float(data.t[-1] - data.t[0])) < SHORT_RECORDING_S:
            raise TooShortError(
                f"{duration:.2f} s long, shorter than {SHORT_RECORDING_S:g} s: a part of a "
                "repetition, not a whole one (a cut file?)"
            )
        mask = moving if moving is not None else movement_mask(data.gyr, dataset.fs_hz, trim)
        rest = _still(dataset, data, mask, row)
        signals, spikes = recording_signals(data.acc, data.gyr, rest, data.faults)
        row.update(signals)
        limit = dataset.acc_limit(rec["sensor_set"], rec["imu"])
        if limit is None and (plateau := plateau_limit(data.acc)) is not None:
            limit, row["clipping_from_data"] = plateau, True  # clipped at a range nobody declared
        clipped = mask & (np.abs(data.acc) >= limit).any(axis=1) if limit else np.zeros_like(mask)
        row["n_clipped"] = int(clipped.sum())
        if row["n_clipped"] > MAX_CLIPPED_FRACTION * mask.sum():
            raise SaturatedError(
                f"{row['n_clipped']} of {int(mask.sum())} moving samples are clipped at "
                f"the accelerometer range (more than {MAX_CLIPPED_FRACTION:.0%})"
            )
        mask = mask & ~clipped & ~spikes  # single-sample spikes: beyond any body's motion
        row["n_samples"] = int(mask.sum())
        kept = mask_to_ranges(mask)
        row["n_segments"] = len(kept)
        row["kept"] = ";".join(f"{a}:{b}" for a, b in kept)  # what the peers are given too
        for statistic in motion_statistics() if statistics is None else statistics:
            if statistic.reduce is not None:
                row.update(statistic.reduce(data.acc, data.gyr, mask, dataset.fs_hz))
    except CalibrationError as exc:
        doubt = ""  # a gyroscope that reads far too little: its units, named where it moved
        if exc.code == "no_movement":
            peak = float(np.degrees(np.linalg.norm(data.gyr, axis=1).max()))
            units = dataset.meta["units"]["gyr"]
            doubt = gyro_units_doubt(peak, data.acc, dataset.fs_hz, units)
        row.update(flag=exc.code, message=f"{rec['path']}: {exc}" + (f"; {doubt}" if doubt else ""))
    return row


def _still(dataset: Dataset, data: Recording, mask: np.ndarray, row: dict) -> np.ndarray:
    """The vertical of a motion recording's still portions (the samples outside the movement
    ``mask``: standing before, between and after the movements), added to its summary ``row``
    (NaN where they are too short); returns those samples where they are enough to tell the
    gyroscope's offset at rest (none else).
    """
    still = ~mask
    enough = still.sum() >= MIN_STILL_S * dataset.fs_hz
    row.update(zip(STILL_COLUMNS, vertical_axis(data.acc[still]) if enough else np.full(3, np.nan)))
    return still if enough else still & False


def _pair_rows(
    dataset: Dataset,
    subject: str,
    test: str,
    rep: int,
    loaded: dict,
    pair_imus: dict,
    max_lag: int,
) -> list[dict]:
    """The Obj 1 and Obj 2 pairs among one repetition's recordings (``loaded``: (set, IMU) ->
    (recording, moving mask)): Obj 1 the same IMU in the first two sensor sets, acceleration and
    angular velocity; Obj 2 the IMU pairs ``pair_imus`` lists for the test (:func:`segment_pair_imus`:
    two segments on the same side of one set), acceleration.
    """
    rows = []
    sets = list(dataset.meta["sensor_sets"])
    base = {"subject": subject, "test": test, "rep": rep}
    common = [i for s, i in loaded if len(sets) == 2 and s == sets[0] and (sets[1], i) in loaded]
    if common:
        pairs = [(loaded[(sets[0], imu)], loaded[(sets[1], imu)]) for imu in common]
        magnitudes = [
            (getattr(a, q), getattr(b, q)) for (a, _), (b, _) in pairs for q in ("acc", "gyr")
        ]
        lag = pooled_lag(magnitudes, max_lag)
        at_bound = max_lag > 0 and abs(lag) == max_lag  # the true offset may lie beyond
        for imu, (first, second) in zip(common, pairs):
            rows += pair_moments(
                first,
                second,
                {
                    **base,
                    "objective": "frontal_lateral",
                    "sensor_set": "|".join(sets),
                    "imu": imu,
                    "imu_b": "",
                },
                ("acc", "gyr"),
                lag,
                "lag_at_bound" if at_bound else "",
            )
    return rows + _segment_pair_rows(loaded, pair_imus, base)


def segment_pair_imus(dataset: Dataset, segment_pairs: dict) -> dict[str, list[tuple]]:
    """``{test: [(sensor_set, imu_a, imu_b), ...]}``: the IMU pairs of each test's Obj 2 segment
    pairs (``segment_pairs`` as in config ``objectives.segment_pairs``: the IMUs of the two
    segments on the same side of one set), each pair once however many specs name it.
    """
    imus = dataset.imus.reset_index()
    out: dict[str, list[tuple]] = {}
    for spec in segment_pairs.values():
        seg_a, seg_b = spec["segments"]
        matched = imus[imus["segment"] == seg_a].merge(
            imus[imus["segment"] == seg_b], on=["sensor_set", "side"], suffixes=("_a", "_b")
        )
        pairs = list(matched[["sensor_set", "imu_a", "imu_b"]].itertuples(index=False, name=None))
        for test in spec["t_ap"]:
            known = out.setdefault(test, [])
            known += [pair for pair in pairs if pair not in known]
    return out


def _segment_pair_rows(loaded, pair_imus: dict, base) -> list[dict]:
    """Obj 2 pairs of :func:`_pair_rows` (``pair_imus``: :func:`segment_pair_imus`)."""
    rows = []
    for sensor_set, imu_a, imu_b in pair_imus.get(base["test"], []):
        if (sensor_set, imu_a) in loaded and (sensor_set, imu_b) in loaded:
            rows += pair_moments(
                loaded[(sensor_set, imu_a)],
                loaded[(sensor_set, imu_b)],
                {
                    **base,
                    "objective": "segment_pair",
                    "sensor_set": sensor_set,
                    "imu": imu_a,
                    "imu_b": imu_b,
                },
                ("acc",),
                0,  # one set, one clock: no offset
            )
    return rows


def pair_moments(first, second, base: dict, signals: tuple, lag: int, flag: str = "") -> list[dict]:
    """Rows of :data:`PAIR_COLUMNS` for two recordings ((recording, moving mask) each) aligned in
    time by ``lag`` (samples; ``a[t + lag]`` matches ``b[t]``: one offset per repetition between
    the two sensor sets, :func:`aceval.signals.alignment.pooled_lag`, Kong Sec. 2.3; 0 inside one
    set), then, per signal, the moments of the overlap (window ``all``) and of the samples either
    sensor's trimmer keeps as movement (``moving``). A pair overlapping less than
    :data:`MIN_OVERLAP` of the shorter recording is flagged ``no_overlap``, one whose offset sits
    at the search bound ``flag`` ('lag_at_bound'); either has no moments.
    """
    (a, moving_a), (b, moving_b) = first, second
    part_a, part_b = aligned(len(a.t), len(b.t), lag)
    n = part_b.stop - part_b.start
    common = {**base, "lag_samples": lag, "n_overlap": n, "flag": ""}
    if n < MIN_OVERLAP * min(len(a.t), len(b.t)):
        flag = "no_overlap"
    if flag:
        return [{**common, "signal": s, "window": "all", "flag": flag, "n": 0} for s in signals]
    moving = moving_a[part_a] | moving_b[part_b]
    rows = []
    for signal in signals:
        x, y = getattr(a, signal)[part_a], getattr(b, signal)[part_b]
        for window, keep in (("all", slice(None)), ("moving", moving)):
            rows.append({**common, "signal": signal, "window": window, **moments(x[keep], y[keep])})
    return rows


def moments(x: np.ndarray, y: np.ndarray) -> dict:
    """``n``, both means and the centred scatters and cross-moment of two (n, 3) signals."""
    n = len(x)
    if n == 0:
        return {"n": 0}
    mean_x, mean_y = x.mean(axis=0), y.mean(axis=0)
    dx, dy = x - mean_x, y - mean_y
    return {
        "n": n,
        **dict(zip(MEAN_A, mean_x)),
        **dict(zip(MEAN_B, mean_y)),
        **dict(zip(C_AA, (dx.T @ dx).ravel())),
        **dict(zip(C_BB, (dy.T @ dy).ravel())),
        **dict(zip(C_AB, (dx.T @ dy).ravel())),
    }
