"""Write a dataset in the on-disk contract (docs/design.md, section 1), streaming to disk: used by the
simulator and the importers.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import yaml

from .dataset import ACC_UNITS, GYR_UNITS, KONG_FIRST_PHASE, R_COLUMNS, RECORDING_COLUMNS


def write_sheet(path: Path, columns: list[str], rows: list) -> None:
    """Write a tab-separated sheet with a header line."""
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle, delimiter="\t", lineterminator="\n")
        writer.writerow(columns)
        writer.writerows(rows)


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
        "sensor_sets": sensor_sets,
        "acc_range_g": acc_range_g,
        "gyr_range_dps": gyr_range_dps,
    }


class DatasetWriter:
    """Writes sheets and one CSV per recording; recordings.tsv is appended as files are written."""

    def __init__(self, root: Path, meta: dict):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.meta = meta
        self.acc_scale = ACC_UNITS[meta["units"]["acc"]]
        self.gyr_scale = GYR_UNITS[meta["units"]["gyr"]]
        with open(self.root / "dataset.yaml", "w") as handle:
            yaml.safe_dump(meta, handle, sort_keys=False)
        self._recordings = open(self.root / "recordings.tsv", "w", newline="")
        self._recordings.write("subject\tsensor_set\ttest\trep\timu\tpath\n")
        self._ground_truth: list = []

    def recording(self, subject, sensor_set, test, rep, imu, gyr, acc) -> str:
        """Write one recording (SI in, dataset.yaml's units out); returns its path in the dataset."""
        rel = Path("data") / subject / sensor_set / f"{test}_R{rep}_{imu}.csv"
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        t = np.arange(len(acc)) / self.meta["sampling_rate_hz"]
        table = np.column_stack([t, acc / self.acc_scale, gyr / self.gyr_scale])
        row_format = ",".join(["%.6g"] * table.shape[1]) + "\n"
        # one %-format over the whole table: the same text as np.savetxt, several times faster
        path.write_text(
            ",".join(RECORDING_COLUMNS) + "\n" + (row_format * len(table)) % tuple(table.ravel())
        )
        self.reference(subject, sensor_set, test, rep, imu, rel.as_posix())
        return rel.as_posix()

    def reference(self, subject, sensor_set, test, rep, imu, path: str) -> None:
        """A recordings.tsv row for a file already written (one file serving two tests)."""
        self._recordings.write(f"{subject}\t{sensor_set}\t{test}\t{rep}\t{imu}\t{path}\n")

    def protocol_sheets(self, tests: dict, repetitions: dict, calibrates: dict) -> None:
        """tests.tsv from ``{test: (kind, description)}`` and ``{test: repetitions}`` (``first_phase``
        from Kong's test names, :data:`aceval.dataset.KONG_FIRST_PHASE`), and
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
            write_sheet(
                self.root / "ground_truth.tsv",
                ["subject", "sensor_set", "imu", *R_COLUMNS],
                self._ground_truth,
            )
