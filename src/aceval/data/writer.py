"""Write a dataset in the on-disk contract (docs/design.md, section 1), streaming to disk: used by the
simulator and the importers.
"""

from __future__ import annotations

import csv
import io
import multiprocessing
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from aceval.data.contract import (
    GYR_UNITS,
    KONG_FIRST_PHASE,
    QUAT_COLUMNS,
    R_COLUMNS,
    RECORDING_COLUMNS,
    acc_factor,
)

#: what a worker process of DatasetWriter.each_subject runs (set before the workers fork)
_TASK: tuple | None = None


def _write_subject(k: int) -> tuple[str, list]:
    """One subject in a worker: its files written, its recordings.tsv rows and truths returned."""
    write_subject, root, meta, file_format = _TASK
    writer = DatasetWriter(root, meta, sheets=False, file_format=file_format)
    write_subject(k, writer)
    return writer.collected()


def progress(label: str, done: int, total: int) -> None:
    """One-line progress on stderr for long generations."""
    if label:
        print(
            f"\r{label}: {done}/{total}",
            end="\n" if done == total else "",
            file=sys.stderr,
            flush=True,
        )


def write_sheet(path: Path, columns: list[str], rows: list) -> None:
    """Write a tab-separated sheet with a header line."""
    Path(path).write_text(sheet_text(columns, rows), newline="")


def sheet_text(columns: list[str], rows: list) -> str:
    """The text of a tab-separated sheet with a header line (:func:`write_sheet`)."""
    handle = io.StringIO(newline="")
    writer = csv.writer(handle, delimiter="\t", lineterminator="\n")
    writer.writerow(columns)
    writer.writerows(rows)
    return handle.getvalue()


def simulated_meta(
    name: str,
    protocol: str,
    command: str,
    seed: int,
    fs_hz: float,
    *,
    units: dict,
    sensor_sets: list[str],
    acc_range_g: dict,
    gyr_range_dps: float,
) -> dict:
    """dataset.yaml of a simulated dataset, labelled as simulated in its fields and description."""
    return {
        "name": name,
        "description": f"SIMULATED data in the protocol of {protocol} (aceval simulate {command}, "
        f"seed {seed}); not the paper's recordings",
        "simulated": True,
        "sampling_rate_hz": fs_hz,
        "units": units,
        "acc_at_rest": "up",  # specific force, as the simulated accelerometers report it
        "sensor_sets": sensor_sets,
        "acc_range_g": acc_range_g,
        "gyr_range_dps": gyr_range_dps,
    }


#: the first line of recordings.tsv, and the columns of ground_truth.tsv, as DatasetWriter writes them
RECORDINGS_HEADER = "subject\tsensor_set\ttest\trep\timu\tpath\n"
TRUTH_COLUMNS = ["subject", "sensor_set", "imu", *R_COLUMNS]


def sheet_texts(rows: str, truth: list) -> dict[str, str]:
    """The recordings.tsv and ground_truth.tsv a writer's :meth:`DatasetWriter.collected` rows
    make, as text (:func:`aceval.data.dataset.read_sheets` reads them so).
    """
    texts = {"recordings.tsv": RECORDINGS_HEADER + rows}
    return texts | ({"ground_truth.tsv": sheet_text(TRUTH_COLUMNS, truth)} if truth else {})


#: the file formats DatasetWriter writes a recording in: a CSV of 6 significant digits (what a
#: lab's export looks like), or Parquet, time in float64 and the signals in float32 (7 significant
#: digits; half the bytes of the CSV, written 2x and read 2-3x faster: benchmarks/README.md)
FILE_FORMATS = ("csv", "parquet")


class DatasetWriter:
    """Writes sheets and one file per recording (``file_format``: :data:`FILE_FORMATS`);
    recordings.tsv is appended as files are written.

    :meth:`each_subject` writes the subjects in parallel processes: each writes its own files and
    hands back its sheet rows, which are appended in subject order, so the dataset is the same
    byte for byte whatever the number of processes.
    """

    def __init__(
        self,
        root: Path,
        meta: dict,
        sheets: bool = True,
        file_format: str = "csv",
        keep: bool = False,
    ):
        if file_format not in FILE_FORMATS:
            raise ValueError(f"file_format {file_format!r} is not one of {', '.join(FILE_FORMATS)}")
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.meta = meta
        self.file_format = file_format
        self.acc_scale = acc_factor(meta)
        self.gyr_scale = GYR_UNITS[meta["units"]["gyr"]]
        self._ground_truth: list = []
        #: with ``keep`` (Parquet only): recordings.tsv path -> the file's (N, 7) values exactly as
        #: they read back, for a process that calibrates what it has just simulated
        self.kept: dict[str, np.ndarray] = {}
        self._keep = keep and file_format == "parquet"
        if not sheets:  # a worker of each_subject: its rows go back to the parent
            self._recordings = io.StringIO()
            return
        with open(self.root / "dataset.yaml", "w") as handle:
            yaml.safe_dump(meta, handle, sort_keys=False)
        self._recordings = open(self.root / "recordings.tsv", "w", newline="")
        self._recordings.write(RECORDINGS_HEADER)

    def recording(self, subject, sensor_set, test, rep, imu, gyr, acc, quat=None) -> str:
        """Write one recording (SI in, dataset.yaml's units out); returns its path in the dataset.
        ``quat``: the vendor's orientation estimate (N, 4: w, x, y, z, sensor -> its z-up world),
        kept as the optional columns ``QUAT_COLUMNS`` (aceval's methods do not read them; OpenSense
        does, workflow/peers/).
        """
        rel = Path("data") / subject / sensor_set / f"{test}_R{rep}_{imu}.{self.file_format}"
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        t = np.arange(len(acc)) / self.meta["sampling_rate_hz"]
        parts = [t, acc / self.acc_scale, gyr / self.gyr_scale]
        columns = list(RECORDING_COLUMNS)
        if quat is not None:
            parts.append(quat)
            columns += QUAT_COLUMNS
        table = np.column_stack(parts)
        if self.file_format == "parquet":
            _write_parquet(path, columns, table)
            if self._keep:  # as the file reads back: the signals through float32
                values = table[:, : len(RECORDING_COLUMNS)].copy()
                values[:, 1:] = values[:, 1:].astype(np.float32)
                self.kept[rel.as_posix()] = values
        else:
            row_format = ",".join(["%.6g"] * table.shape[1]) + "\n"
            # one %-format over the whole table: the same text as np.savetxt, several times faster
            text = (row_format * len(table)) % tuple(table.ravel())
            path.write_text(",".join(columns) + "\n" + text)
        self.reference(subject, sensor_set, test, rep, imu, rel.as_posix())
        return rel.as_posix()

    def collected(self) -> tuple[str, list]:
        """What a writer without its own sheets (``sheets=False``) collected for the dataset's:
        its recordings.tsv rows (text) and ground_truth.tsv rows.
        """
        return self._recordings.getvalue(), self._ground_truth

    def append(self, rows: str, truth: list) -> None:
        """Add another writer's :meth:`collected` rows (in the dataset's subject order)."""
        self._recordings.write(rows)
        self._ground_truth += truth

    def reference(self, subject, sensor_set, test, rep, imu, path: str) -> None:
        """A recordings.tsv row for a file already written (one file serving two tests)."""
        self._recordings.write(f"{subject}\t{sensor_set}\t{test}\t{rep}\t{imu}\t{path}\n")

    def each_subject(self, write_subject: Callable, n: int, jobs: int = 1, label: str = "") -> None:
        """Call ``write_subject(k, writer)`` for k = 0 .. n-1, in ``jobs`` processes (each subject
        must draw from its own random streams); progress on stderr as subjects complete.
        """
        if jobs <= 1 or n <= 1:
            for k in range(n):
                write_subject(k, self)
                progress(label, k + 1, n)
            return
        global _TASK
        _TASK = (write_subject, self.root, self.meta, self.file_format)
        pool = ProcessPoolExecutor(min(jobs, n), mp_context=multiprocessing.get_context("fork"))
        try:
            for k, (rows, truth) in enumerate(pool.map(_write_subject, range(n))):
                self.append(rows, truth)
                progress(label, k + 1, n)
        finally:  # on an error or SIGTERM: no worker may still write once the caller cleans up
            pool.shutdown(wait=True, cancel_futures=True)
            _TASK = None

    def protocol_sheets(self, tests: dict, repetitions: dict, calibrates: dict) -> None:
        """tests.tsv from ``{test: (kind, description)}`` and ``{test: repetitions}`` (``first_phase``
        from Kong's test names, :data:`aceval.data.dataset.KONG_FIRST_PHASE`), and
        calibrates.tsv from ``{test: [imu, ...]}``.
        """
        write_sheet(
            self.root / "tests.tsv",
            ["test", "kind", "repetitions", "first_phase", "description"],
            [
                [
                    test,
                    kind,
                    repetitions[test],
                    KONG_FIRST_PHASE.get(test, "") if kind == "motion" else "",
                    text,
                ]
                for test, (kind, text) in tests.items()
            ],
        )
        write_sheet(
            self.root / "calibrates.tsv",
            ["test", "imu"],
            [[test, imu] for test, imus in calibrates.items() for imu in imus],
        )

    def ground_truth(self, subject, sensor_set, imu, R: np.ndarray) -> None:
        """Record the true sensor-to-body rotation of one IMU (ground_truth.tsv)."""
        self._ground_truth.append([subject, sensor_set, imu, *[f"{v:.10f}" for v in R.ravel()]])

    def close(self) -> None:
        """Finish recordings.tsv and write ground_truth.tsv."""
        self._recordings.close()
        if self._ground_truth:
            write_sheet(self.root / "ground_truth.tsv", TRUTH_COLUMNS, self._ground_truth)


def _write_parquet(path: Path, columns: list[str], table: np.ndarray) -> None:
    """One recording as Parquet (:data:`FILE_FORMATS`): ``t`` float64, the other columns float32,
    uncompressed (float noise does not compress) and without statistics.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = [pa.array(table[:, 0])] + [
        pa.array(table[:, k].astype(np.float32)) for k in range(1, table.shape[1])
    ]
    pq.write_table(
        pa.Table.from_arrays(arrays, names=columns),
        path,
        compression="none",
        write_statistics=False,
        use_dictionary=False,  # float signals repeat no values: trying a dictionary costs 2x
    )
