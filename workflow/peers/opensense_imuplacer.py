"""OpenSim 4.6's OpenSense IMUPlacer as a calibration method (``opensense_imuplacer``), in
OpenSim's own environment (.venv-peers/opensim): ``python opensense_imuplacer.py PLAN OUT``.

What OpenSense does: it takes each IMU's orientation in one world frame (from the vendor's
magnetometer-aided fusion) during a static pose, assumes the subject stands in the model's default
pose, turns every orientation about the vertical so that a base IMU's declared heading axis points
along the model's forward direction, and places each IMU on its body with the orientation that
makes them agree. So it needs more than accelerometers and gyroscopes:

* orientations in one gravity-aligned world: the recordings' optional ``quat_w..quat_z`` columns
  (scalar first, sensor -> the vendor's z-up world; the Xsens importer keeps them). Without them
  every calibration is flagged ``not_applicable`` with the reason;
* a base IMU on the pelvis (segment ``waist``) and its forward axis: the sensor axis nearest to
  forward = right x down, from the declared right axis and the quiet-standing vertical, as a user
  would declare it in OpenSense;
* a model: here one body per IMU on a free joint, every body frame aligned with the ground in the
  default pose (a standing model's segment frames; OpenSim's ground: X forward, Y up, Z right).

It calibrates from the static pose alone (the first sample of quiet standing and the vendor's
headings), so each IMU gets one calibration, reported under the static test it reads (e.g. T0),
not under the motion tests it does not use; it has no repetitions, so no test-retest. ``seconds``:
the IMUPlacer run divided by the number of IMUs placed.
"""

from __future__ import annotations

import math
import re
import tempfile
from pathlib import Path

import numpy as np
import opensim as osim
from peer_io import Timer, main, read_columns, read_recording, row

METHOD = "opensense_imuplacer"
QUAT = ["quat_w", "quat_x", "quat_y", "quat_z"]
#: OpenSim's ground (X forward, Y up, Z right) -> Kong's body frame (x forward, y right, z down)
OPENSIM_TO_KONG = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
NO_ORIENTATION = (
    "needs each IMU's orientation in one gravity-aligned world (a magnetometer-aided fusion: "
    "quat_w..quat_z columns) during a static pose; this dataset's recordings have none"
)
NO_STATIC_POSE = (
    "needs each IMU's orientation in one gravity-aligned world during a static pose: the vendor's "
    "orientations (quat_w..quat_z) are in this subject's motion recordings but not in its static "
    "recordings ({tests}; walking_vertical, the mean walking posture, has none: it is no pose), "
    "so record quiet standing"
)
NO_BASE = "needs a base IMU on the pelvis (segment waist) with a static recording"


def quaternions(plan: dict, relative: str) -> np.ndarray | None:
    """The (N, 4) quat_w..quat_z of a recording, or None when it has none."""
    return read_columns(plan, relative, QUAT)


def orientation_gap(plan: dict, static: list[dict], motion: list[dict]) -> str:
    """Why a subject's IMUs have no orientations for the static pose ('' when they have them):
    none in any recording, or only in the motion recordings (the static pose is what is missing).
    """
    if static and all(quaternions(plan, e["paths"][0]) is not None for e in static):
        return ""
    if any(quaternions(plan, next(iter(e["reps"].values()))) is not None for e in motion):
        return NO_STATIC_POSE.format(tests=", ".join(sorted({e["test"] for e in static})))
    return NO_ORIENTATION


def heading_axis(entry: dict, plan: dict) -> str:
    """The base IMU's axis nearest forward (``'-x'`` ...): forward = right x down."""
    acc = np.vstack([read_recording(plan, p)[0] for p in entry["paths"]])
    down = -np.median(acc, axis=0)
    forward = np.cross(np.asarray(entry["right_axis"], float), down / np.linalg.norm(down))
    k = int(np.argmax(np.abs(forward)))
    return ("-" if forward[k] < 0 else "") + "xyz"[k]


def body_name(entry: dict) -> str:
    """The model body (and, with ``_imu``, the IMU label) of one sensor: set and IMU."""
    return re.sub(r"\W", "_", f"{entry['sensor_set']}__{entry['imu']}")


def place(plan: dict, imus: list[dict], base: dict, folder: Path) -> dict:
    """IMUPlacer on one subject's static pose: {(set, IMU): R sensor -> Kong's body frame}."""
    orientations = {body_name(e): quaternions(plan, e["paths"][0]) for e in imus}
    n = min(len(q) for q in orientations.values())
    model = osim.Model()
    model.setName("aceval_one_body_per_imu")
    for name in orientations:
        body = osim.Body(name, 1.0, osim.Vec3(0), osim.Inertia(0.01, 0.01, 0.01))
        model.addBody(body)
        model.addJoint(osim.FreeJoint(f"{name}_free", model.getGround(), body))
    model.finalizeConnections()
    model.printToXML(str(folder / "model.osim"))
    table = osim.TimeSeriesTableQuaternion()
    labels = osim.StdVectorString()
    for name in orientations:
        labels.append(f"{name}_imu")
    table.setColumnLabels(labels)
    for k in range(n):
        values = osim.RowVectorQuaternion(len(orientations), osim.Quaternion(1, 0, 0, 0))
        for j, q in enumerate(orientations.values()):
            element = values.updElt(0, j)
            for i in range(4):
                element.set(i, float(q[k, i]))
        table.appendRow(k / plan["fs_hz"], values)
    table.addTableMetaDataString("DataRate", str(plan["fs_hz"]))
    osim.STOFileAdapterQuaternion.write(table, str(folder / "orientations.sto"))
    placer = osim.IMUPlacer()
    placer.set_model_file(str(folder / "model.osim"))
    placer.set_orientation_file_for_calibration(str(folder / "orientations.sto"))
    placer.set_sensor_to_opensim_rotations(osim.Vec3(-math.pi / 2, 0, 0))  # z-up world -> Y up
    placer.set_base_imu_label(f"{body_name(base)}_imu")
    placer.set_base_heading_axis(heading_axis(base, plan))
    placer.run(False)
    calibrated = placer.getCalibratedModel()
    out = {}
    for entry in imus:
        name = body_name(entry)
        frame = osim.PhysicalOffsetFrame.safeDownCast(
            calibrated.getComponent(f"/bodyset/{name}/{name}_imu")
        )
        rotation = frame.getOffsetTransform().R()  # IMU frame -> body frame (OpenSim axes)
        offset = np.array([[rotation.get(i, j) for j in range(3)] for i in range(3)])
        out[(entry["sensor_set"], entry["imu"])] = OPENSIM_TO_KONG @ offset
    return out


def calibrate(plan: dict) -> list[dict]:
    """One calibration per IMU of the plan, from its subject's static pose, under its static test
    (module docstring).
    """
    osim.Logger.setLevelString("warn")
    rows = []
    for subject in sorted({e["subject"] for e in plan["calibrations"]}):
        wanted = [e for e in plan["calibrations"] if e["subject"] == subject]
        imus = [e for e in plan["static"] if e["subject"] == subject]
        bases = [e for e in imus if e["segment"] == "waist"]
        reason = orientation_gap(plan, imus, wanted) or (NO_BASE if not bases else "")
        placed, seconds = {}, float("nan")
        if not reason:
            with tempfile.TemporaryDirectory() as folder, Timer() as timer:
                placed = place(plan, imus, bases[0], Path(folder))
            seconds = timer.seconds / len(imus)
        calibrated = {(e["sensor_set"], e["imu"]) for e in wanted}
        for entry in imus:  # one calibration per IMU, under the static test it reads
            if (entry["sensor_set"], entry["imu"]) not in calibrated:
                continue
            R = placed.get((entry["sensor_set"], entry["imu"]))
            if R is None:
                rows.append(row(entry, [1], METHOD, flag="not_applicable", note=reason))
            else:
                note = f"the first sample of {entry['test']} and the vendor's headings"
                rows.append(row(entry, [1], METHOD, R, seconds, note=note))
    return rows


if __name__ == "__main__":
    main(calibrate)
