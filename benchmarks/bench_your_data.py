"""From a folder of Xsens exports to SUMMARY.md, timed: the steps of docs/your_data.md on a
SIMULATED lab of issue 40's shape (4 subjects, 19 treadmill-like walking trials of about 40 s,
5 sensors: lower back, shanks, feet; no quiet standing; tab-separated MT Manager 2019 exports
without a rate line and with an empty SampleTimeFine; 100 Hz).

    python benchmarks/bench_your_data.py [--work DIR] [--peers]

Prints each command and its wall time. ``--peers``: the workflow with the three peers, whose
environments must exist already (the default .venv-peers beside the Snakefile).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from aceval.data.dataset import load_dataset  # noqa: E402
from tests.labexports import SENSORS, export  # noqa: E402

TRIALS = {"P01": 5, "P02": 5, "P03": 5, "P04": 4}
WALKS_PER_TRIAL = 5  # simulated 7 m walks joined at their standing ends: about 40 s


def exports(work: Path) -> None:
    """The lab's folder under ``work/exports`` and its two sheets."""
    simulated = work / "simulated"
    reps = max(TRIALS.values()) * WALKS_PER_TRIAL
    subprocess.run(
        [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(simulated), "--seed",
         "11", "--subjects", str(len(TRIALS)), "--repetitions", str(reps), "--jobs", "2"],
        check=True, capture_output=True,
    )  # fmt: skip
    dataset = load_dataset(simulated)
    rec = dataset.recordings
    rec = rec[(rec["sensor_set"] == "frontal") & (rec["test"] == "T6")]
    rows = ["subject\ttrial\ttest\tstatic\tfirst_phase"]
    counter = 0
    for k, (lab, n) in enumerate(TRIALS.items()):
        subject = f"S{k + 1}"
        for trial in range(1, n + 1):
            name = f"{lab}/treadmill_{trial:02d}"
            walks = range((trial - 1) * WALKS_PER_TRIAL + 1, trial * WALKS_PER_TRIAL + 1)
            for sensor_id, _, _, _, imu in SENSORS:
                paths = rec[
                    (rec["subject"] == subject) & (rec["imu"] == imu) & rec["rep"].isin(walks)
                ]
                parts = [dataset.read_recording(p) for p in paths.sort_values("rep")["path"]]
                acc = np.vstack([p.acc for p in parts])
                gyr = np.vstack([p.gyr for p in parts])
                path = work / "exports" / f"{name}-000_{sensor_id}.txt"
                path.parent.mkdir(parents=True, exist_ok=True)
                export(path, sensor_id, counter, acc, gyr, "bare")
            counter += 10000
            rows.append(f"{lab}\t{name}\ttreadmill\twalking\tgait")
    (work / "trials.tsv").write_text("\n".join(rows) + "\n")
    sheet = ["sensor_id\timu\tsegment\tside\tright_axis"]
    axes = {"IMU3": "-y", "IMU5": "+y", "IMU6": "-y", "IMU8": "+y", "IMU9": "-y"}
    sheet += [f"{s}\t{name}\t{seg}\t{side}\t{axes[imu]}" for s, name, seg, side, imu in SENSORS]
    (work / "sensors.tsv").write_text("\n".join(sheet) + "\n")
    peers = "" if PEERS else "peers: []\n"
    (work / "my_lab.yaml").write_text(
        f"directory: aceval_out\n{peers}datasets:\n  my_lab:\n    path: my_lab\n    analyses: [kong]\n"
    )


COMMANDS = [
    "aceval import xsens exports --trials trials.tsv --sensors sensors.tsv --rate 100 "
    "--name my_lab --out my_lab",
    "aceval validate my_lab",
    "aceval right-axis my_lab",
    f"snakemake -s {REPO / 'Snakefile'} --cores 2 --configfile my_lab.yaml "
    "--replace-workflow-config",
]
PEERS = False


def main() -> None:
    global PEERS
    parser = argparse.ArgumentParser()
    parser.add_argument("--work", help="folder to work in (default: a temporary one)")
    parser.add_argument("--peers", action="store_true")
    args = parser.parse_args()
    PEERS = args.peers
    work = Path(args.work or tempfile.mkdtemp())
    work.mkdir(parents=True, exist_ok=True)
    exports(work)
    size = sum(p.stat().st_size for p in (work / "exports").rglob("*.txt")) / 2**20
    print(f"{work}/exports: {len(list((work / 'exports').rglob('*.txt')))} exports, {size:.0f} MiB")
    total = 0.0
    for command in COMMANDS:
        start = time.perf_counter()
        run = subprocess.run(command, shell=True, cwd=work, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        total += seconds
        print(f"{seconds:7.1f} s  {command}  (exit {run.returncode})")
        if run.returncode:
            print(run.stderr[-2000:])
            raise SystemExit(1)
    summary = work / "aceval_out" / "results" / "my_lab" / "SUMMARY.md"
    print(f"{total:7.1f} s  in all; {summary} exists: {summary.exists()}")


if __name__ == "__main__":
    main()
