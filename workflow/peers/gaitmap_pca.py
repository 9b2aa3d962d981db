"""gaitmap 2.6's sensor alignment as a calibration method (``gaitmap_pca``), in gaitmap's own
environment (.venv-peers/gaitmap): ``python gaitmap_pca.py PLAN.json OUT.csv`` (peer_io.py).

What gaitmap does, with its own functions: the vertical from the static samples of the quiet
standing recording (``find_static_samples`` on the gyroscope, the median accelerometer vector
rotated onto gravity by ``get_gravity_rotation``: what ``align_dataset_to_gravity`` does inside),
then the heading from ``PcaAlignment``: the first principal component of the gravity-aligned
gyroscope in the horizontal plane becomes the medial-lateral axis (its docs cite Kong 2016). The
motion samples are those aceval's methods read from the subset's repetitions (the plan's
``kept`` ranges: Kong's movement windows, clipped samples left out), so that every method sees
the same samples; gaitmap itself would take whole recordings (it trims nothing).
gaitmap leaves the sign of that axis open ("an additional 180 deg flip might still be
necessary"); it is set by the dataset's declared right axis, as for every aceval method.
Units as gaitmap wants them: acceleration m/s^2, angular velocity deg/s.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from gaitmap.preprocessing.sensor_alignment import PcaAlignment
from gaitmap.utils.consts import GRAV_VEC, SF_ACC, SF_GYR
from gaitmap.utils.rotations import get_gravity_rotation
from gaitmap.utils.static_moment_detection import find_static_samples
from peer_io import Timer, frame_from_axes, kept_samples, main, read_recording, row

METHOD = "gaitmap_pca"
#: gaitmap's defaults of align_dataset_to_gravity
WINDOW_S, STATIC_THRESHOLD_DEG_S = 0.7, 2.5


def sensor_data(acc: np.ndarray, gyr: np.ndarray) -> pd.DataFrame:
    """Gaitmap's single-sensor data: acc in m/s^2, gyr in deg/s."""
    return pd.DataFrame(np.column_stack([acc, np.degrees(gyr)]), columns=[*SF_ACC, *SF_GYR])


def gravity_rotation(static: pd.DataFrame, fs_hz: float) -> tuple:
    """Gaitmap's rotation of the sensor onto gravity (z up) from the quiet standing recording:
    the median accelerometer vector of its static windows, or of the whole recording when
    gaitmap finds none (a gyroscope bias above its 2.5 deg/s threshold, as the MPU-9250 datasheet
    allows, is enough; a standing shorter than its 0.7 s window, too); the note says which.
    """
    window = int(round(WINDOW_S * fs_hz))
    gyr = static[SF_GYR].to_numpy()
    note = ""
    try:
        still, *_ = find_static_samples(gyr, window, STATIC_THRESHOLD_DEG_S, "median")
    except ValueError as exc:  # e.g. standing shorter than gaitmap's window
        still = np.zeros(len(gyr), dtype=bool)
        note = f"gaitmap: {exc}; "
    if not np.any(still):
        still = np.ones(len(gyr), dtype=bool)
        note += (
            f"no static window at gaitmap's {STATIC_THRESHOLD_DEG_S} deg/s gyroscope threshold "
            f"and {WINDOW_S} s window: the whole quiet-standing recording used"
        )
    return get_gravity_rotation(np.median(static[SF_ACC].to_numpy()[still], axis=0), GRAV_VEC), note


def pca_rotation(gravity, motion: pd.DataFrame) -> tuple[np.ndarray, float, np.ndarray]:
    """Gaitmap's sensor -> aligned rotation (z up, y the gravity-aligned gyroscope's principal
    horizontal axis, x = y x z), the ratio of its PCA's two variances (second / first: near 1,
    the principal axis is undetermined), and the gyroscope's principal axis before gaitmap
    projects it on the horizontal (the first component of the same samples' 3-D PCA, centred as
    gaitmap's; sensor frame): what aceval's vertical gate judges, since gaitmap's own axis is
    horizontal by construction whatever the motion.
    """
    gyr = gravity.apply(motion[SF_GYR].to_numpy())
    aligned = pd.DataFrame(
        np.column_stack([gravity.apply(motion[SF_ACC].to_numpy()), gyr]),
        columns=[*SF_ACC, *SF_GYR],
    )
    pca = PcaAlignment(target_axis="y", pca_plane_axis=("gyr_x", "gyr_y")).align(aligned)
    variance = pca.pca_.explained_variance_
    _, vectors = np.linalg.eigh(np.cov(gyr.T))
    axis = gravity.inv().apply(vectors[:, -1])
    return (pca.rotation_ * gravity).as_matrix(), float(variance[1] / variance[0]), axis


def calibrate(plan: dict) -> list[dict]:
    """Every calibration of the plan (its subsets too) by gaitmap's alignment."""
    rows = []
    for entry in plan["calibrations"]:
        static = sensor_data(
            *map(np.vstack, zip(*(read_recording(plan, p) for p in entry["static"])))
        )
        reps = {}
        for k, path in entry["reps"].items():
            acc, gyr = read_recording(plan, path)
            kept = kept_samples(entry, k)
            reps[int(k)] = acc[kept], gyr[kept]
        with Timer() as gravity_timer:
            gravity, note = gravity_rotation(static, plan["fs_hz"])
        for subset in entry["subsets"]:
            motion = sensor_data(
                np.vstack([reps[r][0] for r in subset]), np.vstack([reps[r][1] for r in subset])
            )
            with Timer() as timer:
                aligned, ratio, axis = pca_rotation(gravity, motion)
            R = frame_from_axes(-aligned[2], aligned[1], entry["right_axis"])
            seconds = gravity_timer.seconds + timer.seconds  # one calibration: both steps
            rows.append(
                row(
                    entry,
                    subset,
                    METHOD,
                    R,
                    seconds,
                    note=note,
                    axis=axis,
                    axis_variance_ratio=ratio,
                )
            )
    return rows


if __name__ == "__main__":
    main(calibrate)
