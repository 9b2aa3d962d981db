"""31-subset Kong sweep: per-repetition scatters (one pass over the samples) vs recomputing each
subset from its samples. Run: ``python benchmarks/bench_subsets.py``. Prints times and the ratio,
measured in one run on the same data (18 IMUs x 5 repetitions x 1500 samples, i.e. Kong's two sets
of 9 IMUs and 15 s repetitions at 100 Hz)."""

import itertools
import time

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.methods import kong_calibrate, kong_from_scatters, scatter, vertical_axis

N_IMU, N_REP, N_SAMPLES, REPEATS = 18, 5, 1500, 5


def make_data(rng):
    mounts = Rotation.random(N_IMU, random_state=1).as_matrix()
    t = np.linspace(0, 6 * np.pi, N_SAMPLES)
    theta = np.radians(30) * np.sin(t)
    body = np.column_stack([9.81 * np.sin(theta), np.zeros_like(t), -9.81 * np.cos(theta)])
    static = [np.tile([0, 0, -9.81], (200, 1)) @ R for R in mounts]
    reps = [[body @ R + rng.normal(0, 0.3, body.shape) for _ in range(N_REP)] for R in mounts]
    rights = [R[1] for R in mounts]
    return static, reps, rights


def sweep_from_scatters(static, reps, rights, subsets):
    scatters = np.stack([[scatter(r) for r in imu] for imu in reps])
    counts = np.array([[len(r) for r in imu] for imu in reps])
    z0 = np.stack([vertical_axis(s) for s in static])
    return kong_from_scatters(scatters, counts, z0, np.stack(rights), subsets).R


def sweep_from_samples(static, reps, rights, subsets):
    return np.stack(
        [
            [kong_calibrate(s, np.vstack([imu[k] for k in subset]), right).R for subset in subsets]
            for s, imu, right in zip(static, reps, rights)
        ]
    )


def best_time(function, *args):
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        result = function(*args)
        times.append(time.perf_counter() - start)
    return min(times), result


def main():
    data = make_data(np.random.default_rng(0))
    subsets = [c for k in range(1, N_REP + 1) for c in itertools.combinations(range(N_REP), k)]
    fast_s, fast = best_time(sweep_from_scatters, *data, subsets)
    slow_s, slow = best_time(sweep_from_samples, *data, subsets)
    assert np.allclose(fast, slow, atol=1e-10)
    print(
        f"{N_IMU} IMUs x {len(subsets)} subsets, {N_REP} reps x {N_SAMPLES} samples (best of {REPEATS})"
    )
    print(f"from scatters: {fast_s * 1e3:8.2f} ms")
    print(f"from samples : {slow_s * 1e3:8.2f} ms")
    print(f"ratio        : {slow_s / fast_s:8.1f}x")


if __name__ == "__main__":
    main()
