"""Time per calibration of every method, measured in one run on the same simulated recordings.

    python benchmarks/bench_peers.py          # needs the peers' environments (snakemake peer_envs)

1. One IMU, one signal: aceval's Kong call (the trimming of Kong Fig. 5 and Kong's plane, from the
   samples: ``movement_mask`` + ``kong_calibrate``) against gaitmap's alignment of the same
   recordings (its static detection and gravity rotation, then ``PcaAlignment``), each the median
   of repeated calls in its own environment. Issue 17's goal: aceval at least as fast.
2. Every method on every calibration of one simulated subject (54 IMU x test calibrations, each
   from all 5 repetitions and every 3-subset): aceval's methods timed per call here, the peers'
   from the ``seconds`` their adapters report (their own computation, file reading left out).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
PEERS = REPO / "workflow" / "peers"
ENVS = REPO / ".venv-peers"
METHODS = {"gaitmap_pca": "gaitmap", "qmt_hinge": "qmt", "opensense_imuplacer": "opensim"}
REPEATS = 50

GAITMAP_TIMER = """
import json, statistics, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from gaitmap_pca import gravity_rotation, pca_rotation, sensor_data
data = np.load(sys.argv[2])
static = sensor_data(data["static_acc"], data["static_gyr"])
motion = sensor_data(data["motion_acc"], data["motion_gyr"])
times = []
for _ in range(int(sys.argv[3])):
    start = time.perf_counter()
    gravity, _note = gravity_rotation(static, float(data["fs_hz"]))
    pca_rotation(gravity, motion)
    times.append(time.perf_counter() - start)
print(json.dumps(statistics.median(times)))
"""


def one_signal(dataset, plan: dict, entry: dict) -> tuple[float, float]:
    """(aceval's Kong call, gaitmap's alignment) on one IMU's recordings: median seconds."""
    from aceval.methods.kong import kong_calibrate
    from aceval.signals.segmentation import movement_mask

    static = [dataset.read_recording(p) for p in entry["static"]]
    reps = [dataset.read_recording(p) for p in entry["reps"].values()]
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        moving = [r.acc[movement_mask(r.gyr, dataset.fs_hz)] for r in reps]
        kong_calibrate(np.vstack([s.acc for s in static]), moving, np.array(entry["right_axis"]))
        times.append(time.perf_counter() - start)
    with tempfile.TemporaryDirectory() as scratch:
        arrays = Path(scratch) / "signal.npz"
        np.savez(
            arrays,
            static_acc=np.vstack([s.acc for s in static]),
            static_gyr=np.vstack([s.gyr for s in static]),
            motion_acc=np.vstack([r.acc for r in reps]),
            motion_gyr=np.vstack([r.gyr for r in reps]),
            fs_hz=dataset.fs_hz,
        )
        done = subprocess.run(
            [
                str(ENVS / "gaitmap" / "bin" / "python"),
                "-c",
                GAITMAP_TIMER,
                str(PEERS),
                str(arrays),
                str(REPEATS),
            ],  # fmt: skip
            capture_output=True,
            text=True,
            check=True,
        )
    return statistics.median(times), json.loads(done.stdout)


def aceval_methods(dataset, summaries) -> dict[str, float]:
    """Seconds per calibration of aceval's methods on one subject, all made in one pass (Kong for
    every subset, the axis methods and the combined heading from all repetitions and every
    3-subset, the checks and the bootstrap cones): the pass's time over its number of
    calibrations, one row (the methods are not timed apart)."""
    from aceval.calibrate.pipeline import calibrate

    start = time.perf_counter()
    calibrations, _ = calibrate(dataset, summaries, retest_k=3)
    seconds = time.perf_counter() - start
    methods = "+".join(calibrations["method"].unique())
    return {
        f"aceval, one pass ({methods}; {len(calibrations)} calibrations)": seconds
        / len(calibrations)
    }


def main() -> None:
    missing = [env for env in METHODS.values() if not (ENVS / env / "bin" / "python").exists()]
    if missing:
        raise SystemExit(f"the peers' environments are missing ({', '.join(missing)}): "
                         "build them with `snakemake --cores 2 peer_envs`")  # fmt: skip
    from aceval.calibrate.peer_plan import calibration_plan
    from aceval.data.dataset import load_dataset
    from aceval.signals.reduction import reduce_recordings

    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        subprocess.run(
            [
                sys.executable,
                "-m",
                "aceval",
                "simulate",
                "kong",
                "--out",
                str(scratch / "kong"),
                "--subjects",
                "1",
                "--seed",
                "0",
            ],  # fmt: skip
            check=True,
            capture_output=True,
        )
        dataset = load_dataset(scratch / "kong")
        summaries = reduce_recordings(dataset, "S1").summaries
        plan = calibration_plan(dataset, summaries, retest_k=3)
        (scratch / "plan.json").write_text(json.dumps(plan))
        entry = next(e for e in plan["calibrations"] if e["imu"] == "IMU4" and e["test"] == "T6")
        kong, gaitmap = one_signal(dataset, plan, entry)
        print(f"one IMU (right thigh, T6, 5 repetitions), median of {REPEATS} calls: aceval Kong "
              f"{1e3 * kong:.2f} ms (trimming + plane), gaitmap {1e3 * gaitmap:.2f} ms (static "
              f"detection + gravity + PcaAlignment): aceval {gaitmap / kong:.1f}x faster")  # fmt: skip
        rows = [{"method": m, "seconds_per_calibration": s} for m, s in
                aceval_methods(dataset, summaries).items()]  # fmt: skip
        for method, env in METHODS.items():
            out = scratch / f"{method}.csv"
            subprocess.run(
                [
                    str(ENVS / env / "bin" / "python"),
                    str(PEERS / f"{method}.py"),
                    str(scratch / "plan.json"),
                    str(out),
                ],  # fmt: skip
                check=True,
                capture_output=True,
            )
            seconds = pd.read_csv(out)["seconds"].dropna()
            rows.append({"method": method, "seconds_per_calibration":
                         seconds.median() if len(seconds) else float("nan")})  # fmt: skip
        table = pd.DataFrame(rows)
        table["ms_per_calibration"] = (1e3 * table.pop("seconds_per_calibration")).round(3)
        print("every calibration of one subject (median for the peers):")
        print(table.to_string(index=False))


if __name__ == "__main__":
    main()
