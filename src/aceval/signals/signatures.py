"""Is each sensor on the segment, side and movement the sheets say? Checks from the motion's
signature against the other sensors of the same test (beyond both papers).

A sensor whose recordings carry another segment's motion (two sensors' labels exchanged, a left
sensor listed as right) or a movement other than the test (random 3-D motion) gives a calibration
that Kong's and Ricci's own limits can pass. Every sensor of one sensor set in one repetition of a
test is recorded on one clock, so its motion can be compared with the others':

* **Timing** (``timing_r``): the angular-speed envelope (|gyr| averaged over :data:`ENVELOPE_S`)
  of a sensor that a test calibrates rises and falls with that of at least one other sensor
  recorded in the test (one movement moves them together). Not judged in walking, where the two legs
  alternate and the thigh's speed peaks twice a stride (on HuGaDB it fell to 0.16-0.27 on clean
  thighs). The best Pearson correlation with them,
  median over the repetitions, below :data:`MIN_TIMING_R` flags that test's calibrations of the
  IMU ``not_moving_with_others``.
* **Pattern** (``gyro_p90_deg_s`` of every motion recording, also of tests that do not calibrate
  the IMU): calibrates.tsv says which segments a test moves. A sensor that moves in a test that
  does not calibrate it (its typical speed more than :data:`MAX_OTHER_SPEED_RATIO` of the median
  of the test's calibrated sensors) flags every calibration of the IMU
  ``unexpected_motion_pattern``: a sensor on another segment than its row says? Judged only where
  the lab recorded the IMU in a test that does not calibrate it. The converse (a sensor that
  hardly moves in a test that calibrates it) is not a flag: a pelvis in walking moves at
  0.15-0.22 of the legs' speed (qmt, NeuRA), as slowly as a thigh in bowing.
* **Side** (``side_votes``, ``side_evidence``): in walking a leg's segments swing together, half a
  stride from the other leg's. For a sensor with a side and each other segment worn on both sides,
  the envelope correlates better with the same side's sensor (a vote +1) or the other side's
  (-1). More votes against than for, summed over the repetitions and at least
  :data:`MIN_SIDE_EVIDENCE` votes, flags every calibration ``opposite_side_timing``: a left
  sensor listed as right? The vote is cast on the swing signed by the declared right axis; the
  same vote on the angular-speed envelope, which has no sign (``speed_side_votes``), tells a
  sensor on the other leg (both vote against) from a swing whose sign alone is reversed (the
  speed votes for its side): a gyroscope with one axis negated (left-handed) or a right axis
  declared with the wrong sign, flagged ``swing_reversed`` instead; where the speed does not
  tell (its votes even), the message names both causes.

The limits and the rates measured with them are in config/README.md's table of checks
(``python benchmarks/check_rates.py``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d

#: the angular-speed envelope: |gyr| averaged over this window (s), compared at this rate (Hz)
ENVELOPE_S = 0.25
ENVELOPE_HZ = 20.0
#: the recordings of one test must overlap this long (s) for their envelopes to be compared
MIN_OVERLAP_S = 2.0
SIGNATURE_COLUMNS = ["timing_r", "side_votes", "side_evidence", "speed_side_votes"]
#: best envelope correlation with another sensor of the test (median over repetitions)
MIN_TIMING_R = 0.3
#: a sensor the test does not calibrate, against the median of the test's calibrated sensors
MAX_OTHER_SPEED_RATIO = 0.75
#: a recording's principal gyroscope axis within this angle (deg) of the declared right axis
#: gives its swing a sign (the side votes)
MAX_SWING_AXIS_DEG = 45.0
#: side votes (over the repetitions and the other segments) needed to judge the side
MIN_SIDE_EVIDENCE = 2
SIDES = ("left", "right")


def speed_envelope(t: np.ndarray, gyr: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, |gyr| averaged over :data:`ENVELOPE_S`) of one recording; any gyroscope units."""
    width = max(1, int(round(ENVELOPE_S * fs_hz)))
    return t, uniform_filter1d(np.linalg.norm(gyr, axis=1), width, mode="nearest")


def sagittal_rate(
    t: np.ndarray, gyr: np.ndarray, fs_hz: float, right: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """(t, the angular velocity about the recording's principal gyroscope axis, signed towards the
    declared right axis ``right`` (3,) and averaged over :data:`ENVELOPE_S`): the segment's
    forward and backward swing in walking. None when that axis is more than
    :data:`MAX_SWING_AXIS_DEG` from ``right`` (its sign then says nothing: e.g. a strap wobbling
    about the thigh's long axis).
    """
    _, vectors = np.linalg.eigh(gyr.T @ gyr)
    cosine = float(vectors[:, -1] @ right)
    if abs(cosine) < np.cos(np.radians(MAX_SWING_AXIS_DEG)):
        return None
    axis = vectors[:, -1] * np.sign(cosine)
    width = max(1, int(round(ENVELOPE_S * fs_hz)))
    return t, uniform_filter1d(gyr @ axis, width, mode="nearest")


def envelope_correlations(
    envelopes: dict[str, tuple[np.ndarray, np.ndarray]],
) -> tuple[list[str], np.ndarray]:
    """``(names, r)``: the Pearson correlations ``r`` (IMU x IMU, in the order of ``names``,
    sorted) of the (t, series) of one sensor set's recordings of one repetition, on a common
    :data:`ENVELOPE_HZ` grid over their overlap in time; no names when they overlap less than
    :data:`MIN_OVERLAP_S`.
    """
    names = sorted(envelopes)
    start = max(envelopes[n][0][0] for n in names)
    end = min(envelopes[n][0][-1] for n in names)
    if len(names) < 2 or end - start < MIN_OVERLAP_S:
        return [], np.zeros((0, 0))
    grid = np.arange(start, end, 1.0 / ENVELOPE_HZ)
    series = np.array([np.interp(grid, *envelopes[n]) for n in names])
    with np.errstate(invalid="ignore", divide="ignore"):
        return names, np.corrcoef(series)


def motion_signatures(
    envelopes: dict[str, tuple[np.ndarray, np.ndarray]],
    places: dict[str, tuple[str, str]],
    rates: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
) -> dict[str, dict]:
    """``SIGNATURE_COLUMNS`` of each IMU of one sensor set's recordings of one repetition.

    ``envelopes``: IMU -> :func:`speed_envelope`; ``places``: IMU -> (segment, side);
    ``rates``: IMU -> :func:`sagittal_rate`, given for walking (the test's ``first_phase`` is
    gait): there the side votes are cast, and the timing is not judged (the legs alternate).
    """
    out = {imu: dict.fromkeys(SIGNATURE_COLUMNS, np.nan) for imu in envelopes}
    names, r = envelope_correlations(envelopes)
    if not names:
        return out
    if rates is None:  # timing: not in walking, where the two legs alternate
        for k, imu in enumerate(names):
            others = np.delete(r[k], k)
            others = others[np.isfinite(others)]  # a still sensor's envelope correlates with none
            out[imu]["timing_r"] = float(others.max()) if len(others) else np.nan
        return out
    signed = {imu: rate for imu, rate in rates.items() if rate is not None}
    swing_names, swing = envelope_correlations(signed) if len(signed) > 1 else ([], None)
    for imu in signed:
        if swing_names:
            out[imu].update(_side_votes(imu, swing_names, swing, places))
            speed = _side_votes(imu, names, r, places).get("side_votes", np.nan)
            out[imu]["speed_side_votes"] = speed
    return out


def _side_votes(
    imu: str, names: list[str], r: np.ndarray, places: dict[str, tuple[str, str]]
) -> dict:
    segment, side = places[imu]
    if side not in SIDES:
        return {}
    votes = evidence = 0
    at = {name: k for k, name in enumerate(names)}
    by_place = {places[o]: o for o in names if o != imu}
    other_side = SIDES[1 - SIDES.index(side)]
    for other_segment in {s for s, _ in by_place} - {segment}:
        same, opposite = (
            by_place.get((other_segment, side)),
            by_place.get((other_segment, other_side)),
        )
        if same is None or opposite is None:
            continue
        r_same, r_opposite = r[at[imu], at[same]], r[at[imu], at[opposite]]
        if np.isfinite(r_same) and np.isfinite(r_opposite):
            votes += 1 if r_same > r_opposite else -1
            evidence += 1
    return {"side_votes": votes, "side_evidence": evidence}


def signature_verdicts(motion: pd.DataFrame) -> dict[tuple, dict]:
    """Per (subject, set, IMU): ``flag`` (''; or the checks' flags joined by ';'), ``message``,
    ``test_flags`` (test -> 'not_moving_with_others' for the tests whose calibrations it flags)
    and the evidence (``timing_r`` per test, ``speed_ratio`` extremes, ``side_votes``).

    ``motion``: one row per motion recording (summaries and the rows of kind ``extra``), with
    ``calibrates`` (bool: the test calibrates the IMU), ``gyro_p90_deg_s`` and
    ``SIGNATURE_COLUMNS``.
    """
    key = ["subject", "sensor_set", "imu"]
    speed = motion.groupby(key + ["test", "calibrates"], as_index=False)["gyro_p90_deg_s"].median()
    reference = (
        speed[speed["calibrates"]].groupby(["subject", "sensor_set", "test"])["gyro_p90_deg_s"]
    ).agg(["median", "size"])
    speed = speed.join(reference, on=["subject", "sensor_set", "test"])
    speed["ratio"] = speed["gyro_p90_deg_s"] / speed["median"]
    judged = speed["size"] >= 2  # a median of one sensor is that sensor itself
    moves = judged & ~speed["calibrates"] & (speed["ratio"] > MAX_OTHER_SPEED_RATIO)
    calibrated = motion[motion["calibrates"]]
    timing: dict[tuple, list] = {}
    for (*k, test), r in calibrated.groupby(key + ["test"])["timing_r"].median().items():
        timing.setdefault(tuple(k), []).append((test, r))
    voted = [c for c in SIGNATURE_COLUMNS[1:] if c in motion]
    side = motion.groupby(key)[voted].sum(min_count=1).reindex(columns=SIGNATURE_COLUMNS[1:])
    side = dict(zip(side.index, side.to_numpy(float)))
    moving: dict[tuple, list] = {}
    for row in speed[moves].itertuples(index=False):
        moving.setdefault((row.subject, row.sensor_set, row.imu), []).append(row)
    out = {}
    for k in speed[key].drop_duplicates().itertuples(index=False, name=None):
        out[k] = _verdict(moving.get(k, []), *side.get(k, (np.nan,) * 3), timing.get(k, []))
    return out


def _verdict(moving: list, votes: float, evidence: float, speed_votes: float, timing: list) -> dict:
    """:func:`signature_verdicts` of one IMU from its rows that move in a test that does not
    calibrate it (``moving``), its side ``votes``, ``evidence`` and ``speed_votes`` (its angular
    speed's), and its median timing correlation per test it is calibrated in (``timing``:
    [(test, r), ...]).
    """
    messages, flags = [], []
    for row in moving:
        messages.append(
            f"moves in {row.test}, a test that does not calibrate it ({row.gyro_p90_deg_s:.0f} "
            f"deg/s, {row.ratio:.2f} of the median of the sensors the test calibrates)"
        )
    if messages:
        flags.append("unexpected_motion_pattern")
        messages[-1] += ": on another segment than imus.tsv says (labels exchanged)?"
    if evidence >= MIN_SIDE_EVIDENCE and votes < 0 and speed_votes > 0:
        flags.append("swing_reversed")
        messages.append(
            f"in walking its swing runs against its side's segments ({votes:+.0f} over "
            f"{evidence:.0f} comparisons) while its angular speed rises and falls with them "
            f"({speed_votes:+.0f}): its swing's sign reversed rather than its side? (a "
            "gyroscope axis negated: a left-handed gyroscope; or right_axis with the wrong sign)"
        )
    elif evidence >= MIN_SIDE_EVIDENCE and votes < 0:
        flags.append("opposite_side_timing")
        sure = speed_votes < 0  # its speed, which has no sign, votes for the other side too
        messages.append(
            f"in walking it swings with the other side's segments ({votes:+.0f} over "
            f"{evidence:.0f} comparisons): on the other leg (left and right exchanged)?"
            + (
                ""
                if sure
                else " Or its swing's sign reversed (a gyroscope axis negated, right_axis "
                "with the wrong sign): its angular speed does not tell"
            )
        )
    test_flags = {}
    for test, r in timing:
        if r < MIN_TIMING_R:
            test_flags[test] = "not_moving_with_others"
            messages.append(
                f"in {test} its angular speed rises and falls with no other sensor the test "
                f"calibrates (best correlation {r:.2f} < {MIN_TIMING_R}): another movement than "
                "the test's?"
            )
    return {
        "flag": ";".join(flags),
        "message": "; ".join(messages),
        "test_flags": test_flags,
        "side_votes": votes,
    }
