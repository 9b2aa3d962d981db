"""Ground truth from optical markers: each sensor's rotation to Kong's body frame, by two methods.

:func:`truth_rows` gives both for every sensor (documented in config/README.md "Real datasets"):
the optical point acceleration method (:func:`aceval.data.truth.acceleration_truth`: the truth), and
the marker-frame method of this module (:func:`ground_truth`, the second estimate):

1. Segment frames from markers (low-passed at 6 Hz, zero phase): three points rigid with each
   segment (:data:`SEGMENT_MARKERS`) give an orthonormal frame ``R_world_seg(t)``.
2. Optical angular velocity in the segment frame from consecutive frames (central difference of
   ``R(t-1)^T R(t+1)``); the gyroscope is low-passed alike and its bias (mean while standing) removed.
3. Time alignment: one lag for the trial (one synchronised recording, one clock; within +-0.3 s),
   the one that maximises the summed correlations of its sensors' two angular speeds during the
   walk (used by both methods).
4. ``R_seg_sensor`` = the rotation that maps the accelerometer's vertical while standing exactly
   onto the Vicon vertical in the segment frame, and best maps gyroscope onto optical angular
   velocity over the walk about it (Wahba problem with one exact pair,
   ``scipy.spatial.transform.Rotation.align_vectors`` with an infinite weight). This assumes the
   marker frame stays rigid with the sensor while walking; where it twists about the segment's
   long axis (the NeuRA shanks: 6-10 deg on average), the fit inherits the twist.
5. Kong's whole-body frame while standing (what Kong's calibration estimates for every IMU): z
   down (world vertical), y the body's medial-lateral axis (:data:`BODY_ML_MARKERS`, pointing
   right) made horizontal, x = y x z. A segment whose own flexion axis is turned from the body's
   (toe-out of the feet, tibial torsion) is therefore a real error of Kong's plane, not of the
   truth.

Uncertainty reported per sensor (:func:`truth_rows`): the spread of the strides' own headings
(weighted by motion), over other points of the segment and over +-1 sample of time offset,
combined; an independent optical check of each truth's heading from the angular velocity of the
segment's long axis (no marker frame); the two truths' difference, the marker frame's twist, the
lever arm, the pair consistency of two sensors on one segment (heading and tilt apart), and for
the marker frame its own split-half, the RMS misfit of the angular velocities and
``vertical_check_deg`` (the tilt between the accelerometer's vertical and the one a fit of the
angular velocities alone gives). Because the vertical is the accelerometer's in both, Kong's z0
agrees with the truth by construction: the error against it is the heading (the medial-lateral
axis), the part Kong's PCA estimates.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.importers.shared import FormatError

#: three markers or joint centres rigid with each segment: origin, along, in-plane (the thigh and
#: tibia wand markers, well off the long axis; the foot has only heel and toe markers, so its
#: third point is the ankle centre, as in Plug-in Gait)
SEGMENT_MARKERS = {
    ("waist", "center"): ("LASI", "RASI", "RPSI"),
    ("thigh", "right"): ("RHJC", "RKJC", "RTHI"),
    ("thigh", "left"): ("LHJC", "LKJC", "LTHI"),
    ("shank", "right"): ("RKJC", "RAJC", "RTIB"),
    ("shank", "left"): ("LKJC", "LAJC", "LTIB"),
    ("foot", "right"): ("RHEE", "RTOE", "RAJC"),
    ("foot", "left"): ("LHEE", "LTOE", "LAJC"),
}
#: another point of a segment counts in the truth's uncertainty when its horizontal acceleration
#: over the bout has at least this share of the chosen point's power (:func:`_uncertainty`)
MIN_POINT_POWER = 0.5
#: a line rigid with each leg segment whose angular velocity checks a truth's heading without any
#: marker frame (:func:`aceval.data.truth.long_axis_heading_deg`): the thigh's and shank's joint
#: centres, the foot's heel to toe. The legs swing across these lines; the pelvis hardly turns
#: across any of its marker lines in walking (its ASIS line read 19 deg off a truth that its other
#: checks put within 3: no check), so it has none
LONG_AXES = {
    ("thigh", "right"): ("RHJC", "RKJC"),
    ("thigh", "left"): ("LHJC", "LKJC"),
    ("shank", "right"): ("RKJC", "RAJC"),
    ("shank", "left"): ("LKJC", "LAJC"),
    ("foot", "right"): ("RHEE", "RTOE"),
    ("foot", "left"): ("LHEE", "LTOE"),
}
#: the body's medial-lateral axis (from, to), pointing right: the line of the anterior superior iliac
#: spines while standing. Kong calibrates every IMU to the whole-body frame, so every segment shares it.
BODY_ML_MARKERS = ("LASI", "RASI")
LOWPASS_HZ = 6.0
MAX_LAG_S = 0.3


def read_markers(path) -> dict[str, np.ndarray]:
    """Marker and joint-centre trajectories (N, 3) in metres from a Vicon .mat export."""
    from scipy.io import loadmat

    try:
        content = loadmat(path)
    except Exception as exc:  # scipy raises several types for a damaged file
        raise FormatError(f"{path}: cannot be read as a MATLAB file: {exc}") from exc
    markers = {
        k: np.asarray(v, float) / 1000.0
        for k, v in content.items()
        if not k.startswith("__") and np.ndim(v) == 2 and np.shape(v)[1] == 3
    }
    if not markers:
        raise FormatError(f"{path}: no (N, 3) marker arrays")
    return markers


def _lowpass(x: np.ndarray, fs_hz: float) -> np.ndarray:
    from scipy.signal import butter, sosfiltfilt

    return sosfiltfilt(butter(2, LOWPASS_HZ, fs=fs_hz, output="sos"), x, axis=0)


def segment_frames(markers: dict, names: tuple[str, str, str], fs_hz: float) -> Rotation:
    """``R_world_seg(t)`` from three points rigid with the segment (origin, along, in-plane)."""
    missing = [n for n in names if n not in markers]
    if missing:
        raise FormatError(f"Vicon markers {', '.join(missing)} are missing")
    p0, p1, p2 = (_lowpass(markers[n], fs_hz) for n in names)
    e1 = p1 - p0
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e3 = np.cross(e1, p2 - p0)
    e3 /= np.linalg.norm(e3, axis=1, keepdims=True)
    e2 = np.cross(e3, e1)
    return Rotation.from_matrix(np.stack([e1, e2, e3], axis=2))


def optical_angular_velocity(frames: Rotation, fs_hz: float) -> np.ndarray:
    """(N, 3) rad/s in the segment frame (central difference; ends copied from their neighbours)."""
    omega = (frames[:-2].inv() * frames[2:]).as_rotvec() * fs_hz / 2.0
    return np.vstack([omega[:1], omega, omega[-1:]])


def lag_scores(
    optical: np.ndarray, gyr: np.ndarray, span: tuple[int, int], fs_hz: float
) -> pd.Series:
    """The correlation of the optical and gyroscope angular speeds within ``span`` for each lag
    (samples, within :data:`MAX_LAG_S`; gyroscope sample ``t + lag`` matches optical ``t``).
    """
    a, b = span
    limit = int(MAX_LAG_S * fs_hz)
    speed_opt, speed_gyr = np.linalg.norm(optical, axis=1), np.linalg.norm(gyr, axis=1)
    lags = [lag for lag in range(-limit, limit + 1) if a + lag >= 0 and b + lag <= len(gyr)]
    scores = [np.corrcoef(speed_opt[a:b], speed_gyr[a + lag : b + lag])[0, 1] for lag in lags]
    return pd.Series(scores, index=lags)


def best_lag(optical: np.ndarray, gyr: np.ndarray, span: tuple[int, int], fs_hz: float) -> int:
    """The lag of :func:`lag_scores` with the highest correlation."""
    return int(lag_scores(optical, gyr, span, fs_hz).idxmax())


def _filtered_gyr(gyr: np.ndarray, standing: tuple[int, int], fs_hz: float) -> np.ndarray:
    """The gyroscope without its bias (mean while standing), low-passed as the markers are."""
    return _lowpass(gyr - gyr[standing[0] : standing[1]].mean(axis=0), fs_hz)


def common_lag(
    markers: dict, sensors: dict, standing: tuple[int, int], walk: tuple[int, int], fs_hz: float
) -> int:
    """One lag for the whole trial (its sensors are one synchronised recording, one clock): the
    lag of the sum of every sensor's :func:`lag_scores` over the walk. Before, each sensor set
    chose its own, and earlier each sensor (NeuRA: thigh_l -1, the others +2).
    """
    total = None
    for sensor in sensors.values():
        optical = optical_angular_velocity(segment_frames(markers, sensor["frame"], fs_hz), fs_hz)
        scores = lag_scores(optical, _filtered_gyr(sensor["gyr"], standing, fs_hz), walk, fs_hz)
        total = scores if total is None else total.add(scores, fill_value=0)
    return int(total.idxmax())


def sensor_to_segment(
    optical: np.ndarray, gyr: np.ndarray, up: tuple | None = None
) -> tuple[Rotation, float]:
    """``R_seg_sensor`` mapping gyroscope onto optical angular velocity, and the RMS misfit (rad/s).
    ``up = (up_segment, up_sensor)``: unit vertical in both frames, matched exactly.
    """
    if up is None:
        rotation, _ = Rotation.align_vectors(optical, gyr)
    else:
        weights = np.concatenate([[np.inf], np.ones(len(gyr))])
        rotation, _ = Rotation.align_vectors(
            np.vstack([up[0], optical]), np.vstack([up[1], gyr]), weights
        )
    rms = float(np.sqrt(np.mean(np.sum((optical - rotation.apply(gyr)) ** 2, axis=1))))
    return rotation, rms


def body_axes(ml_world: np.ndarray) -> np.ndarray:
    """Rows x, y, z of Kong's body frame in world coordinates (world z up): z down, y the
    horizontal part of the medial-lateral axis ``ml_world`` (pointing right), x = y x z.
    """
    z = np.array([0.0, 0.0, -1.0])
    y = ml_world - np.dot(ml_world, z) * z
    y /= np.linalg.norm(y)
    return np.vstack([np.cross(y, z), y, z])


def ground_truth(
    markers: dict,
    names: tuple[str, str, str],
    gyr: np.ndarray,
    acc: np.ndarray,
    standing: tuple[int, int],
    walk: tuple[int, int],
    fs_hz: float,
    lag: int | None = None,
) -> dict:
    """The marker-frame method (module docstring): the sensor's orientation while standing,
    ``R_ws0`` (Rotation, sensor -> world), from the segment frame of the three points ``names``,
    with its uncertainty. ``lag``: the recording's time offset (:func:`common_lag`); None: this
    sensor's own best.
    """
    n = len(next(iter(markers.values())))
    if len(gyr) != n:
        raise FormatError(
            f"Vicon has {n} frames, the sensor {len(gyr)} samples: not the same trial"
        )
    frames = segment_frames(markers, names, fs_hz)
    optical = optical_angular_velocity(frames, fs_hz)
    gyr_filtered = _filtered_gyr(gyr, standing, fs_hz)
    lag = best_lag(optical, gyr_filtered, walk, fs_hz) if lag is None else lag
    a, b = walk
    shifted = gyr_filtered[a + lag : b + lag]
    stand_frames = frames[standing[0] : standing[1]].mean()
    up_sensor = np.median(acc[standing[0] : standing[1]], axis=0)
    up = (stand_frames.inv().apply([0.0, 0.0, 1.0]), up_sensor / np.linalg.norm(up_sensor))
    rotation, rms = sensor_to_segment(optical[a:b], shifted, up)
    half = (b - a) // 2
    first, _ = sensor_to_segment(optical[a : a + half], shifted[:half], up)
    second, _ = sensor_to_segment(optical[a + half : b], shifted[half:], up)
    gyro_only, _ = sensor_to_segment(optical[a:b], shifted)
    vertical_check = np.degrees(
        np.arccos(np.clip(np.dot(gyro_only.inv().apply(up[0]), up[1]), -1.0, 1.0))
    )
    return {
        "R_ws0": stand_frames * rotation,
        "frames": frames,
        "lag_samples": lag,
        "rms_misfit_deg_s": float(np.degrees(rms)),
        "split_half_deg": float(np.degrees((first * second.inv()).magnitude())),
        "vertical_check_deg": float(vertical_check),
        "n_samples": b - a,
    }


def forward_check(markers: dict, walk: tuple[int, int]) -> np.ndarray:
    """Unit horizontal walking direction (pelvis centre displacement over ``walk``, the first
    straight repetition), to check that the body frames' x axes point forward.
    """
    centre = sum(markers[m] for m in ("LASI", "RASI", "LPSI", "RPSI")) / 4.0
    step = centre[walk[1] - 1] - centre[walk[0]]
    step[2] = 0.0
    return step / np.linalg.norm(step)


#: a point rigid with each segment whose optical acceleration the sensor's is matched to
#: (:func:`aceval.data.truth.acceleration_truth`): the pelvis centre, the joint centre at the distal
#: end of the thigh and shank (on the long axis, so a twist about it does not move the point), the
#: heel marker of the foot
SEGMENT_POINTS = {
    ("waist", "center"): ("LASI", "RASI", "LPSI", "RPSI"),
    ("thigh", "right"): ("RKJC",),
    ("thigh", "left"): ("LKJC",),
    ("shank", "right"): ("RAJC",),
    ("shank", "left"): ("LAJC",),
    ("foot", "right"): ("RHEE",),
    ("foot", "left"): ("LHEE",),
}
#: two truths of one sensor farther apart than this (deg) are flagged ``methods_differ``; a truth
#: whose uncertainty (strides, points, lags: :func:`_uncertainty`) is larger is flagged
#: ``truth_unstable``
MAX_METHOD_DIFFERENCE_DEG = 5.0


def segment_point(markers: dict, segment: str, side: str) -> np.ndarray:
    """The world trajectory (N, 3, m) of the segment's point of :data:`SEGMENT_POINTS`."""
    names = SEGMENT_POINTS.get((segment, side))
    if names is None or any(n not in markers for n in names):
        raise FormatError(f"no Vicon point for segment {segment} ({side}): needs {names}")
    return sum(markers[n] for n in names) / len(names)


def ground_truth_table(
    markers: dict, imports: dict, imus: pd.DataFrame, subject: str
) -> pd.DataFrame:
    """One row per sensor of a NeuRA-style trial (:func:`truth_rows`), the body frame from the
    anterior superior iliac spines while standing.
    """
    spans, fs_hz = imports["spans"], imports["fs_hz"]
    standing = spans["T0"][0]
    forward = forward_check(markers, spans["T6"][0])
    B = body_axes(body_ml(markers, standing))
    heading_error = float(np.degrees(np.arccos(np.clip(B[0] @ forward, -1, 1))))
    if heading_error > 45:
        raise FormatError(
            f"the body frame's x axis is {heading_error:.0f} deg from the walking direction: "
            f"are the {', '.join(BODY_ML_MARKERS)} markers swapped?"
        )
    sensors = {}
    for key, (gyr, acc) in imports["signals"].items():
        segment, side = imus.loc[
            (imus["sensor_set"] == key[0]) & (imus["imu"] == key[1]), ["segment", "side"]
        ].iloc[0]
        if (segment, side) not in SEGMENT_MARKERS:
            raise FormatError(f"no Vicon marker set for segment {segment} ({side})")
        frame = SEGMENT_MARKERS[(segment, side)]
        sensors[key] = dict(
            segment=segment,
            side=side,
            gyr=gyr,
            acc=acc,
            frame=frame,
            point=segment_point(markers, segment, side),
            points={name: markers[name] for name in frame},
            long_axis=tuple(markers[n] for n in LONG_AXES.get((segment, side), ())),
            sensor_id=imports["sensor_ids"][key],
        )
    table = truth_rows(markers, sensors, spans, fs_hz, B)
    table.insert(0, "subject", subject)
    table["heading_vs_walk_deg"] = heading_error
    return table


def truth_rows(
    markers: dict, sensors: dict, spans: dict, fs_hz: float, B: np.ndarray
) -> pd.DataFrame:
    """Both truths of every sensor and their checks (Kong's body frame ``B``: rows x, y, z in
    world coordinates).

    ``sensors``: ``{(sensor_set, imu): {segment, side, gyr, acc, frame, point, points,
    long_axis, sensor_id}}`` with ``frame`` the three marker names of the segment frame, ``point``
    the world trajectory of a point rigid with the segment, ``points`` other such points (name ->
    trajectory) and ``long_axis`` a line rigid with it (two trajectories) or None. The true R
    (r11..r33) is the optical point acceleration method (:func:`aceval.data.truth.
    acceleration_truth`, from the end of quiet standing to the end of the first straight walk),
    beside the marker-frame method (:func:`ground_truth`, ``marker_frame_*``). Its uncertainty
    (:func:`_uncertainty`): the spread of the strides' own headings, over the other points and
    over +-1 sample of time offset; ``long_axis_check_deg`` (and the marker frame's) the heading
    an independent optical check would correct each truth by; ``flag`` names what exceeds
    :data:`MAX_METHOD_DIFFERENCE_DEG` (the truths' difference, the truth's uncertainty); the
    marker frame's twist relative to the sensor during the walk (``twist_*_deg``, about the
    segment's long axis); the lever arm from the point to the sensor; for two sensors on one
    segment, their gyroscopes' relative rotation against their truths' (``pair_heading_deg``,
    ``pair_tilt_deg``).
    """
    from aceval.data.truth import acceleration_truth, twist_about_axis

    standing = spans["T0"][0]
    walk = (spans["T6"][0][0], spans["T6"][-1][1])
    # from the end of quiet standing (gait initiation included) to the end of the first straight stretch
    bout = (standing[1], spans.get("first_straight", spans["T6"][:1])[0][1])
    rows, kept = [], {}
    lag = common_lag(markers, sensors, standing, walk, fs_hz)
    for (sensor_set, imu), sensor in sensors.items():
        gyr, acc = sensor["gyr"], sensor["acc"]
        old = ground_truth(markers, sensor["frame"], gyr, acc, standing, walk, fs_hz, lag)
        new = acceleration_truth(
            acc, gyr, sensor["point"], standing, bout, fs_hz, lag, spans.get("strides")
        )
        R, R_marker = B @ new["R_ws0"].as_matrix(), B @ old.pop("R_ws0").as_matrix()
        frames = old.pop("frames")[new["start"] : bout[1]]
        twist = twist_about_axis(frames, new["orientation"], [1.0, 0.0, 0.0], 0)[
            bout[0] - new["start"] :
        ]
        checks = _uncertainty(sensor, new, standing, bout, fs_hz, lag)
        checks |= _long_axis_checks(sensor, new, R, R_marker, bout, fs_hz, lag, standing)
        kept[(sensor_set, imu)] = ((sensor["segment"], sensor["side"]), gyr[walk[0] : walk[1]], R)
        rows.append(
            {
                "sensor_set": sensor_set,
                "imu": imu,
                **_truth_columns(sensor, new, old, R, R_marker, twist, checks),
            }
        )
    return _with_pair_consistency(pd.DataFrame(rows), kept)


def _uncertainty(sensor: dict, new: dict, standing, bout, fs_hz: float, lag: int) -> dict:
    """The truth's uncertainty (deg): ``truth_stride_se_deg`` (the strides' own headings,
    :func:`aceval.data.truth.acceleration_truth`), ``truth_points_deg`` (the largest change of the
    heading when another point of the segment is matched: its frame markers and the middle of
    its long axis other than the chosen point itself, those whose horizontal acceleration over
    the bout has at least :data:`MIN_POINT_POWER` of the chosen point's: a point that hardly
    accelerates, such as the hip centre on the thigh, cannot fix a heading; NaN where no other
    point does, ``truth_n_points`` says how many did) and ``truth_lags_deg`` (the largest change
    at one sample more or less of time offset), and ``truth_uncertainty_deg``, the three (or the
    two without a points term) combined as a root sum of squares.
    """
    from aceval.data.truth import acceleration_truth, point_acceleration

    def change(point, shift) -> float:
        other = acceleration_truth(
            sensor["acc"], sensor["gyr"], point, standing, bout, fs_hz, lag + shift
        )["heading_rad"]
        return float(np.degrees(abs((other - new["heading_rad"] + np.pi) % (2 * np.pi) - np.pi)))

    def power(point) -> float:
        return float(np.sum(point_acceleration(point, fs_hz)[bout[0] : bout[1], :2] ** 2))

    others = list(sensor.get("points", {}).values())
    if sensor.get("long_axis"):
        others.append((sensor["long_axis"][0] + sensor["long_axis"][1]) / 2)
    # the chosen point itself (a frame marker or joint centre, e.g. the knee centre of the thigh)
    # changes nothing: it is not another point
    others = [p for p in others if not np.array_equal(p, sensor["point"])]
    enough = MIN_POINT_POWER * power(sensor["point"])
    others = [p for p in others if power(p) >= enough]
    points = max((change(p, 0) for p in others), default=np.nan)
    lags = max(change(sensor["point"], shift) for shift in (-1, 1))
    parts = np.array([new["stride_se_deg"], points, lags])
    return {
        "truth_stride_sd_deg": new["stride_sd_deg"],
        "truth_stride_se_deg": new["stride_se_deg"],
        "truth_n_strides": new["n_strides"],
        "truth_points_deg": points,
        "truth_n_points": len(others),
        "truth_lags_deg": lags,
        "truth_uncertainty_deg": float(np.sqrt(np.nansum(parts**2))),
    }


def _long_axis_checks(sensor, new, R, R_marker, bout, fs_hz: float, lag: int, standing) -> dict:
    """``long_axis_check_deg`` and ``marker_frame_long_axis_check_deg``: the heading correction
    (deg, unsigned) that the angular velocity of the segment's long axis asks of each truth
    (:func:`aceval.data.truth.long_axis_heading_deg`); NaN without a long axis.
    """
    from aceval.data.truth import long_axis_heading_deg

    line = sensor.get("long_axis")
    if not line:
        return {"long_axis_check_deg": np.nan, "marker_frame_long_axis_check_deg": np.nan}
    a, b = bout
    start = new["start"]
    bias = sensor["gyr"][standing[0] : standing[1]].mean(axis=0)
    correction = long_axis_heading_deg(
        new["orientation"][a - start : b - start],
        sensor["gyr"][a + lag : b + lag] - bias,
        line[0][a:b],
        line[1][a:b],
        fs_hz,
    )
    # the marker-frame truth differs from this one by a turn about the vertical (both match the
    # accelerometer's vertical exactly): theta about body z (down) is -theta about world z (up),
    # so the marker frame's correction is this one plus theta
    theta = np.degrees(Rotation.from_matrix(R_marker @ R.T).as_rotvec()[2])
    marker = (correction + theta + 180.0) % 360.0 - 180.0
    return {"long_axis_check_deg": abs(correction), "marker_frame_long_axis_check_deg": abs(marker)}


def _truth_columns(sensor: dict, new: dict, old: dict, R, R_marker, twist, checks: dict) -> dict:
    """One sensor's row of :func:`truth_rows` after its identity: the truth R, its uncertainty
    and checks (``checks``), both methods' diagnostics, their difference, the marker frame's twist
    and the flags.
    """
    from aceval.data.rotations import error_angle_deg

    difference = float(error_angle_deg(R, R_marker))
    return {
        **{f"r{i + 1}{j + 1}": R[i, j] for i in range(3) for j in range(3)},
        "sensor_id": sensor["sensor_id"],
        "segment": sensor["segment"],
        "side": sensor["side"],
        "method": "optical point acceleration, from standing to the end of the first straight walk",
        "lag_samples": old["lag_samples"],
        "rms_misfit_m_s2": new["rms_misfit_m_s2"],
        **checks,
        "n_samples": new["n_samples"],
        "lever_arm_x_m": new["lever_arm_m"][0],
        "lever_arm_y_m": new["lever_arm_m"][1],
        "lever_arm_z_m": new["lever_arm_m"][2],
        "lever_arm_m": float(np.linalg.norm(new["lever_arm_m"])),
        **{f"marker_frame_{k}": v for k, v in old.items() if k != "lag_samples"},
        **{f"marker_frame_r{i + 1}{j + 1}": R_marker[i, j] for i in range(3) for j in range(3)},
        "methods_differ_deg": difference,
        "twist_mean_deg": float(np.mean(twist)),
        "twist_p5_deg": float(np.percentile(twist, 5)),
        "twist_p95_deg": float(np.percentile(twist, 95)),
        "flag": ";".join(
            name
            for name, raised in (
                ("methods_differ", difference > MAX_METHOD_DIFFERENCE_DEG),
                ("truth_unstable", checks["truth_uncertainty_deg"] > MAX_METHOD_DIFFERENCE_DEG),
            )
            if raised
        ),
    }


def _with_pair_consistency(table: pd.DataFrame, kept: dict) -> pd.DataFrame:
    """``pair_heading_deg`` and ``pair_tilt_deg`` of two sensors on one segment (their
    gyroscopes' relative rotation against their truths', split about the body vertical:
    :func:`aceval.data.truth.pair_consistency_deg`); NaN for a sensor alone on its segment.
    """
    from aceval.data.truth import pair_consistency_deg

    table["pair_heading_deg"], table["pair_tilt_deg"] = np.nan, np.nan
    for key_a, (segment_a, gyr_a, R_a) in kept.items():
        for key_b, (segment_b, gyr_b, R_b) in kept.items():
            if segment_a == segment_b and key_a[0] < key_b[0]:
                heading, tilt = pair_consistency_deg(gyr_a, gyr_b, R_a, R_b)
                for key in (key_a, key_b):
                    same = (table["sensor_set"] == key[0]) & (table["imu"] == key[1])
                    table.loc[same, ["pair_heading_deg", "pair_tilt_deg"]] = heading, tilt
    return table


def body_ml(markers: dict, standing: tuple[int, int]) -> np.ndarray:
    """Unit medial-lateral axis of the body (world coordinates, pointing right) while standing."""
    left, right = BODY_ML_MARKERS
    ml = (markers[right] - markers[left])[standing[0] : standing[1]].mean(axis=0)
    return ml / np.linalg.norm(ml)
