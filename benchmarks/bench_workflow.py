"""Wall-clock time of the default workflow from clean and of an up-to-date re-run.

    python benchmarks/bench_workflow.py

Runs `snakemake --cores 2` with the default config/config.yaml in a temporary working directory
(the repository's results/ are not touched), then runs it again with nothing to do.
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed_run(workdir: str) -> float:
    start = time.perf_counter()
    subprocess.run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "-s",
            str(REPO / "Snakefile"),
            "--directory",
            workdir,
            "--cores",
            "2",
            "--quiet",
        ],
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - start


def main() -> None:
    with tempfile.TemporaryDirectory() as workdir:
        clean = timed_run(workdir)
        again = timed_run(workdir)
    print(
        f"default workflow from clean: {clean:.1f} s; up-to-date re-run: {again:.1f} s "
        f"(ratio {clean / again:.0f}x)"
    )


if __name__ == "__main__":
    main()
