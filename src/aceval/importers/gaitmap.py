"""gaitmap's example recording: both feet, IMU with optical markers -> the dataset contract, with a
ground truth from the markers.

Format (../shared/data/README.md): ``imu_sample_not_rotated.csv``, one IMU per foot in its own
frame, 204.8 Hz, two header rows (sensor, axis), acc m/s^2, gyr deg/s; ``mocap_sample.csv``,
toe (TOE), heel (FCC) and fifth metatarsal head (FM5) of each foot, mm, 100 Hz, same trial. A
sensor sheet (config/real/gaitmap_feet_sensors.tsv: ``name prefix imu segment side region
right_axis``) names each sensor and its markers.

Rules (config/README.md "Real datasets"):

* The markers are resampled to the IMU's times (linear interpolation) and low-passed at 6 Hz
  once, by the truth.
* T0 = quiet standing: from the start to 0.2 s before the first movement (Kong's trimmer on
  either foot), at least 0.5 s (the trial has about 0.9 s).
* T6 = straight walking: strides from the left foot's angular speed; a stride during which a
  foot's heading (its angular velocity about its standing vertical, integrated) turns by 20 deg
  or more is left out (the turn between the two 20 m walks); at most 5 repetitions of equal
  numbers of whole strides.
* Ground truth (:func:`aceval.importers.vicon.truth_rows`): the optical point acceleration method
  (the heel marker, lever arm fitted) beside the marker-frame method (foot frame: heel, toe, fifth
  metatarsal head). There are no pelvis markers: Kong's body frame is x = the walking direction
  (horizontal heel progression over the first straight walk), z down, y = z x x (right). A foot's
  toe-out is then a real error of Kong's plane, as for the NeuRA trial.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers.shared import (
    FormatError,
    ImportReport,
    first_stretch,
    read_sensor_sheet,
    straight_strides,
    stride_peaks,
    stride_spans,
    walking_bouts,
)
from aceval.signals.segmentation import movement_mask

SHEET_COLUMNS = ["name", "prefix", "imu", "segment", "side", "region", "right_axis"]
IMU_RATE_HZ = 204.8
MOCAP_RATE_HZ = 100.0
STANDING_MARGIN_S = 0.2
MIN_STANDING_S = 0.5
#: the foot frame's three markers (origin, along, in-plane), the point matched and the foot's long
#: axis (heel to toe: the independent check of the truth's heading)
FRAME, POINT, LONG_AXIS = ("FCC", "TOE", "FM5"), "FCC", ("FCC", "TOE")
#: Xsens/NilsPod-class IMU ranges of gaitmap's example: +-16 g, +-2000 deg/s
ACC_RANGE_G, GYR_RANGE_DPS = 16.0, 2000.0


def read_two_header_csv(path: Path) -> pd.DataFrame:
    """A CSV with two header rows (name, axis) and an index column; FormatError names the cause."""
    try:
        table = pd.read_csv(path, header=[0, 1], index_col=0)
    except Exception as exc:  # pandas raises many types for a damaged file
        raise FormatError(f"{path}: cannot be read as a CSV with two header rows: {exc}") from exc
    if table.isna().any().any():
        raise FormatError(f"{path}: {int(table.isna().any(axis=1).sum())} rows with missing values")
    return table


def resample(values: np.ndarray, fs_from: float, n_to: int, fs_to: float) -> np.ndarray:
    """Linear interpolation of (N, 3) samples at ``fs_from`` onto ``n_to`` samples at ``fs_to``
    (both starting at t = 0; held constant beyond the last sample).
    """
    t_from = np.arange(len(values)) / fs_from
    t_to = np.arange(n_to) / fs_to
    return np.column_stack([np.interp(t_to, t_from, values[:, k]) for k in range(values.shape[1])])


def import_gaitmap(
    src: str | Path, out: Path, sensors: str | Path, subject: str = "S01", name: str = "gaitmap"
) -> tuple:
    """Convert the example (``src``: its folder) into a dataset at ``out``; returns the report and
    the truth table (:func:`aceval.importers.vicon.truth_rows`), which the caller writes.
    """
    src = Path(src)
    sheet = read_sensor_sheet(sensors, SHEET_COLUMNS)
    signals, markers = _read(src, sheet)
    spans = _spans(signals, sheet, IMU_RATE_HZ)
    truth = _truth(sheet, signals, markers, spans)
    truth.insert(0, "subject", subject)
    meta = {
        "name": name,
        "description": "gaitmap example (both feet, IMU with optical markers), recorded data, imported by "
        "aceval import gaitmap; ground truth from the markers",
        "simulated": False,
        "sampling_rate_hz": IMU_RATE_HZ,
        "units": {"acc": "m/s^2", "gyr": "rad/s"},
        "acc_at_rest": "up",  # the importer writes specific force
        "sensor_sets": ["main"],
        "acc_range_g": {"lower_body": ACC_RANGE_G},
        "gyr_range_dps": GYR_RANGE_DPS,
    }
    report = ImportReport()
    writer = DatasetWriter(out, meta)
    for row in sheet.to_dict("records"):
        gyr, acc = signals[row["imu"]]
        for test in ("T0", "T6"):
            for rep, (a, b) in enumerate(spans[test], start=1):
                writer.recording(subject, "main", test, rep, row["imu"], gyr[a:b], acc[a:b])
        report.add(
            "imu_sample_not_rotated.csv",
            subject,
            row["imu"],
            "imported",
            f"T0 x{len(spans['T0'])}; T6 x{len(spans['T6'])}",
        )
    writer.protocol_sheets(
        {
            "T0": ("static", "quiet standing at the start"),
            "T6": ("motion", "straight walking (20 m, twice)"),
        },
        {test: len(spans[test]) for test in ("T0", "T6")},
        {"T6": list(sheet["imu"])},
    )
    writer.close()
    write_sheet(out / "subjects.tsv", ["subject"], [[subject]])
    write_sheet(
        out / "imus.tsv",
        ["imu", "sensor_set", "segment", "side", "region", "right_axis"],
        [
            [r["imu"], "main", r["segment"], r["side"], r["region"], r["right_axis"]]
            for r in sheet.to_dict("records")
        ],
    )
    return report, truth


def _read(src: Path, sheet: pd.DataFrame) -> tuple[dict, dict]:
    """``(signals, markers)``: each sensor's (gyr rad/s, acc m/s^2) and each marker of its frame
    (m, resampled to the IMU's samples; the truth low-passes them, once).
    """
    imu = read_two_header_csv(src / "imu_sample_not_rotated.csv")
    mocap = read_two_header_csv(src / "mocap_sample.csv")
    signals, markers = {}, {}
    for row in sheet.to_dict("records"):
        if row["name"] not in imu.columns.get_level_values(0):
            raise FormatError(f"{src / 'imu_sample_not_rotated.csv'}: no sensor {row['name']}")
        part = imu[row["name"]]
        acc = part[["acc_x", "acc_y", "acc_z"]].to_numpy(float)
        gyr = np.radians(part[["gyr_x", "gyr_y", "gyr_z"]].to_numpy(float))
        signals[row["imu"]] = (gyr, acc)
        for marker in FRAME:
            label = f"{row['prefix']}_{marker}"
            if label not in mocap.columns.get_level_values(0):
                raise FormatError(f"{src / 'mocap_sample.csv'}: no marker {label}")
            position = mocap[label][["x", "y", "z"]].to_numpy(float) / 1000.0
            markers[label] = resample(position, MOCAP_RATE_HZ, len(imu), IMU_RATE_HZ)
    return signals, markers


def _truth(sheet: pd.DataFrame, signals: dict, markers: dict, spans: dict) -> pd.DataFrame:
    """The feet's ground truth (:func:`aceval.importers.vicon.truth_rows`) in Kong's body frame of
    the walking direction: the heels' horizontal progression in the first straight.
    """
    from aceval.importers.vicon import body_axes, truth_rows

    heels = np.mean([markers[f"{p}_{POINT}"] for p in sheet["prefix"]], axis=0)
    a, b = spans["first_straight"][0]
    forward = heels[b - 1] - heels[a]
    forward[2] = 0.0
    forward /= np.linalg.norm(forward)
    B = body_axes(np.array([forward[1], -forward[0], 0.0]))  # right = forward x up, world z up
    sensors = {
        ("main", row["imu"]): dict(
            segment=row["segment"],
            side=row["side"],
            gyr=signals[row["imu"]][0],
            acc=signals[row["imu"]][1],
            frame=tuple(f"{row['prefix']}_{m}" for m in FRAME),
            point=markers[f"{row['prefix']}_{POINT}"],
            points={m: markers[f"{row['prefix']}_{m}"] for m in FRAME},
            long_axis=tuple(markers[f"{row['prefix']}_{m}"] for m in LONG_AXIS),
            sensor_id=row["name"],
        )
        for row in sheet.to_dict("records")
    }
    return truth_rows(markers, sensors, spans, IMU_RATE_HZ, B)


def _spans(signals: dict, sheet: pd.DataFrame, fs_hz: float) -> dict:
    """T0, T6 and the first straight stretch (the module's rules)."""
    masks = [movement_mask(gyr, fs_hz) for gyr, _ in signals.values()]
    onset = int(np.flatnonzero(np.any(masks, axis=0))[0])
    standing_end = onset - int(STANDING_MARGIN_S * fs_hz)
    if standing_end < MIN_STANDING_S * fs_hz:
        raise FormatError(
            f"only {standing_end / fs_hz:.2f} s of standing before the first movement"
        )
    spans = {"T0": [(0, standing_end)]}
    first = sheet["imu"].iloc[0]
    gyr, acc = signals[first]
    vertical = acc[:standing_end].mean(axis=0)
    yaw = gyr @ (vertical / np.linalg.norm(vertical))
    strides = [(onset + a, onset + b) for a, b in stride_spans(stride_peaks(gyr[onset:], fs_hz))]
    straight = straight_strides(strides, yaw, fs_hz)
    bouts = walking_bouts(straight)
    if not bouts:
        raise FormatError("no straight walking found")
    spans["T6"] = bouts
    stretch = first_stretch(straight)
    spans["first_straight"] = [(stretch[0][0], stretch[-1][1])]
    spans["strides"] = stretch  # the truth's per-stride uncertainty reads them
    return spans
