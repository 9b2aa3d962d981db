"""Ground truth from Vicon markers: each sensor's rotation to Kong's body frame.

Method (documented in config/README.md "Real datasets", with its uncertainty):

1. Segment frames from markers (low-passed at 6 Hz, zero phase): three points rigid with each
   segment (:data:`SEGMENT_MARKERS`) give an orthonormal frame ``R_world_seg(t)``.
2. Optical angular velocity in the segment frame from consecutive frames (central difference of
   ``R(t-1)^T R(t+1)``); the gyroscope is low-passed alike and its bias (mean while standing) removed.
3. Time alignment: the lag (within +-0.3 s) that maximises the correlation of the two angular
   speeds during the walk.
4. ``R_seg_sensor`` = the rotation that maps the accelerometer's vertical while standing exactly
   onto the Vicon vertical in the segment frame, and best maps gyroscope onto optical angular
   velocity over the walk about it (Wahba problem with one exact pair,
   ``scipy.spatial.transform.Rotation.align_vectors`` with an infinite weight). Quiet standing
   gives the vertical to better than a degree; walking, mostly about one axis, gives the rest.
5. Kong's whole-body frame while standing (what Kong's calibration estimates for every IMU): z
   down (world vertical), y the body's medial-lateral axis (:data:`BODY_ML_MARKERS`, pointing
   right) made horizontal, x = y x z. ``R_true = B @ R_world_seg(standing) @ R_seg_sensor``. A
   segment whose own flexion axis is turned from the body's (toe-out of the feet, tibial torsion)
   is therefore a real error of Kong's plane, not of the truth.

Uncertainty reported per sensor: the lag, the RMS misfit of the angular velocities, the angle
between the fits on the first and second half of the walk (``split_half_deg``), and
``vertical_check_deg``: the tilt between the accelerometer's vertical and the one a fit of the
angular velocities alone (without step 4's exact pair) carries into the sensor frame, an
independent check of the optical-inertial alignment. Because the vertical is the accelerometer's,
Kong's z0 agrees with the truth by construction: the error against it is the heading (the
medial-lateral axis), the part Kong's PCA estimates.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from .common import FormatError

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


def best_lag(optical: np.ndarray, gyr: np.ndarray, span: tuple[int, int], fs_hz: float) -> int:
    """Lag (samples; gyroscope sample ``t + lag`` matches optical ``t``) maximising the correlation
    of the angular speeds within ``span``.
    """
    a, b = span
    limit = int(MAX_LAG_S * fs_hz)
    speed_opt, speed_gyr = np.linalg.norm(optical, axis=1), np.linalg.norm(gyr, axis=1)
    lags = [lag for lag in range(-limit, limit + 1) if a + lag >= 0 and b + lag <= len(gyr)]
    scores = [np.corrcoef(speed_opt[a:b], speed_gyr[a + lag : b + lag])[0, 1] for lag in lags]
    return int(lags[int(np.argmax(scores))])


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
    segment: str,
    side: str,
    gyr: np.ndarray,
    acc: np.ndarray,
    standing: tuple[int, int],
    walk: tuple[int, int],
    fs_hz: float,
) -> dict:
    """The true sensor-to-body rotation of one sensor and its uncertainty (module docstring)."""
    key = (segment, side)
    if key not in SEGMENT_MARKERS:
        raise FormatError(f"no Vicon marker set for segment {segment} ({side})")
    n = len(next(iter(markers.values())))
    if len(gyr) != n:
        raise FormatError(
            f"Vicon has {n} frames, the sensor {len(gyr)} samples: not the same trial"
        )
    frames = segment_frames(markers, SEGMENT_MARKERS[key], fs_hz)
    optical = optical_angular_velocity(frames, fs_hz)
    bias = gyr[standing[0] : standing[1]].mean(axis=0)
    gyr_filtered = _lowpass(gyr - bias, fs_hz)
    lag = best_lag(optical, gyr_filtered, walk, fs_hz)
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
    R = body_axes(body_ml(markers, standing)) @ (stand_frames * rotation).as_matrix()
    return {
        "R": R,
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


def ground_truth_table(
    markers: dict, imports: dict, imus: pd.DataFrame, subject: str
) -> pd.DataFrame:
    """One row per sensor: the true R (r11..r33) and the uncertainty columns."""
    spans, fs_hz = imports["spans"], imports["fs_hz"]
    standing = spans["T0"][0]
    walk = (spans["T6"][0][0], spans["T6"][-1][1])
    forward = forward_check(markers, spans["T6"][0])
    heading_error = float(
        np.degrees(np.arccos(np.clip(body_axes(body_ml(markers, standing))[0] @ forward, -1, 1)))
    )
    if heading_error > 45:
        raise FormatError(
            f"the body frame's x axis is {heading_error:.0f} deg from the walking direction: "
            f"are the {', '.join(BODY_ML_MARKERS)} markers swapped?"
        )
    rows = []
    for (sensor_set, imu), (gyr, acc) in imports["signals"].items():
        segment, side = imus.loc[
            (imus["sensor_set"] == sensor_set) & (imus["imu"] == imu), ["segment", "side"]
        ].iloc[0]
        truth = ground_truth(markers, segment, side, gyr, acc, standing, walk, fs_hz)
        R = truth.pop("R")
        rows.append(
            {
                "subject": subject,
                "sensor_set": sensor_set,
                "imu": imu,
                **{f"r{i + 1}{j + 1}": R[i, j] for i in range(3) for j in range(3)},
                "sensor_id": imports["sensor_ids"][(sensor_set, imu)],
                "segment": segment,
                "side": side,
                **truth,
                "heading_vs_walk_deg": heading_error,
            }
        )
    return pd.DataFrame(rows)


def body_ml(markers: dict, standing: tuple[int, int]) -> np.ndarray:
    """Unit medial-lateral axis of the body (world coordinates, pointing right) while standing."""
    left, right = BODY_ML_MARKERS
    ml = (markers[right] - markers[left])[standing[0] : standing[1]].mean(axis=0)
    return ml / np.linalg.norm(ml)
