"""Long recordings: the wall time and peak memory of `aceval calibrate` on a 1-subject Kong
simulation whose T3 repetition 1 of some IMUs is replaced by a recording HOURS long (its own
samples repeated, time continued), Parquet (issue 41; benchmarks/README.md).

    python benchmarks/bench_long_recording.py [--hours 10] [--imus 1 6]

Each run is a subprocess; its peak resident set is the kernel's (``ru_maxrss`` of the child),
Linux only. Run it with ``PYTHONPATH`` pointing at another checkout's ``src`` to compare.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: the frontal IMUs that T3 calibrates first (Kong Table 2), in the order they are made long
T3_IMUS = ["IMU1", "IMU2", "IMU3", "IMU4", "IMU7", "IMU5"]


def long_dataset(root: Path, hours: float, n_imus: int) -> Path:
    """The simulation at ``root`` with T3 R1 of ``n_imus`` frontal IMUs made ``hours`` long."""
    subprocess.run(
        [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(root),
         "--subjects", "1", "--repetitions", "3", "--seed", "1"],
        check=True, capture_output=True,
    )  # fmt: skip
    sheet = pd.read_csv(root / "recordings.tsv", sep="\t", dtype=str)
    for imu in T3_IMUS[:n_imus]:
        row = sheet[
            (sheet["test"] == "T3") & (sheet["rep"] == "1") & (sheet["imu"] == imu)
            & (sheet["sensor_set"] == "frontal")
        ]  # fmt: skip
        path = root / row["path"].iloc[0]
        table = pd.read_parquet(path)
        copies = int(np.ceil(hours * 3600 / (table["t"].iloc[-1] - table["t"].iloc[0])))
        step = float(np.median(np.diff(table["t"])))
        long = pd.concat([table] * copies, ignore_index=True)
        long["t"] = table["t"].iloc[0] + step * np.arange(len(long))
        long.to_parquet(path, index=False)
    return root


def run(argv: list[str]) -> tuple[float, float, int]:
    """(seconds, peak MiB, exit code) of ``python -m aceval *argv`` in a child process."""
    start = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-m", "aceval", *argv], stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    return time.perf_counter() - start, usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=10.0)
    parser.add_argument("--imus", type=int, nargs="+", default=[1, 6])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        baseline = long_dataset(Path(tmp) / "short", 0.0, 0)
        seconds, peak, code = run(["calibrate", str(baseline), "--out", f"{tmp}/s.csv"])
        print(f"no long recording: {seconds:.1f} s, peak {peak:.0f} MiB (exit {code})")
        for n in args.imus:
            root = long_dataset(Path(tmp) / f"long{n}", args.hours, n)
            seconds, peak, code = run(["calibrate", str(root), "--out", f"{tmp}/{n}.csv"])
            print(
                f"{n} recording(s) of {args.hours:g} h ({args.hours * 360000:.0f} samples each) "
                f"in one repetition: {seconds:.1f} s, peak {peak:.0f} MiB (exit {code})",
                flush=True,
            )


if __name__ == "__main__":
    main()
