"""Which sensor axis points to the subject's right: a proposal from the recordings.

``right_axis`` (imus.tsv) fixes the sign of Kong's y axis (Eq. 3) and is checked against every
calibration (``right_axis_mismatch``, ``backward``); a lab that does not know it can ask the
recordings, and learns where they cannot tell.

* **Which axis.** The normal of the plane of the IMU's trimmed accelerations in the tests that
  calibrate it (Kong Eq. 3, the method itself) is the medial-lateral line; the proposal is the
  sensor axis nearest to it. Determined where the normal is (smallest/middle eigenvalue at most
  :data:`MAX_NORMAL_RATIO`, Kong's limit), else where the gyroscope has a main rotation axis
  (middle/largest at most the same); *confirmed* when both are determined and agree. A trunk
  sensor in walking takes its direction from the inverted pendulum instead (below): its
  accelerations' plane is no sagittal plane there.
* **Which sign**, from a movement whose direction physics or the protocol fixes, as aceval's
  ``backward`` check judges it:

  - a test with a ``first_phase`` of ``-y`` or ``+y`` (bowing, sit-to-stand: -y; seated shank
    lift, leg swing: +y): the sign of each recording's first half-movement about the axis
    (:func:`aceval.methods.moments.first_phase_sign`);
  - walking (``gait``), a shank: it swings forward faster than it moves back, so the third
    moment (skew) of its angular velocity about the right axis is positive;
  - walking, a foot: from foot flat it pitches toe-down first and farther (push-off), then
    toe-up (:func:`aceval.signals.gait_sign.foot_pitch_votes`, one vote per stride); where no
    stride tells, its angular velocity rises and falls with that of the shank of its side
    (correlation positive; same sensor set and repetition, one clock), as a thigh's does;
  - walking, a trunk sensor (head, chest, waist, lower back): its forward acceleration opposes
    its upward velocity at each step (the inverted pendulum,
    :func:`aceval.signals.gait_sign.pendulum_right`), which gives the right direction itself;
  - walking, a thigh without a shank of its side: nothing (its swing is too symmetric): the
    proposal names the axis only (``+-z``) and says the data cannot tell the sign.

Each subject's recordings are judged apart and pooled only where they agree: subjects who wore
different sensors (or wore them differently) are named with their own answers, not averaged.
Measured on recordings whose right axes are known (``python benchmarks/check_right_axis.py``,
numbers in config/README.md): the verdict ``sure`` is what those measurements support, ``likely``
a weaker cue, ``undetermined`` none.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from aceval.data.errors import CalibrationError
from aceval.methods.moments import first_phase_sign
from aceval.signals.gait_sign import (
    FOOT_COLUMNS,
    MIN_PENDULUM_CORRELATION,
    STRENGTH_COLUMNS,
    TRUNK_COLUMNS,
    TRUNK_SEGMENTS,
    gait_right,
    walking_cues,
)
from aceval.signals.segmentation import TrimParams, movement_mask

#: Kong's limit on the plane normal (smallest/middle eigenvalue): above it the normal, and so the
#: medial-lateral axis, is undetermined (aceval.methods.kong.KongLimits.max_normal_ratio)
MAX_NORMAL_RATIO = 0.5
#: the shank's skew (normalised third moment about the axis) must be at least this far from 0
#: to give a sign (clean walking: 0.5-1.1 on every shank measured)
MIN_SKEW = 0.2
#: a foot's or thigh's correlation with its shank's swing: at least this gives a ``sure`` sign
#: (feet 0.81-0.90 on every recording measured), above 0 a ``likely`` one (thighs 0.07-0.55)
SURE_CORRELATION = 0.5
#: below this the correlation gives no sign at all
MIN_CORRELATION = 0.05
#: strides (foot) or walking recordings (trunk) that must agree, none against, for ``sure``
SURE_STRIDES, SURE_RECORDINGS = 3, 2
#: two subjects' right directions farther apart than this (deg) disagree
SUBJECTS_DISAGREE_DEG = 90.0


def recording_evidence(
    group: dict, first_phase: str, fs_hz: float, trim: TrimParams = TrimParams()
) -> dict:
    """Additive evidence of one time-aligned set of recordings (one subject, sensor set, test and
    repetition): ``group`` maps each IMU to ``(acc, gyr, segment, side)`` (SI, (N, 3)).

    Returns ``{imu: stats}``: ``n``, ``acc_scatter`` and ``gyr_scatter`` (3, 3) and ``gyr_third``
    (3, 3, 3) sums of the trimmed samples (Kong Fig. 5); in a test with a ``-y``/``+y`` first
    phase, ``phase_axis`` (the recording's gyroscope axis) and ``phase_sign`` (its first phase's
    sign about it); in walking, ``walking`` (:func:`aceval.signals.gait_sign.walking_cues` of the
    whole recording) and ``gait_right`` (the right direction it gives a foot or a trunk sensor,
    NaN where it does not tell); for a thigh or foot in walking, ``shank`` (the shank of its side)
    and the centred sums over their common samples ``cross`` (its angular velocity times the
    shank's), ``own`` and ``other`` (each one's own). A recording without movement gives nothing.
    """
    trimmed = {}
    for imu, (acc, gyr, segment, side) in group.items():
        try:
            mask = movement_mask(gyr, fs_hz, trim)
        except CalibrationError:
            continue
        trimmed[imu] = (acc[mask], gyr[mask], segment, side)
    shanks = {side: imu for imu, (*_, segment, side) in trimmed.items() if segment == "shank"}
    evidence = {}
    for imu, (acc, gyr, segment, side) in trimmed.items():
        stats = {
            "n": len(gyr),
            "acc_scatter": acc.T @ acc,
            "gyr_scatter": gyr.T @ gyr,
            "gyr_third": np.einsum("ni,nj,nk->ijk", gyr, gyr, gyr),
        }
        if first_phase in ("-y", "+y"):
            axis = np.linalg.eigh(gyr.T @ gyr)[1][:, 2]
            stats["phase_axis"], stats["phase_sign"] = axis, first_phase_sign(gyr, axis, fs_hz)
        if first_phase == "gait":
            cues = walking_cues(group[imu][0], group[imu][1], fs_hz)
            stats["walking"] = cues
            stats["gait_right"] = gait_right(
                np.array([segment]), *(np.array([[[cues[c] for c in cols]]]) for cols in _CUES)
            )[0, 0]
        if first_phase == "gait" and segment in ("thigh", "foot") and side in shanks:
            own, other = group[imu][1], group[shanks[side]][1]
            n = min(len(own), len(other))
            own, other = own[:n] - own[:n].mean(0), other[:n] - other[:n].mean(0)
            stats |= {"shank": shanks[side], "cross": own.T @ other}
            stats |= {"own": own.T @ own, "other": other.T @ other}
        evidence[imu] = stats
    return evidence


_CUES = (FOOT_COLUMNS, TRUNK_COLUMNS, STRENGTH_COLUMNS)


def _principal(scatter: np.ndarray, smallest: bool) -> tuple[np.ndarray, float]:
    """The principal axis of a scatter and the eigenvalue ratio that decides it: the smallest
    eigenvalue's (a plane's normal: smallest/middle) or the largest's (middle/largest).
    """
    values, vectors = np.linalg.eigh(scatter)
    if smallest:
        return vectors[:, 0], values[0] / values[1]
    return vectors[:, 2], values[1] / values[2]


def propose(units: list[dict], key=None) -> list[dict]:
    """The right axis the recordings propose, per ``key(unit)`` (default: the unit's sensor set
    and IMU; the Xsens import keys each sensor sheet line).

    ``units``: one dict per (subject, sensor_set, imu, test) with ``sensor_set``, ``imu``,
    ``segment``, ``subject``, ``test``, ``first_phase`` and ``stats``, a list of
    :func:`recording_evidence` values of its repetitions. Returns one dict per key: ``key``,
    ``sensor_set`` and ``imu`` (of its first unit), ``proposed`` ('+y'; '+-z' when only the axis
    is known; '' when not even that), ``direction`` (the measured right direction in the sensor
    frame, unit (3,), NaN when unknown), ``verdict`` ('sure', 'likely', 'undetermined'),
    ``sign_from`` (the cue that gave the sign, '' for none) and ``evidence`` (what was measured,
    in words).
    """
    key = key or (lambda unit: (unit["sensor_set"], unit["imu"]))
    units = {(u["subject"], u["sensor_set"], u["imu"], u["test"]): u for u in units if u["stats"]}
    axes = {k: _unit_axis(unit) for k, unit in units.items()}
    shank_right = {}  # the shanks first: a thigh's or foot's sign in walking may follow its shank's
    for k in sorted(units, key=lambda k: units[k]["segment"] != "shank"):
        axes[k] |= _unit_sign(units[k], axes[k], shank_right)
        if units[k]["segment"] == "shank" and axes[k]["level"]:
            shank_right[k] = axes[k]["sign"] * axes[k]["axis"]
    grouped = defaultdict(list)
    for k, unit in units.items():
        grouped[key(unit)].append((unit, axes[k]))
    return [_by_subject(k, found) for k, found in grouped.items()]


def _unit_axis(unit: dict) -> dict:
    """The medial-lateral line one unit's repetitions give (``axis``, unsigned; None when
    undetermined): a trunk sensor's in walking from the pendulum (signed: ``pendulum`` the
    correlations that gave it); else Kong's plane normal where determined, else the gyroscope's
    principal axis where that is; ``confirmed`` when both are determined and within 30 deg of
    each other, ``conflict`` when both are determined and further apart.
    """
    normal, ratio = _principal(sum(s["acc_scatter"] for s in unit["stats"]), smallest=True)
    gyro, gyro_ratio = _principal(sum(s["gyr_scatter"] for s in unit["stats"]), smallest=False)
    plane, turn = ratio <= MAX_NORMAL_RATIO, gyro_ratio <= MAX_NORMAL_RATIO
    close = abs(normal @ gyro) >= np.cos(np.radians(30.0))
    found = {"ratio": float(ratio), "gyro_ratio": float(gyro_ratio), "pendulum": []}
    if unit["first_phase"] == "gait" and unit["segment"] in TRUNK_SEGMENTS:
        told = [s for s in unit["stats"] if np.isfinite(s["gait_right"]).all()]
        found["pendulum"] = [s["walking"]["trunk_correlation"] for s in unit["stats"]]
        if not told:
            return found | {"axis": None, "confirmed": False, "conflict": False}
        direction = sum(s["gait_right"] for s in told)
        return found | {
            "axis": direction / np.linalg.norm(direction),
            "confirmed": False,
            "conflict": False,
        }
    axis = normal if plane else gyro if turn else None
    return found | {
        "axis": None if (plane and turn and not close) else axis,
        "plane": bool(plane),
        "confirmed": bool(plane and turn and close),
        "conflict": bool(plane and turn and not close),
    }


def _unit_sign(unit: dict, found: dict, shank_right: dict) -> dict:
    """``sign`` (+1/-1 about the unit's axis, 0 unknown), ``level`` ('sure', 'likely', ''),
    ``cue`` (what decided it, or why nothing did, in words) and ``source`` (the cue's name) of
    one unit.
    """
    axis, stats, phase = found["axis"], unit["stats"], unit["first_phase"]
    none = {"sign": 0.0, "level": "", "source": ""}
    if axis is None:
        return none | {"cue": "no axis"}
    if phase in ("-y", "+y"):
        return _phase_sign(stats, axis, phase)
    if phase != "gait":
        return none | {"cue": f"its test {unit['test']} has no first_phase (no known direction)"}
    segment = unit["segment"]
    if segment in TRUNK_SEGMENTS:
        return _pendulum_sign(found["pendulum"], len(stats))
    if segment == "shank":
        return _swing_sign(stats, axis)
    if segment == "foot":
        strides = _foot_sign(stats, axis)
        if strides["level"]:
            return strides
    shanked = _with_shank(unit, axis, shank_right)
    if segment == "foot" and not shanked["level"]:
        return shanked | {"cue": f"{strides['cue']}, and {shanked['cue']}"}
    return shanked


def _phase_sign(stats: list, axis: np.ndarray, phase: str) -> dict:
    """The sign of a ``-y``/``+y`` test: each repetition's first half-movement about ``axis``."""
    votes = np.array(
        [s["phase_sign"] * np.sign(s["phase_axis"] @ axis) for s in stats if s["phase_sign"]]
    )
    if not len(votes) or votes.sum() == 0:
        return {"sign": 0.0, "level": "", "source": "", "cue": "no first phase about it"}
    agree = float(np.mean(votes == np.sign(votes.sum())))
    protocol = -1.0 if phase == "-y" else 1.0  # the first phase about body y (the right axis)
    counts = (int(round(agree * len(votes))), len(votes))
    return {
        "sign": float(np.sign(votes.sum())) * protocol,
        "level": "sure" if agree >= 2 / 3 else "likely",
        "source": "first phase",
        "numbers": counts,
        "cue": _cue_text("first phase", [counts]),
    }


def _swing_sign(stats: list, axis: np.ndarray) -> dict:
    """A shank's sign in walking: it swings forward faster than back (skew about ``axis``)."""
    n = sum(s["n"] for s in stats)
    second = axis @ sum(s["gyr_scatter"] for s in stats) @ axis / n
    third = np.einsum("ijk,i,j,k->", sum(s["gyr_third"] for s in stats), axis, axis, axis) / n
    skew = float(third / second**1.5)
    if abs(skew) < MIN_SKEW:
        return {
            "sign": 0.0,
            "level": "",
            "source": "",
            "cue": f"its swing's skew {abs(skew):.2f} is below {MIN_SKEW} (forward and back alike)",
        }
    return {
        "sign": float(np.sign(skew)),
        "level": "sure",
        "source": "shank swing",
        "numbers": (abs(skew), len(stats)),
        "cue": _cue_text("shank swing", [(abs(skew), len(stats))]),
    }


def _foot_sign(stats: list, axis: np.ndarray) -> dict:
    """A foot's sign in walking: its strides' pitch from foot flat (toe-down first and farther)."""
    cues = [s["walking"] for s in stats]
    strides = sum(c["foot_strides_for"] + c["foot_strides_against"] for c in cues)
    told = [s for s in stats if np.isfinite(s["gait_right"]).all()]
    if not told:
        why = "no stride between two rests of the foot" if not strides else "its strides disagree"
        return {"sign": 0.0, "level": "", "source": "", "cue": f"its pitch tells nothing ({why})"}
    votes = {+1: 0, -1: 0}
    for s in told:
        sign = int(np.sign(s["gait_right"] @ axis))
        votes[sign] += int(s["walking"]["foot_strides_for"])
        votes[-sign] += int(s["walking"]["foot_strides_against"])
    sign = 1 if votes[1] >= votes[-1] else -1
    numbers = (votes[sign], votes[sign] + votes[-sign], len(told), len(stats))
    return {
        "sign": float(sign),
        "level": "sure" if votes[sign] >= SURE_STRIDES and not votes[-sign] else "likely",
        "source": "foot pitch",
        "numbers": numbers,
        "cue": _cue_text("foot pitch", [numbers]),
    }


def _pendulum_sign(correlations: list, n: int) -> dict:
    """A trunk sensor's sign in walking (its axis is the pendulum's signed direction already)."""
    told = [c for c in correlations if c >= MIN_PENDULUM_CORRELATION]
    if not told:
        best = max(correlations, default=0.0)
        return {
            "sign": 0.0,
            "level": "",
            "source": "",
            "cue": f"its forward acceleration does not follow the inverted pendulum (correlation "
            f"{best:.2f} at best, below {MIN_PENDULUM_CORRELATION})",
        }
    numbers = (min(told), max(told), len(told), n)
    return {
        "sign": 1.0,
        "level": "sure" if len(told) >= min(SURE_RECORDINGS, n) and len(told) == n else "likely",
        "source": "trunk pendulum",
        "numbers": numbers,
        "cue": _cue_text("trunk pendulum", [numbers]),
    }


def _with_shank(unit: dict, axis: np.ndarray, shank_right: dict) -> dict:
    """A thigh's or foot's sign in walking from its shank's: their angular velocities correlate."""
    none = {"sign": 0.0, "level": "", "source": ""}
    paired = [s for s in unit["stats"] if "shank" in s]
    if not paired:
        return none | {"cue": "walking gives no sign without a shank of its side"}
    shank = (unit["subject"], unit["sensor_set"], paired[0]["shank"], unit["test"])
    if shank not in shank_right:
        return none | {"cue": "its shank's swing gives no sign"}
    right = shank_right[shank]
    r = (axis @ sum(s["cross"] for s in paired) @ right) / np.sqrt(
        (axis @ sum(s["own"] for s in paired) @ axis)
        * (right @ sum(s["other"] for s in paired) @ right)
    )
    if abs(r) < MIN_CORRELATION:
        return none | {"cue": f"it hardly turns with its shank (r {r:+.2f})"}
    return {
        "sign": float(np.sign(r)),
        "level": "sure" if abs(r) >= SURE_CORRELATION else "likely",
        "source": "shank of its side",
        "numbers": (abs(r),),
        "cue": _cue_text("shank of its side", [(abs(r),)]),
    }


def _cue_text(source: str, numbers: list[tuple]) -> str:
    """What one cue measured over one or more units (``numbers``: each unit's), in words."""
    values = np.array(numbers, dtype=float)
    total = values.sum(axis=0)

    def span(column: int) -> str:
        low, high = values[:, column].min(), values[:, column].max()
        return f"{low:.2f}" if low == high else f"{low:.2f}-{high:.2f}"

    if source == "first phase":
        return f"the first half-movement of {total[0]:.0f} of {total[1]:.0f} repetitions"
    if source == "shank swing":
        return f"it swings forward faster than back (skew {span(0)}, {total[1]:.0f} recordings)"
    if source == "foot pitch":
        return (
            f"from foot flat it pitches toe-down first and farther, then toe-up, in "
            f"{total[0]:.0f} of {total[1]:.0f} strides ({total[2]:.0f} of {total[3]:.0f} walking "
            "recordings)"
        )
    if source == "trunk pendulum":
        return (
            "its forward acceleration opposes its upward velocity at each step (the inverted "
            f"pendulum: correlation {min(values[:, 0]):.2f}-{max(values[:, 1]):.2f} in "
            f"{total[2]:.0f} of {total[3]:.0f} walking recordings)"
        )
    return f"it turns with its shank (r {span(0)})"


def _by_subject(key, found: list) -> dict:
    """One key's proposal: its subjects' answers (:func:`_subject_answer`), pooled where they
    agree; where two subjects' signed right directions are more than
    :data:`SUBJECTS_DISAGREE_DEG` apart, none, and each subject's answer named.
    """
    subjects = defaultdict(list)
    for unit, axis in found:
        subjects[unit["subject"]].append((unit, axis))
    answers = {s: _subject_answer(f) for s, f in subjects.items()}
    signed = {s: a for s, a in answers.items() if np.isfinite(a["direction"]).all()}
    first = found[0][0]
    base = {"key": key, "sensor_set": first["sensor_set"], "imu": first["imu"]}
    if len(signed) > 1:
        reference = next(iter(signed.values()))["direction"]
        apart = [
            s
            for s, a in signed.items()
            if np.degrees(np.arccos(np.clip(a["direction"] @ reference, -1, 1)))
            > SUBJECTS_DISAGREE_DEG
        ]
        if apart:
            said = "; ".join(f"{s}: {a['proposed']} ({a['verdict']})" for s, a in answers.items())
            return base | {
                "proposed": "",
                "direction": np.full(3, np.nan),
                "verdict": "undetermined",
                "sign_from": "",
                "evidence": f"its subjects' recordings disagree ({said}): different sensors, or "
                "worn differently? give each its own sheet line or imu name",
            }
    if len(subjects) == 1:
        return base | next(iter(answers.values()))
    return base | _subject_answer(found) | {"evidence": _pooled_text(found, answers)}


def _pooled_text(found: list, answers: dict) -> str:
    """The evidence of subjects who agree: the pooled answer's, then, where their answers differ
    (a sign for some, the axis only or nothing for others), each subject's in brief.
    """
    pooled = _subject_answer(found)["evidence"]
    if len({a["proposed"] for a in answers.values()}) == 1:
        return f"{pooled} ({len(answers)} subjects, each alike)"
    each = ", ".join(f"{s} {a['proposed'] or 'nothing'}" for s, a in answers.items())
    return f"{pooled} (per subject: {each})"


def _subject_answer(found: list) -> dict:
    """``proposed``, ``direction``, ``verdict``, ``sign_from`` and ``evidence`` of units (one
    subject's tests, or several subjects' that agree): the mean of their signed right
    directions, or of their lines when none is signed.
    """
    lines = [a for _, a in found if a["axis"] is not None]
    tests = ", ".join(sorted({u["test"] for u, _ in found}))
    if not lines:
        return {
            "proposed": "",
            "direction": np.full(3, np.nan),
            "verdict": "undetermined",
            "sign_from": "",
            "evidence": f"the data cannot tell ({tests}): {_no_axis(found)}",
        }
    signed = [a for a in lines if a["level"]]
    if signed:
        direction = sum(a["sign"] * a["axis"] for a in signed)
        direction /= np.linalg.norm(direction)
        agree = float(np.mean([a["sign"] * (a["axis"] @ direction) > 0 for a in signed]))
    else:
        reference = lines[0]["axis"]
        direction = sum(a["axis"] * np.sign(a["axis"] @ reference) for a in lines)
        direction /= np.linalg.norm(direction)
    k = int(np.argmax(np.abs(direction)))
    off = float(np.degrees(np.arccos(min(1.0, abs(direction[k])))))
    where = "xyz"[k] + (f" ({off:.0f} deg from the measured direction)" if off >= 20 else "")
    text = f"{_axis_text(found, lines)}: nearest sensor axis {where}"
    if not signed:
        why = "; ".join(dict.fromkeys(a.get("cue", "") for _, a in found if a["axis"] is not None))
        return {
            "proposed": f"+-{'xyz'[k]}",
            "direction": direction * np.nan,
            "verdict": "undetermined",
            "sign_from": "",
            "evidence": f"{text}; the data cannot tell the sign ({why}): look at how it is worn",
        }
    sure = agree == 1.0 and all(
        a["level"] == "sure" and (a["confirmed"] or a["pendulum"]) for a in signed
    )
    sign = "+" if direction[k] > 0 else "-"
    sources = dict.fromkeys(a["source"] for a in signed)
    cues = "; ".join(
        _cue_text(source, [a["numbers"] for a in signed if a["source"] == source])
        for source in sources
    )
    together = f" ({round(agree * len(signed))} of {len(signed)} subject x tests agree)"
    text += f"; sign: {cues}" + (together if len(signed) > 1 else "")
    return {
        "proposed": sign + "xyz"[k],
        "direction": direction,
        "verdict": "sure" if sure else "likely" if agree > 0.5 else "undetermined",
        "sign_from": ", ".join(sources),
        "evidence": text,
    }


def _axis_text(found: list, lines: list) -> str:
    """Where the line came from, in words: the pendulum, or how many of the units determined the
    plane normal or the gyroscope's axis, and whether the two agreed.
    """
    n = len(found)
    pendulum = sum(bool(a["pendulum"]) and a["axis"] is not None for a in lines)
    if pendulum:
        return f"right = down x forward from the inverted pendulum in walking ({pendulum} of {n})"
    planes = sum(a.get("plane", False) for a in lines)
    confirmed = sum(a["confirmed"] for a in lines)
    by_gyro = len(lines) - planes
    parts = [f"the plane of its accelerations (Kong Eq. 3) in {planes}"] if planes else []
    parts += [f"its gyroscope's main axis in {by_gyro}"] if by_gyro else []
    text = f"medial-lateral line from {' and '.join(parts)} of {n} subject x test(s)"
    if planes:
        text += (
            f", confirmed by its gyroscope's main axis in {confirmed}"
            if confirmed
            else ", not confirmed by its gyroscope"
        )
    return text


def _no_axis(found: list) -> str:
    """Why no unit gave a line, in words."""
    axes = [a for _, a in found]
    if any(a["conflict"] for a in axes):
        return "the plane of its accelerations and its gyroscope name different axes"
    trunk = [a for a in axes if a["pendulum"]]
    if trunk:
        best = max(max(a["pendulum"]) for a in trunk)
        return (
            f"its forward acceleration does not follow the inverted pendulum in walking "
            f"(correlation {best:.2f} at best, below {MIN_PENDULUM_CORRELATION})"
        )
    ratio = min(a["ratio"] for a in axes)
    gyro = min(a["gyro_ratio"] for a in axes)
    return (
        f"its accelerations have no plane (eigenvalue ratio {ratio:.2f} at best, above "
        f"{MAX_NORMAL_RATIO}) and its gyroscope no main rotation axis ({gyro:.2f})"
    )


def dataset_right_axes(dataset, trim: TrimParams = TrimParams()) -> list[dict]:
    """:func:`propose` on a dataset in the contract (every motion recording of a test that
    calibrates its IMU; each subject, sensor set, test and repetition read together, one clock),
    each proposal beside the declared ``right_axis`` and the imus.tsv cell that holds it.
    """
    import pandas as pd

    from aceval.data.recording_checks import known_recordings

    recordings = known_recordings(dataset)
    kinds, phases = dataset.test_kinds, dataset.first_phases
    allowed = set(map(tuple, dataset.calibrates[["test", "imu"]].to_numpy()))
    recordings = recordings[
        [
            kinds.get(t) == "motion" and (t, i) in allowed
            for t, i in zip(recordings["test"], recordings["imu"])
        ]
    ]
    places = dataset.places
    units: dict[tuple, dict] = {}
    keys = ["subject", "sensor_set", "test", "rep"]
    for (subject, sensor_set, test, _), group in recordings.groupby(keys, sort=False):
        samples = {}
        for imu, path in zip(group["imu"], group["path"]):
            data = dataset.read_recording(path)
            samples[imu] = (data.acc, data.gyr, *places[(sensor_set, imu)])
        for imu, stats in recording_evidence(
            samples, phases.get(test, ""), dataset.fs_hz, trim
        ).items():
            unit = units.setdefault(
                (subject, sensor_set, imu, test),
                {
                    "subject": subject,
                    "sensor_set": sensor_set,
                    "imu": imu,
                    "test": test,
                    "segment": places[(sensor_set, imu)][0],
                    "first_phase": phases.get(test, ""),
                    "stats": [],
                },
            )
            unit["stats"].append(stats)
    sheet = pd.read_csv(dataset.root / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    proposals = []
    for proposal in propose(list(units.values())):
        key = (proposal["sensor_set"], proposal["imu"])
        declared = dataset.right_axes[key]
        line = _sheet_line(sheet, *key)
        proposals.append(
            {
                **proposal,
                "segment": places[key][0],
                "side": places[key][1],
                "declared": declared,
                "agrees": _agrees(declared, proposal),
                "cell": f"imus.tsv line {line}, column right_axis"
                + (f" ({sheet.loc[line - 2, 'source']})" if "source" in sheet else ""),
            }
        )
    return proposals


def _sheet_line(sheet, sensor_set: str, imu: str) -> int:
    """The imus.tsv line (header: line 1) of an IMU of a set: its own row, or the row for every set."""
    sets = sheet["sensor_set"] if "sensor_set" in sheet else [""] * len(sheet)
    for index, (name, row_set) in enumerate(zip(sheet["imu"], sets)):
        if name.strip() == imu and row_set.strip() in (sensor_set, ""):
            return index + 2
    return 0


def _agrees(declared: str, proposal: dict) -> str:
    """'yes' when the declared axis is within 60 deg of the measured right direction (the limit
    of ``right_axis_mismatch``): the data verified its sign; 'no' when not; 'axis agrees, sign not
    verified by the data' for an unsigned proposal; '' without a proposal.
    """
    from aceval.data.rotations import axis_vector, vector_angle_deg
    from aceval.signals.checks import MAX_RIGHT_AXIS_ANGLE_DEG

    if not proposal["proposed"]:
        return ""
    if proposal["proposed"].startswith("+-"):
        same = declared.lstrip("+-") == proposal["proposed"][2:]
        return "axis agrees, sign not verified by the data" if same else "no"
    angle = float(vector_angle_deg(axis_vector(declared), proposal["direction"]))
    return "yes" if angle <= MAX_RIGHT_AXIS_ANGLE_DEG else f"no ({angle:.0f} deg apart)"
