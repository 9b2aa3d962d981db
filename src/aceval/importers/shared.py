"""Shared by the importers: format errors, sensor sheets, walking bouts from strides, the import
report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Kong's protocol: 5 repetitions of each motion test
MAX_REPETITIONS = 5
#: fewest whole strides in one walking repetition
MIN_STRIDES_PER_REPETITION = 1
#: a stride whose heading changes more than this (deg) is a turn and not used
MAX_TURN_DEG = 20.0
#: shortest plausible stride (s): peaks closer than this are one stride (fast walking: ~0.9 s)
MIN_STRIDE_S = 0.7
#: walking low-passed below the stride frequency (about 0.9 Hz) is the mean walking posture
MEAN_POSTURE_CUTOFF_HZ = 0.5


class FormatError(ValueError):
    """A foreign file does not have the format its importer reads; the message names the file,
    the line and the cause.
    """


@dataclass
class ImportReport:
    """What an importer wrote, left out or flagged, as rows for ``import_report.tsv``."""

    rows: list[dict] = field(default_factory=list)
    #: what the user should read on screen (a trim, a skipped file, an IMU left uncalibrated)
    notes: list[str] = field(default_factory=list)

    def note(self, text: str) -> None:
        """A line for the screen (``aceval import`` prints them)."""
        self.notes.append(text)

    def add(self, source: str, subject: str, imu: str, status: str, cause: str) -> None:
        """Record one imported, flagged, excluded or skipped item and why."""
        self.rows.append(
            {"source": source, "subject": subject, "imu": imu, "status": status, "cause": cause}
        )

    def write(self, path: Path) -> None:
        """Write the rows as ``import_report.tsv``."""
        from aceval.data.writer import write_sheet

        columns = ["source", "subject", "imu", "status", "cause"]
        write_sheet(path, columns, [[row[c] for c in columns] for row in self.rows])

    def summary(self) -> str:
        """Counts per status, e.g. '2 excluded, 9 imported'."""
        counts: dict[str, int] = {}
        for row in self.rows:
            counts[row["status"]] = counts.get(row["status"], 0) + 1
        return (
            ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
            or "nothing to report"
        )


def text_encoding(path: Path) -> str:
    """The encoding to read a text export with: UTF-16 where it starts with that byte-order mark,
    else UTF-8 with or without one (an export re-saved by Notepad or Excel starts with one).
    """
    import codecs

    with open(path, "rb") as handle:
        start = handle.read(2)
    return "utf-16" if start in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE) else "utf-8-sig"


def mean_posture(signal: np.ndarray, fs_hz: float) -> np.ndarray:
    """``signal`` (N, 3) low-passed at :data:`MEAN_POSTURE_CUTOFF_HZ` (zero-phase): what stays
    of a walking bout below the stride frequency, the fallback vertical of recordings without
    quiet standing (its accuracy: docs/your_data.md).
    """
    from scipy.signal import butter, sosfiltfilt

    return sosfiltfilt(butter(2, MEAN_POSTURE_CUTOFF_HZ, fs=fs_hz, output="sos"), signal, axis=0)


def stride_peaks(gyr: np.ndarray, fs_hz: float) -> np.ndarray:
    """Sample indices of one peak per stride: the maxima of a shank's angular speed (rad/s,
    (N, 3)) low-passed at 3 Hz, at least :data:`MIN_STRIDE_S` apart and at least 40 % of the
    95th percentile high (the swing-phase peak). Only the timing is used, so a gain error in the
    gyroscope does not move the peaks.
    """
    from scipy.signal import butter, find_peaks, sosfiltfilt

    speed = np.linalg.norm(gyr, axis=1)
    sos = butter(2, 3.0, fs=fs_hz, output="sos")
    smooth = sosfiltfilt(sos, speed) if len(speed) > 15 else speed
    peaks, _ = find_peaks(
        smooth, height=0.4 * np.percentile(smooth, 95), distance=max(1, int(MIN_STRIDE_S * fs_hz))
    )
    return peaks


def stride_spans(peaks: np.ndarray) -> list[tuple[int, int]]:
    """Whole strides as half-open ranges from one stride peak to the next."""
    return [(int(a), int(b)) for a, b in zip(peaks[:-1], peaks[1:])]


def straight_strides(
    strides: list[tuple[int, int]],
    yaw_rate: np.ndarray,
    fs_hz: float,
    max_turn_deg: float = MAX_TURN_DEG,
) -> list[tuple[int, int]]:
    """The strides during which the heading (``yaw_rate``, rad/s about the vertical, integrated)
    changes by less than ``max_turn_deg``: turns are not sagittal-plane motion.
    """
    return [
        (a, b) for a, b in strides if abs(np.degrees(yaw_rate[a:b].sum() / fs_hz)) < max_turn_deg
    ]


def first_stretch(strides: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The strides of the first straight stretch: from the first up to the first gap (a turn left
    out of ``strides``).
    """
    stretch = strides[:1]
    for stride in strides[1:]:
        if stride[0] != stretch[-1][1]:
            break
        stretch.append(stride)
    return stretch


def read_sensor_sheet(path: str | Path, columns: list[str]):
    """An importer's sensor sheet (tab-separated, ``#`` comments, cells stripped) as a DataFrame of
    strings; FormatError naming the file where it lacks one of ``columns``.
    """
    import pandas as pd

    sheet = pd.read_csv(path, sep="\t", dtype=str, comment="#").apply(lambda c: c.str.strip())
    missing = [c for c in columns if c not in sheet.columns]
    if missing:
        raise FormatError(
            f"{path}: missing column(s) {', '.join(missing)} (needs {', '.join(columns)})"
        )
    return sheet


def walking_bouts(
    strides: list[tuple[int, int]], max_repetitions: int = MAX_REPETITIONS
) -> list[tuple[int, int]]:
    """Group whole strides into at most ``max_repetitions`` repetitions of equal numbers of
    consecutive strides (``max(1, n // max_repetitions)`` each, in order; a gap between strides,
    e.g. a left-out turn, starts a new group; strides left over are not used). Returns half-open
    sample ranges.
    """
    per_rep = max(MIN_STRIDES_PER_REPETITION, len(strides) // max_repetitions)
    bouts, run = [], []
    for a, b in strides:
        if run and a != run[-1][1]:
            run = []
        run.append((a, b))
        if len(run) == per_rep:
            bouts.append((run[0][0], run[-1][1]))
            run = []
    return bouts[:max_repetitions]
