"""The qmt toolbox's full-body example recording -> the dataset contract (one subject, 16 IMUs).

Format (../shared/data/README.md): ``full_body_example_data.mat`` (MATLAB v5) with ``t`` (s,
100 Hz) and one struct per segment with ``acc`` (m/s^2, specific force), ``gyr`` (rad/s) and the
vendor's ``quat``. A sensor sheet (tab-separated: ``name imu segment side region right_axis``;
config/real/qmt_sensors.tsv) says which struct is which IMU; structs not in it (arms, hands) are
not imported.

Rules (documented in config/README.md "Real datasets"):

* T0 = quiet standing: from the start until the thighs' inclination (angle of the specific force
  from its direction in the first second) first exceeds 10 deg, less 0.5 s.
* T3 = the two transitions around sitting, found from the thighs' inclination (sitting: above
  60 deg): R1 stand-to-sit, from the last standing sample (below 10 deg) before sitting to the
  first sitting one, R2 sit-to-stand, from the last sitting sample to the first standing one,
  each with 0.5 s on either side. The two move in opposite directions, so tests.tsv gives T3 no
  ``first_phase`` (no direction check).
* T6 = straight walking after the sitting: strides from the right shank's angular speed, a
  stride whose pelvis heading turns by 20 deg or more left out, grouped into at most 5
  repetitions of equal numbers of whole strides (:func:`aceval.importers.shared.walking_bouts`).
* Which test may calibrate which IMU: Kong Table 2 (T3: head, chest, waist, thighs; T6: thighs,
  shanks, feet) plus what this recording allows to compare: the lower back with T3, the shanks
  with T3, the pelvis and lower back with T6 (cross-test T3 vs T6 for the trunk and shanks).
* The vendor's ``quat`` is not imported: it gives no common vertical. Mapped by it, the sensors'
  standing specific forces point up to 67-99 deg apart in its world (head vs right foot; 67 deg
  in the most favourable of the four readings, scalar first or last, either direction), so its
  frame is not the accelerometer's, and the OpenSense peer, which needs orientations in one
  gravity-aligned world, cannot use it.
* No ground truth. The publishers' hand-tuned segment-to-sensor quaternions
  (``hand_tuned_segment2sensor.tsv``, ISB segment frames: x forward, y up, z right) were set by
  eye for a visualisation: they give the sheet's ``right_axis`` signs (checked by aceval's
  direction checks) and are written as ``loose_reference.tsv`` (:func:`loose_reference`: each
  segment's right and up axes in sensor coordinates) for comparing orders of magnitude, never as
  truth. The quaternion maps segment to sensor coordinates: so read, the segment's up lies within
  2-9 deg of the accelerometer's vertical while standing for every imported IMU (read the other
  way, 28-176 deg); ``standing_up_angle_deg`` keeps that check per IMU.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from aceval.data.writer import DatasetWriter, write_sheet
from aceval.importers import shared
from aceval.importers.shared import (
    FormatError,
    ImportReport,
    straight_strides,
    stride_peaks,
    stride_spans,
    walking_bouts,
)

SHEET_COLUMNS = ["name", "imu", "segment", "side", "region", "right_axis"]
STANDING_DEG, SITTING_DEG = 10.0, 60.0
MARGIN_S = 0.5
TESTS = {
    "T0": ("static", "quiet standing at the start"),
    "T3": ("motion", "R1 stand-to-sit, R2 sit-to-stand (opposite directions: no first_phase)"),
    "T6": (
        "motion",
        "straight walking after sitting, repetitions of equal numbers of whole strides",
    ),
}
CALIBRATES = {
    "T3": ("head", "chest", "waist", "lower_back", "thigh", "shank"),
    "T6": ("thigh", "shank", "foot", "waist", "lower_back"),
}
#: Xsens MTw (the qmt example's sensors): +-16 g, +-2000 deg/s
ACC_RANGE_G, GYR_RANGE_DPS = 16.0, 2000.0


def read_qmt(path: str | Path) -> tuple[np.ndarray, dict]:
    """(t, {struct name: (acc, gyr)}) of the example .mat; FormatError names the file and cause."""
    from scipy.io import loadmat

    try:
        content = loadmat(path, squeeze_me=True, struct_as_record=False)
    except Exception as exc:  # scipy raises several types for a damaged file
        raise FormatError(f"{path}: cannot be read as a MATLAB file: {exc}") from exc
    if "t" not in content:
        raise FormatError(f"{path}: no time vector 't'")
    t = np.asarray(content["t"], float).ravel()
    segments = {}
    for name, value in content.items():
        if hasattr(value, "acc") and hasattr(value, "gyr"):
            acc, gyr = np.asarray(value.acc, float), np.asarray(value.gyr, float)
            if acc.shape != (len(t), 3) or gyr.shape != (len(t), 3):
                raise FormatError(
                    f"{path}: {name}: acc {acc.shape} and gyr {gyr.shape}, expected ({len(t)}, 3)"
                )
            segments[name] = (acc, gyr)
    if not segments:
        raise FormatError(f"{path}: no struct with acc and gyr")
    return t, segments


def inclination_deg(acc: np.ndarray, fs_hz: float) -> np.ndarray:
    """Angle (deg) of the specific force from its mean direction in the first second, smoothed
    over 0.5 s: 0 standing, about 80 for a thigh when seated.
    """
    unit = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    reference = unit[: int(fs_hz)].mean(axis=0)
    angle = np.degrees(
        np.arccos(np.clip(unit @ (reference / np.linalg.norm(reference)), -1.0, 1.0))
    )
    return uniform_filter1d(angle, max(1, int(0.5 * fs_hz)))


def protocol_spans(
    thigh_acc: np.ndarray, shank_gyr: np.ndarray, yaw_rate: np.ndarray, fs_hz: float
) -> dict:
    """Sample ranges of T0, T3 (two transitions) and T6 (the module's rules)."""
    inclination = inclination_deg(thigh_acc, fs_hz)
    margin = int(MARGIN_S * fs_hz)
    sitting = np.flatnonzero(inclination > SITTING_DEG)
    if not len(sitting):
        raise FormatError("no sitting found (thigh inclination never above 60 deg)")
    first_sit, last_sit = int(sitting[0]), int(sitting[-1])
    standing_before = np.flatnonzero(inclination[:first_sit] < STANDING_DEG)
    standing_after = np.flatnonzero(inclination[last_sit:] < STANDING_DEG)
    if not len(standing_before) or not len(standing_after):
        raise FormatError("expected standing before and after sitting")
    leave = int(standing_before[-1])
    arrive = last_sit + int(standing_after[0])
    onset = int(np.argmax(inclination > STANDING_DEG))
    spans = {
        "T0": [(0, max(1, onset - margin))],
        "T3": [(max(0, leave - margin), first_sit + margin), (last_sit - margin, arrive + margin)],
    }
    start = arrive + margin
    strides = [
        (start + a, start + b) for a, b in stride_spans(stride_peaks(shank_gyr[start:], fs_hz))
    ]
    bouts = walking_bouts(straight_strides(strides, yaw_rate, fs_hz))
    if not bouts:
        raise FormatError("no straight walking found after sitting")
    spans["T6"] = bouts
    return spans


REFERENCE_FILE = "hand_tuned_segment2sensor.tsv"


def loose_reference(
    reference: pd.DataFrame, sheet: pd.DataFrame, segments: dict, standing: tuple[int, int]
) -> pd.DataFrame:
    """Per IMU of ``sheet``: the hand-tuned segment's right (ISB z) and up (ISB y) axes in sensor
    coordinates (``right_x..z``, ``up_x..z``) and the angle (deg) between that up and the
    accelerometer's vertical while ``standing`` (a check of the reading, not a truth).
    """
    rows = []
    for row in sheet.to_dict("records"):
        if row["name"] not in reference.index:
            continue
        q = reference.loc[row["name"], [f"q_segment2sensor_{c}" for c in "xyzw"]].to_numpy(float)
        segment_to_sensor = Rotation.from_quat(q)
        right, up = segment_to_sensor.apply([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
        measured = segments[row["name"]][0][standing[0] : standing[1]].mean(axis=0)
        cosine = up @ measured / np.linalg.norm(measured)
        rows.append(
            {
                "sensor_set": "main",
                "imu": row["imu"],
                **dict(zip(("right_x", "right_y", "right_z"), right)),
                **dict(zip(("up_x", "up_y", "up_z"), up)),
                "standing_up_angle_deg": float(np.degrees(np.arccos(np.clip(cosine, -1, 1)))),
                "source": f"{REFERENCE_FILE} (hand-tuned for a visualisation: not a truth)",
            }
        )
    return pd.DataFrame(rows)


def read_sensor_sheet(path: str | Path) -> pd.DataFrame:
    """The sensor sheet (``SHEET_COLUMNS``, tab-separated, ``#`` comments)."""
    return shared.read_sensor_sheet(path, SHEET_COLUMNS)


def import_qmt(
    src: str | Path, out: Path, sensors: str | Path, subject: str = "S01", name: str = "qmt"
) -> ImportReport:
    """Convert the example recording (``src``: the .mat or its folder) into a dataset at ``out``."""
    src = Path(src)
    path = src / "full_body_example_data.mat" if src.is_dir() else src
    if not path.is_file():
        raise FormatError(
            f"{path}: not found (the qmt toolbox's examples/full_body_example_data.mat)"
        )
    t, segments = read_qmt(path)
    fs_hz = float(round(1.0 / np.median(np.diff(t)), 6))
    sheet = read_sensor_sheet(sensors)
    missing = sorted(set(sheet["name"]) - set(segments))
    if missing:
        raise FormatError(f"{path}: no struct(s) {', '.join(missing)} named in {sensors}")
    report = ImportReport()
    for struct in sorted(set(segments) - set(sheet["name"])):
        report.add(
            path.name,
            subject,
            struct,
            "skipped",
            "not in the sensor sheet (no test of Kong's calibrates it)",
        )
    by_segment = {(r["segment"], r["side"]): r["name"] for r in sheet.to_dict("records")}
    thigh = segments[by_segment[("thigh", "right")]][0]
    shank_gyr = segments[by_segment[("shank", "right")]][1]
    pelvis_acc, pelvis_gyr = segments[by_segment[("waist", "center")]]
    vertical = pelvis_acc[: int(fs_hz)].mean(axis=0)
    spans = protocol_spans(
        thigh, shank_gyr, pelvis_gyr @ (vertical / np.linalg.norm(vertical)), fs_hz
    )
    meta = {
        "name": name,
        "description": "qmt toolbox full-body example (one subject, 16 IMUs; Kong's segments imported), "
        "recorded data, imported by aceval import qmt; no ground truth",
        "simulated": False,
        "sampling_rate_hz": fs_hz,
        "units": {"acc": "m/s^2", "gyr": "rad/s"},
        "acc_at_rest": "up",  # the importer writes specific force
        "sensor_sets": ["main"],
        "acc_range_g": {region: ACC_RANGE_G for region in sorted(set(sheet["region"]))},
        "gyr_range_dps": GYR_RANGE_DPS,
    }
    writer = DatasetWriter(out, meta)
    for row in sheet.to_dict("records"):
        acc, gyr = segments[row["name"]]
        tests = ["T0"] + [test for test, allowed in CALIBRATES.items() if row["segment"] in allowed]
        for test in tests:
            for rep, (a, b) in enumerate(spans[test], start=1):
                writer.recording(subject, "main", test, rep, row["imu"], gyr[a:b], acc[a:b])
        report.add(
            path.name,
            subject,
            row["imu"],
            "imported",
            "; ".join(f"{t} x{len(spans[t])}" for t in tests),
        )
    _sheets(writer, out, sheet, spans, subject)
    _loose_reference(out, path, sheet, segments, spans, subject, report)
    return report


def _sheets(writer, out: Path, sheet, spans: dict, subject: str) -> None:
    """tests.tsv (T3 without a first phase: the two transitions turn opposite ways),
    calibrates.tsv, subjects.tsv and imus.tsv.
    """
    calibrates = {
        test: [r["imu"] for r in sheet.to_dict("records") if r["segment"] in allowed]
        for test, allowed in CALIBRATES.items()
    }
    writer.protocol_sheets(TESTS, {test: len(ranges) for test, ranges in spans.items()}, calibrates)
    writer.close()
    tests = pd.read_csv(out / "tests.tsv", sep="\t", dtype=str, keep_default_na=False)
    tests.loc[tests["test"] == "T3", "first_phase"] = ""  # the writer gives Kong's by name
    tests.to_csv(out / "tests.tsv", sep="\t", index=False)
    write_sheet(out / "subjects.tsv", ["subject"], [[subject]])
    write_sheet(
        out / "imus.tsv",
        ["imu", "sensor_set", "segment", "side", "region", "right_axis"],
        [
            [r["imu"], "main", r["segment"], r["side"], r["region"], r["right_axis"]]
            for r in sheet.to_dict("records")
        ],
    )


def _loose_reference(out: Path, path: Path, sheet, segments, spans, subject, report) -> None:
    """loose_reference.tsv from the publishers' hand-tuned quaternions beside the recording,
    when they are there (said in the report either way).
    """
    reference_path = path.parent / REFERENCE_FILE
    if reference_path.is_file():
        reference = pd.read_csv(reference_path, sep="\t").set_index("segment")
        table = loose_reference(reference, sheet, segments, spans["T0"][0])
        table.insert(0, "subject", subject)
        table.to_csv(out / "loose_reference.tsv", sep="\t", index=False, float_format="%.6g")
        report.add(reference_path.name, subject, "", "loose reference", "loose_reference.tsv")
    else:
        report.add(reference_path.name, subject, "", "skipped", "not found: no loose reference")
