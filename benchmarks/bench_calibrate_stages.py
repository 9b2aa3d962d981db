"""Where one calibrate job's time goes: the stages of `aceval calibrate` for one subject, timed in
one process (issue 16; benchmarks/README.md).

    python benchmarks/bench_calibrate_stages.py            # simulates the Kong protocol, seed 1
    python benchmarks/bench_calibrate_stages.py DATASET S1 # a dataset on disk and one subject

Stages: importing aceval's calibration modules (with pandas and SciPy), loading the sheets, the
one pass over the subject's recordings (read, check, reduce: aceval.signals.reduction), every calibration
from the summaries (aceval.calibrate.pipeline.calibrate), and Obj 1-2's correlations from the pair moments.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]


def stages(root: Path, subject: str) -> None:
    start = time.perf_counter()
    from aceval.calibrate.pipeline import calibrate
    from aceval.data.dataset import load_dataset
    from aceval.evaluation.correlations import correlations
    from aceval.signals.reduction import reduce_recordings
    from aceval.signals.segmentation import TrimParams

    timed = [("imports", time.perf_counter() - start)]

    def clock(name, call):
        began = time.perf_counter()
        result = call()
        timed.append((name, time.perf_counter() - began))
        return result

    config = yaml.safe_load((REPO / "config" / "config.yaml").read_text())["objectives"]
    dataset = clock("load the sheets", lambda: load_dataset(root))
    reduced = clock(
        "read, check and reduce the recordings",
        lambda: reduce_recordings(
            dataset, subject, TrimParams(), None, config["segment_pairs"], config["max_lag_s"]
        ),
    )
    calibrations, _ = clock(
        "every calibration (subsets, methods, cones)",
        lambda: calibrate(dataset, reduced.summaries, retest_k=config["test_retest_k"]),
    )
    clock(
        "correlations (Obj 1-2)",
        lambda: correlations(
            dataset, calibrations, reduced.pairs, config["correlation"], config["segment_pairs"]
        ),
    )
    files = int((dataset.recordings["subject"] == subject).sum())
    print(f"{root.name} {subject}: {files} recording files, {len(calibrations)} calibrations")
    for name, seconds in timed:
        print(f"  {name:<45} {seconds:6.2f} s")


def main() -> None:
    if len(sys.argv) == 3:
        stages(Path(sys.argv[1]), sys.argv[2])
        return
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "kong1"
        subprocess.run(
            [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(root), "--seed", "1",
             "--subjects", "1"],
            check=True, capture_output=True,
        )  # fmt: skip
        subprocess.run([sys.executable, __file__, str(root), "S1"], check=True)


if __name__ == "__main__":
    main()
