"""Which sensor axis points to the subject's right: a proposal from the recordings.

``right_axis`` (imus.tsv) fixes the sign of Kong's y axis (Eq. 3) and is checked against every
calibration (``right_axis_mismatch``); a lab that does not know it can ask the recordings.

* **Which axis.** The normal of the plane of the IMU's trimmed accelerations in the tests that
  calibrate it (Kong Eq. 3, the method itself) is the medial-lateral line; the proposal is the
  sensor axis nearest to it. Determined where the normal is (smallest/middle eigenvalue at most
  :data:`MAX_NORMAL_RATIO`, Kong's limit) in every test; it is *confirmed* when the gyroscope's
  principal axis (its largest eigenvalue) names the same sensor axis.
* **Which sign**, from the movement, as aceval's ``backward`` check judges it:

  - a test with a ``first_phase`` of ``-y`` or ``+y`` (bowing, sit-to-stand: -y; seated shank
    lift, leg swing: +y): the sign of each recording's first half-movement about the axis
    (:func:`aceval.methods.moments.first_phase_sign`);
  - walking (``gait``), a shank: it swings forward faster than it moves back, so the third
    moment (skew) of its angular velocity about the right axis is positive;
  - walking, a thigh or a foot: its angular velocity about its right axis rises and falls with
    that of the shank of its side, signed as above (correlation positive; same sensor set and
    repetition, one clock);
  - walking, a trunk sensor (head, chest, waist) or a leg sensor without a shank of its side:
    no sign (walking has no forward cue for it): the proposal names the axis only (``+-z``).

Measured on recordings whose right axes are known (``python benchmarks/check_right_axis.py``,
numbers in config/README.md): the verdict ``sure`` is what those measurements support, ``likely``
a weaker cue, ``undetermined`` none.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from aceval.data.errors import CalibrationError
from aceval.methods.moments import first_phase_sign
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
TRUNK = ("head", "chest", "waist")


def recording_evidence(
    group: dict, first_phase: str, fs_hz: float, trim: TrimParams = TrimParams()
) -> dict:
    """Additive evidence of one time-aligned set of recordings (one subject, sensor set, test and
    repetition): ``group`` maps each IMU to ``(acc, gyr, segment, side)`` (SI, (N, 3)).

    Returns ``{imu: stats}``: ``n``, ``acc_scatter`` and ``gyr_scatter`` (3, 3) and ``gyr_third``
    (3, 3, 3) sums of the trimmed samples (Kong Fig. 5); in a test with a ``-y``/``+y`` first
    phase, ``phase_axis`` (the recording's gyroscope axis) and ``phase_sign`` (its first phase's
    sign about it); for a thigh or foot in walking, ``shank`` (the shank of its side) and the
    centred sums over their common samples ``cross`` (its angular velocity times the shank's),
    ``own`` and ``other`` (each one's own). A recording without movement gives nothing.
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
        if first_phase == "gait" and segment in ("thigh", "foot") and side in shanks:
            own, other = group[imu][1], group[shanks[side]][1]
            n = min(len(own), len(other))
            own, other = own[:n] - own[:n].mean(0), other[:n] - other[:n].mean(0)
            stats |= {"shank": shanks[side], "cross": own.T @ other}
            stats |= {"own": own.T @ own, "other": other.T @ other}
        evidence[imu] = stats
    return evidence


def _principal(scatter: np.ndarray, smallest: bool) -> tuple[np.ndarray, float]:
    """The principal axis of a scatter and the eigenvalue ratio that decides it: the smallest
    eigenvalue's (a plane's normal: smallest/middle) or the largest's (middle/largest).
    """
    values, vectors = np.linalg.eigh(scatter)
    if smallest:
        return vectors[:, 0], values[0] / values[1]
    return vectors[:, 2], values[1] / values[2]


def propose(units: list[dict]) -> list[dict]:
    """The right axis each IMU's recordings propose.

    ``units``: one dict per (subject, sensor_set, imu, test) with ``sensor_set``, ``imu``,
    ``segment``, ``subject``, ``test``, ``first_phase`` and ``stats``, a list of
    :func:`recording_evidence` values of its repetitions. Returns one dict per (sensor_set, imu):
    ``proposed`` ('+y'; '+-z' when only the axis is known; '' when not even that), ``direction``
    (the measured right direction in the sensor frame, unit (3,), NaN when unknown), ``verdict``
    ('sure', 'likely', 'undetermined') and ``evidence`` (what decided it, in words).
    """
    units = {(u["subject"], u["sensor_set"], u["imu"], u["test"]): u for u in units if u["stats"]}
    axes = {key: _unit_axis(unit) for key, unit in units.items()}
    shank_right = {}  # the shanks first: a thigh's or foot's sign in walking follows its shank's
    for key in sorted(units, key=lambda k: units[k]["segment"] != "shank"):
        axes[key] |= _unit_sign(units[key], axes[key], shank_right)
        if units[key]["segment"] == "shank" and axes[key]["level"]:
            shank_right[key] = axes[key]["sign"] * axes[key]["axis"]
    by_imu = defaultdict(list)
    for key, unit in units.items():
        by_imu[(unit["sensor_set"], unit["imu"])].append((unit, axes[key]))
    return [_imu_proposal(key, found) for key, found in by_imu.items()]


def _unit_axis(unit: dict) -> dict:
    """The medial-lateral line one unit's repetitions give (``axis``, unsigned; None when
    undetermined): Kong's plane normal where determined, else the gyroscope's principal axis where
    that is; ``confirmed`` when both are determined and within 30 deg of each other, ``conflict``
    when both are determined and further apart.
    """
    normal, ratio = _principal(sum(s["acc_scatter"] for s in unit["stats"]), smallest=True)
    gyro, gyro_ratio = _principal(sum(s["gyr_scatter"] for s in unit["stats"]), smallest=False)
    plane, turn = ratio <= MAX_NORMAL_RATIO, gyro_ratio <= MAX_NORMAL_RATIO
    close = abs(normal @ gyro) >= np.cos(np.radians(30.0))
    axis = normal if plane else gyro if turn else None
    return {
        "axis": None if (plane and turn and not close) else axis,
        "ratio": float(ratio),
        "confirmed": bool(plane and turn and close),
        "conflict": bool(plane and turn and not close),
    }


def _unit_sign(unit: dict, found: dict, shank_right: dict) -> dict:
    """``sign`` (+1/-1 about the unit's axis, 0 unknown), ``level`` ('sure', 'likely', '') and
    ``cue`` (what decided it, in words) of one unit.
    """
    axis, stats, phase = found["axis"], unit["stats"], unit["first_phase"]
    none = {"sign": 0.0, "level": ""}
    if axis is None:
        return none | {"cue": "no axis"}
    if phase in ("-y", "+y"):
        votes = np.array(
            [s["phase_sign"] * np.sign(s["phase_axis"] @ axis) for s in stats if s["phase_sign"]]
        )
        if not len(votes) or votes.sum() == 0:
            return none | {"cue": "no first phase about it"}
        agree = float(np.mean(votes == np.sign(votes.sum())))
        protocol = -1.0 if phase == "-y" else 1.0  # the first phase about body y (the right axis)
        level = "sure" if agree >= 2 / 3 else "likely"
        cue = f"the first phase ({phase}) of {agree:.0%} of {len(votes)} repetitions"
        return {"sign": float(np.sign(votes.sum())) * protocol, "level": level, "cue": cue}
    if phase != "gait":
        return none | {"cue": "its test has no first_phase"}
    if unit["segment"] == "shank":
        n = sum(s["n"] for s in stats)
        second = axis @ sum(s["gyr_scatter"] for s in stats) @ axis / n
        third = np.einsum("ijk,i,j,k->", sum(s["gyr_third"] for s in stats), axis, axis, axis) / n
        skew = float(third / second**1.5)
        if abs(skew) < MIN_SKEW:
            return none | {"cue": f"its swing's skew {abs(skew):.2f} is below {MIN_SKEW}"}
        return {
            "sign": np.sign(skew),
            "level": "sure",
            "cue": f"it swings forward faster than back (skew {abs(skew):.2f})",
        }
    paired = [s for s in stats if "shank" in s]
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
    level = "sure" if abs(r) >= SURE_CORRELATION else "likely"
    return {"sign": np.sign(r), "level": level, "cue": f"it turns with its shank (r {abs(r):.2f})"}


def _imu_proposal(key: tuple, found: list) -> dict:
    """One IMU's proposal from its units (subjects x tests): the mean of their signed right
    directions, or the mean line when none is signed; how sure the whole is.
    """
    sensor_set, imu = key
    segment = found[0][0]["segment"]
    lines = [a for _, a in found if a["axis"] is not None]
    if not lines:
        ratio = min(a["ratio"] for _, a in found)
        conflict = any(a["conflict"] for _, a in found)
        why = (
            "the plane of its accelerations and its gyroscope name different axes"
            if conflict
            else f"its movement has no plane (eigenvalue ratio {ratio:.2f} at best, above "
            f"{MAX_NORMAL_RATIO}) and no main rotation axis"
        )
        return _proposal(sensor_set, imu, "", np.full(3, np.nan), "undetermined", why)
    reference = lines[0]["axis"]
    signed = [a for a in lines if a["level"]]
    if signed:
        direction = sum(a["sign"] * a["axis"] for a in signed)
        direction /= np.linalg.norm(direction)
        agree = np.mean([a["sign"] * (a["axis"] @ direction) > 0 for a in signed])
    else:
        direction = sum(a["axis"] * np.sign(a["axis"] @ reference) for a in lines)
        direction /= np.linalg.norm(direction)
    k = int(np.argmax(np.abs(direction)))
    off = float(np.degrees(np.arccos(min(1.0, abs(direction[k])))))
    where = f"{'xyz'[k]} ({off:.0f} deg off it)" if off >= 20 else "xyz"[k]
    confirmed = sum(a["confirmed"] for a in lines)
    text = f"axis {where} in {len(lines)} of {len(found)} subject x test(s) (gyroscope confirms {confirmed})"
    if not signed:
        why = found[0][1].get("cue", "")
        why = "walking gives no sign for a trunk sensor" if segment in TRUNK else why
        return _proposal(
            sensor_set,
            imu,
            f"+-{'xyz'[k]}",
            direction * np.nan,
            "undetermined",
            f"{text}; sign unknown: {why}: look at how it is worn",
        )
    sign = "+" if direction[k] > 0 else "-"
    sure = (
        agree == 1.0
        and all(a["level"] == "sure" for a in signed)
        and len(lines) == len(found)
        and confirmed == len(lines)
    )
    verdict = "sure" if sure else "likely" if agree > 0.5 else "undetermined"
    text += f"; sign: {signed[0]['cue']} ({agree:.0%} of {len(signed)} agree)"
    return _proposal(sensor_set, imu, sign + "xyz"[k], direction, verdict, text)


def _proposal(sensor_set, imu, proposed: str, direction, verdict: str, evidence: str) -> dict:
    return {
        "sensor_set": sensor_set,
        "imu": imu,
        "proposed": proposed,
        "direction": direction,
        "verdict": verdict,
        "evidence": evidence,
    }


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
    of ``right_axis_mismatch``), 'no' when not; 'axis only' comparisons for an unsigned proposal;
    '' without a proposal.
    """
    from aceval.data.rotations import axis_vector, vector_angle_deg
    from aceval.signals.checks import MAX_RIGHT_AXIS_ANGLE_DEG

    if not proposal["proposed"]:
        return ""
    if proposal["proposed"].startswith("+-"):
        same = declared.lstrip("+-") == proposal["proposed"][2:]
        return "axis agrees, sign unknown" if same else "no"
    angle = float(vector_angle_deg(axis_vector(declared), proposal["direction"]))
    return "yes" if angle <= MAX_RIGHT_AXIS_ANGLE_DEG else f"no ({angle:.0f} deg apart)"
