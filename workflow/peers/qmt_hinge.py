"""qmt 0.2.4's hinge joint axis estimation as a calibration method (``qmt_hinge``), in qmt's own
environment (.venv-peers/qmt): ``python qmt_hinge.py PLAN.json OUT.csv`` (peer_io.py).

``qmt.jointAxisEstHingeOlsson`` (Olsson et al. 2020, after Seel et al. 2012) estimates the axis
of a hinge joint in the frames of the two sensors on either side of it, from their simultaneous
accelerometer and gyroscope samples: for the knee, the medial-lateral axis of the thigh and of
the shank at once. So it calibrates a thigh and a shank of one leg from a test that moves the knee
and records both (the plan lists a test for an IMU only where calibrates.tsv lets the test
calibrate it); every other calibration gets the flag ``not_applicable``, with the reason. A test
in which the knee flexes less than :data:`MIN_KNEE_RANGE_DEG` is outside the method's design: its
calibrations are flagged ``knee_barely_flexes`` (they leave the medians, as aceval's flagged rows
do). The
vertical comes from quiet standing (the median specific force, as for Kong and gaitmap); the sign
of the axis, which the estimate leaves open, from the declared right axis. The repetitions of the
subset are concatenated, each cut to the shorter of its two recordings and to the samples aceval's
methods read from both (the plan's ``kept`` ranges of the thigh and of the shank, intersected: the
joint needs simultaneous samples).
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import qmt
from peer_io import Timer, frame_from_axes, kept_samples, main, read_recording, row

METHOD = "qmt_hinge"
#: the knee must flex for a hinge axis to be seen (Seel et al. 2012 excite the joint on purpose);
#: below this flexion range (deg, median over the repetitions, as :func:`knee_range_deg` reads it)
#: a calibration is flagged ``knee_barely_flexes``. A choice, not from qmt, between what the
#: range reads on the committed data (one subject each, 2026-11-24): kong_sim's straight-leg swing
#: T5 (3.5 deg of knee flexion simulated; read 7.6-35.9, median 12.0: the axes themselves are
#: poorly seen there) against walking (kong_sim 59.9-81.3, HuGaDB 57.3-271.3, qmt 116-157) and
#: sit-to-stand (qmt 50.6-106.9); walking flexes the knee about 60 deg (Perry & Burnfield 2010)
MIN_KNEE_RANGE_DEG = 40.0
NOT_A_JOINT = (
    "needs a hinge joint with a sensor on each side recorded together (a thigh and a shank of one "
    "leg, calibrated from the same test)"
)


def down_axis(plan: dict, entry: dict) -> np.ndarray:
    """The sensor-frame downward vertical from quiet standing (the median specific force)."""
    acc = np.vstack([read_recording(plan, p)[0] for p in entry["static"]])
    median = np.median(acc, axis=0)
    return -median / np.linalg.norm(median)


def knee_range_deg(gyr1: np.ndarray, gyr2: np.ndarray, j1, j2, fs_hz: float) -> float:
    """The flexion range (deg) of the hinge seen by ``j1`` (thigh frame) and ``j2`` (shank frame):
    the integral of the two sensors' angular velocities about their axes, differenced (the
    estimate leaves each axis' sign open: the sign that cancels the leg's common rotation best).
    """
    a, b = gyr1 @ np.ravel(j1), gyr2 @ np.ravel(j2)
    rate = min((b - a, b + a), key=lambda r: float(np.sum(r * r)))
    angle = np.degrees(np.cumsum(rate) / fs_hz)
    return float(np.ptp(angle))


def calibrate(plan: dict) -> list[dict]:
    """The thigh and shank of each leg by the knee's hinge axis; the rest not applicable."""
    entries = plan["calibrations"]
    key = lambda e: (e["subject"], e["sensor_set"], e["side"], e["test"])  # noqa: E731
    shanks = {key(e): e for e in entries if e["segment"] == "shank"}
    rows, done = [], set()
    for thigh in [e for e in entries if e["segment"] == "thigh" and key(e) in shanks]:
        shank = shanks[key(thigh)]
        down = {"thigh": down_axis(plan, thigh), "shank": down_axis(plan, shank)}
        recordings = {
            name: {int(k): read_recording(plan, p) for k, p in entry["reps"].items()}
            for name, entry in (("thigh", thigh), ("shank", shank))
        }
        common = [s for s in thigh["subsets"] if s in shank["subsets"]]
        for subset in common:
            parts = []
            for r in subset:
                n = min(len(recordings["thigh"][r][0]), len(recordings["shank"][r][0]))
                both = np.intersect1d(kept_samples(thigh, r, n), kept_samples(shank, r, n))
                parts.append(
                    [recordings[s][r][i][both] for s in ("thigh", "shank") for i in (0, 1)]
                )
            acc1, gyr1, acc2, gyr2 = (np.vstack([p[i] for p in parts]) for i in range(4))
            with Timer() as timer, contextlib.redirect_stdout(io.StringIO()):  # its iterations
                j1, j2 = qmt.jointAxisEstHingeOlsson(acc1, acc2, gyr1, gyr2)
            knee = np.median(
                [knee_range_deg(p[1], p[3], j1, j2, plan["fs_hz"]) for p in parts]
            )  # each repetition's range: integrating across the joins would drift
            flag, note = (
                (
                    "knee_barely_flexes",
                    f"knee flexion range {knee:.1f} deg < {MIN_KNEE_RANGE_DEG:g}",
                )
                if knee < MIN_KNEE_RANGE_DEG
                else ("", "")
            )
            for name, entry, axis in (("thigh", thigh, j1), ("shank", shank, j2)):
                R = frame_from_axes(down[name], np.ravel(axis), entry["right_axis"])
                rows.append(row(entry, subset, METHOD, R, timer.seconds / 2, flag, note, axis=axis))
        done |= {id(thigh), id(shank)}
    for entry in entries:
        if id(entry) not in done:
            rows += [
                row(entry, s, METHOD, flag="not_applicable", note=NOT_A_JOINT)
                for s in entry["subsets"]
            ]
    return rows


if __name__ == "__main__":
    main(calibrate)
