"""Where a results job's memory goes: `aceval outputs` in one process on a workflow's results
folder, its resident set and peak printed after reading its inputs and after each output (issue
16; benchmarks/README.md).

    python benchmarks/bench_outputs_memory.py RESULTS DATASET --kinds figure
    python benchmarks/bench_outputs_memory.py RESULTS DATASET --kinds table --analyses kong

RESULTS is one dataset's folder under a workflow's results/ (with calibrations/ and
correlations/, as `snakemake` leaves it), DATASET the dataset folder it was made from. The outputs
are written to a temporary folder (or --out); RESULTS is only read. Linux only (/proc/self/status).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path


def memory_mib() -> tuple[float, float]:
    """(resident set now, its peak so far) of this process in MiB."""
    fields = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(("VmRSS:", "VmHWM:")):
            fields[line.split(":")[0]] = int(line.split()[1]) / 1024
    return fields["VmRSS"], fields["VmHWM"]


def report(start: float, what: str) -> str:
    """A line: seconds since ``start``, the resident set and its peak, then ``what``."""
    now, peak = memory_mib()
    return f"{time.perf_counter() - start:7.1f} s  RSS {now:5.0f} MiB  peak {peak:5.0f} MiB  {what}"


class _WithMemory:
    """stderr that adds the time and memory to each of `aceval outputs`' progress lines."""

    def __init__(self, start: float):
        self.start = start

    def write(self, text: str) -> int:
        if text.startswith("aceval outputs: "):  # print() writes the line's end apart
            text = report(self.start, text.removeprefix("aceval outputs: "))
        return sys.__stderr__.write(text)

    def flush(self) -> None:
        sys.__stderr__.flush()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", type=Path)
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--kinds", nargs="+", default=["table", "figure"])
    parser.add_argument("--analyses", nargs="+", default=["kong", "methods", "retest"])
    parser.add_argument("--out", type=Path, help="where to write (default: a temporary folder)")
    args = parser.parse_args()
    calibrations = args.results / "calibrations"

    def files(pattern: str) -> list[str]:
        return [str(p) for p in sorted(calibrations.glob(pattern))]

    units = [p.removesuffix("_findings.tsv") for p in files("*_findings.tsv")]
    start = time.perf_counter()
    from aceval.cli import main as aceval

    with tempfile.TemporaryDirectory() as scratch:
        argv = ["outputs", "--kinds", *args.kinds, "--dataset", str(args.dataset),
                "--results", str(args.out or scratch), "--analyses", *args.analyses,
                "--calibrations", *[f"{u}.csv" for u in units], "--axes", *files("*_axes.csv"),
                "--correlations", *[str(p) for p in sorted(args.results.glob("correlations/*.csv"))],
                "--angles", *files("*_angles.csv"), "--retest-units", *files("*_retest.csv"),
                "--findings", *[f"{u}_findings.tsv" for u in units]]  # fmt: skip
        print(report(start, "start"), file=sys.stderr)
        sys.stderr = _WithMemory(start)
        try:
            aceval(argv)
        finally:
            sys.stderr = sys.__stderr__
    print(report(start, "end"))


if __name__ == "__main__":
    main()
