"""The file interface between aceval and a peer tool, run with the peer's own interpreter.

aceval cannot share an environment with its peers (gaitmap needs numpy < 2.1, OpenSim >= 2.1,
aceval's results are made with its own lock), so each peer runs in ``.venv-peers/<peer>`` and
this module, which needs NumPy (and pyarrow for Parquet recordings) only, is all it shares with
aceval:

* in: a calibration plan (JSON, written by ``aceval calibrate --plan-out``): the dataset folder,
  its sampling rate and unit factors, and per calibration the IMU, segment, side, test, the
  sensor axis declared to point right (``right_axis``, a unit vector: it fixes the signs every
  method needs, as it does Kong's), the static and motion recording files that aceval's own pass
  found usable, the sample ranges of each motion file that aceval's methods read (``kept``: the
  movement windows of Kong's trimming, clipped samples left out; :func:`kept_samples`), and the
  subsets of repetitions to calibrate from (all of them and every k-subset);
* out: one CSV row per calibration and subset in aceval's convention: ``r11..r33`` of R mapping
  sensor-frame vectors into Kong's body frame (x forward, y right, z down), the peer's own axis
  and its eigenvalue ratio (:data:`AXIS_COLUMNS`, for aceval's gate), ``flag`` and ``note`` when
  the peer cannot give one, and ``seconds`` (the peer's own computation, file reading left out).
"""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

COLUMNS = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
R_COLUMNS = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
#: the peer's own medial-lateral axis in the sensor frame, before frame_from_axes removes its
#: vertical part, and the ratio of the eigenvalues that decide it (second / first; NaN when the
#: method has none): what aceval's gate reads (axis near the vertical, axis undetermined)
AXIS_COLUMNS = ["axis_x", "axis_y", "axis_z", "axis_variance_ratio"]
OUT_COLUMNS = [
    "subject",
    "sensor_set",
    "imu",
    "segment",
    "side",
    "test",
    "repetitions",
    "n_reps",
    "method",
    *R_COLUMNS,
    *AXIS_COLUMNS,
    "flag",
    "note",
    "seconds",
]


def read_plan(path: str) -> dict:
    """The calibration plan (module docstring)."""
    return json.loads(Path(path).read_text())


def read_columns(plan: dict, relative: str, names: list[str]) -> np.ndarray | None:
    """The (N, len(names)) values of these columns of a recording of the plan's dataset (a CSV,
    or Parquet: the format of aceval's simulated datasets), or None when it lacks one.
    """
    path = Path(plan["dataset"]) / relative
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq

        recording = pq.ParquetFile(path, pre_buffer=False)
        if not set(names) <= set(recording.schema_arrow.names):
            return None
        table = recording.read(columns=names, use_threads=False)
        return np.column_stack([table.column(c).to_numpy().astype(float) for c in names])
    with open(path, newline="") as handle:
        header = next(csv.reader(handle))
    if not set(names) <= set(header):
        return None
    columns = [header.index(c) for c in names]
    return np.loadtxt(path, delimiter=",", skiprows=1, usecols=columns, ndmin=2)


def read_recording(plan: dict, relative: str) -> tuple[np.ndarray, np.ndarray]:
    """(acc m/s^2, gyr rad/s), each (N, 3), of a recording of the plan's dataset."""
    values = read_columns(plan, relative, COLUMNS[1:])
    return values[:, :3] * plan["acc_scale"], values[:, 3:] * plan["gyr_scale"]


def kept_samples(entry: dict, rep, n: int | None = None) -> np.ndarray:
    """The indices of repetition ``rep``'s samples that aceval's methods read (the plan's
    ``kept`` ranges), below ``n`` when given (two recordings cut to the shorter one).
    """
    ranges = entry["kept"][str(rep)]
    index = np.concatenate([np.arange(a, b) for a, b in ranges]) if ranges else np.arange(0)
    return index if n is None else index[index < n]


def frame_from_axes(down: np.ndarray, right: np.ndarray, right_axis: np.ndarray) -> np.ndarray:
    """R (sensor -> Kong's body frame: x forward, y right, z down) from the sensor-frame downward
    vertical and a medial-lateral axis, the latter made orthogonal to the vertical (Kong Eq. 4-5:
    x = y x z, then y = z x x) and then signed to point along the declared right axis (after the
    projection, as :func:`aceval.methods.kong.kong_from_scatters` does: for an axis near the
    vertical the raw vector and its horizontal part can point to opposite sides).
    """
    z = np.asarray(down, float) / np.linalg.norm(down)
    x = np.cross(np.asarray(right, float), z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)  # the axis' part orthogonal to the vertical, as a unit vector
    if y @ np.asarray(right_axis, float) < 0:  # its sign fixed after the projection, as Kong's
        x, y = -x, -y
    return np.vstack([x, y, z])


def subset_label(subset) -> str:
    """``[1, 3]`` -> ``'R1+R3'`` (aceval's label of a subset of repetitions)."""
    return "+".join(f"R{r}" for r in subset)


def row(
    entry: dict,
    subset,
    method: str,
    R=None,
    seconds=float("nan"),
    flag="",
    note="",
    axis=None,
    axis_variance_ratio=float("nan"),
) -> dict:
    """An output row for one calibration (R None: not calibrated, ``flag`` and ``note`` say why;
    ``axis``: the peer's medial-lateral axis in the sensor frame, see :data:`AXIS_COLUMNS`).
    """
    values = np.full(9, np.nan) if R is None else np.asarray(R, float).ravel()
    axis = np.full(3, np.nan) if axis is None else np.ravel(axis) / np.linalg.norm(axis)
    return {
        **{k: entry[k] for k in ("subject", "sensor_set", "imu", "segment", "side", "test")},
        "repetitions": subset_label(subset),
        "n_reps": len(subset),
        "method": method,
        **dict(zip(R_COLUMNS, values)),
        **dict(zip(AXIS_COLUMNS, [*axis, axis_variance_ratio])),
        "flag": flag,
        "note": note,
        "seconds": seconds,
    }


def write_rows(path: str, rows: list[dict]) -> None:
    """The output CSV, written to a temporary file and moved into place (nothing partial)."""
    out = Path(path)
    tmp = out.with_name(f".tmp.{out.name}")
    with open(tmp, "w", newline="") as handle:
        writer = csv.DictWriter(handle, OUT_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    tmp.replace(out)


class Timer:
    """``with Timer() as t: ...`` then ``t.seconds``."""

    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.start


def main(calibrate) -> None:
    """``python <adapter>.py PLAN OUT``: ``calibrate(plan) -> rows`` written to OUT."""
    if len(sys.argv) != 3:
        raise SystemExit(f"usage: {Path(sys.argv[0]).name} PLAN.json OUT.csv")
    plan = read_plan(sys.argv[1])
    write_rows(sys.argv[2], calibrate(plan))
