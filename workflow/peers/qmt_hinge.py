"""qmt 0.2.4's hinge joint axis estimation as a calibration method (``qmt_hinge``), in qmt's own
environment (.venv-peers/qmt): ``python qmt_hinge.py PLAN.json OUT.csv`` (peer_io.py).

``qmt.jointAxisEstHingeOlsson`` (Olsson et al. 2020, after Seel et al. 2012) estimates the axis
of a hinge joint in the frames of the two sensors on either side of it, from their simultaneous
accelerometer and gyroscope samples: for the knee, the medial-lateral axis of the thigh and of
the shank at once. So it calibrates a thigh and a shank of one leg from a test that moves the knee
and records both (the plan lists a test for an IMU only where calibrates.tsv lets the test
calibrate it); every other calibration gets the flag ``not_applicable``, with the reason. The
vertical comes from quiet standing (the median specific force, as for Kong and gaitmap); the sign
of the axis, which the estimate leaves open, from the declared right axis. The repetitions of the
subset are concatenated, each cut to the shorter of its two recordings.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import qmt
from peer_io import Timer, frame_from_axes, main, read_recording, row

METHOD = "qmt_hinge"
NOT_A_JOINT = (
    "needs a hinge joint with a sensor on each side recorded together (a thigh and a shank of one "
    "leg, calibrated from the same test)"
)


def down_axis(plan: dict, entry: dict) -> np.ndarray:
    """The sensor-frame downward vertical from quiet standing (the median specific force)."""
    acc = np.vstack([read_recording(plan, p)[0] for p in entry["static"]])
    median = np.median(acc, axis=0)
    return -median / np.linalg.norm(median)


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
                parts.append([recordings[s][r][i][:n] for s in ("thigh", "shank") for i in (0, 1)])
            acc1, gyr1, acc2, gyr2 = (np.vstack([p[i] for p in parts]) for i in range(4))
            with Timer() as timer, contextlib.redirect_stdout(io.StringIO()):  # its iterations
                j1, j2 = qmt.jointAxisEstHingeOlsson(acc1, acc2, gyr1, gyr2)
            for name, entry, axis in (("thigh", thigh, j1), ("shank", shank, j2)):
                R = frame_from_axes(down[name], np.ravel(axis), entry["right_axis"])
                rows.append(row(entry, subset, METHOD, R, timer.seconds / 2))
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
