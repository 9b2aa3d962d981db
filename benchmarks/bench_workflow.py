"""Workflow speed, measured in one run on this machine (issues 16 and 29; benchmarks/README.md).

    python benchmarks/bench_workflow.py                       # everything (about half an hour)
    python benchmarks/bench_workflow.py --subjects 5 20       # a shorter scaling run
    python benchmarks/bench_workflow.py --repo ../before      # another checkout (e.g. "before")
    python benchmarks/bench_workflow.py --without-peers --skip-lab --subjects   # 1 only, no peers

1. The default workflow (`snakemake --cores 2`, config/config.yaml: simulate kong, box and ricci,
   then everything) from clean, and three up-to-date re-runs; the same from clean without the peer
   tools (`--config peers=[]`), to show what they cost; the Snakemake executor plugins installed
   (the environment measured: Snakemake imports each at every start).
2. The floor of the whole default: one Python process reading every recording of its three
   generated datasets once (pandas' CSV reader or pyarrow's Parquet reader, as aceval reads them)
   and forming the scatter of each; against it, the default workflow without the peers.
3. The floor of one lab dataset: the same for the simulated Kong dataset (5 subjects) alone,
   its recordings as CSV (a lab's export) and as Parquet (the simulator's default); against it,
   the workflow of that dataset from clean (the dataset already on disk, as a lab's would be).
4. Scaling: the Kong protocol with 5, 20, 50 and 200 simulated subjects, simulation (2
   processes) and workflow timed apart, peak RSS of the largest process, files and disk; the
   marginal cost per subject, where each workflow's time and memory went; a plot
   (benchmarks/scaling.png).

Where the time went (1, 3 and 4): every Python process of the run (Snakemake, each job, each
peer) records its command line, wall time and CPU time (its own and its waited-for children's:
a job's forked workers) from ``getrusage`` as it exits (:data:`HOOK`, a ``sitecustomize`` first
on PYTHONPATH); the jobs are summed per dataset and step, and Snakemake's own CPU is the run's
total (GNU time on the ``snakemake`` command) less the jobs'. (Snakemake's own benchmark files,
used before, sample the process tree and undercount long jobs.)

``--repo`` measures another checkout of aceval (its Snakefile, and its src/ first on PYTHONPATH
for every command, jobs included), so that a "before" and an "after" are measured by the same
script; ``--peers-root`` names the peers' environments (default: the measured checkout's
.venv-peers). Everything runs in temporary folders; the repository's results/ are not touched.
Peak RSS is the largest of GNU time's maximum resident set (the command and the largest process
it waited for) and each process's own.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parents[1]
#: the checkout measured (--repo)
REPO = HERE
TIME = "/usr/bin/time"

#: a ``sitecustomize`` put first on PYTHONPATH of every measured command: each Python process
#: (Snakemake, every job's ``python -m aceval ...``, a peer's adapter) writes, as it exits, its
#: command line, wall time and CPU time (its own, and that of the children it waited for: the
#: forked workers of a job) from ``getrusage``. Snakemake's own benchmark files sample the
#: process tree and undercount long jobs (6.2 vs 10.9 CPU-s for one calibrate job, issue 48).
HOOK = """
import atexit, json, os, resource, sys, time

_START = time.time()


def _aceval_bench_record():
    folder = os.environ.get("ACEVAL_BENCH_LOG")
    if not folder:
        return
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    record = {
        "pid": os.getpid(),
        "ppid": os.getppid(),
        "argv": sys.argv,
        "cwd": os.getcwd(),
        "wall": time.time() - _START,
        "cpu": own.ru_utime + own.ru_stime,
        "children_cpu": children.ru_utime + children.ru_stime,
        "rss_mib": max(own.ru_maxrss, children.ru_maxrss) / 1024,
    }
    try:
        with open(os.path.join(folder, f"{os.getpid()}.json"), "w") as handle:
            json.dump(record, handle)
    except OSError:
        pass


atexit.register(_aceval_bench_record)
"""


@dataclass
class Measured:
    """One measured command: wall seconds, CPU seconds of it and every process it waited for
    (GNU time), peak RSS (MiB) of the largest of them, and every Python process's record."""

    wall: float
    cpu: float
    rss: float
    processes: list[dict]


def run(command: list[str], cwd: Path | None = None) -> Measured:
    """Run ``command`` under GNU time with :data:`HOOK` active. Fails loudly on a non-zero exit."""
    with tempfile.TemporaryDirectory() as hook, tempfile.NamedTemporaryFile("r") as report:
        Path(hook, "sitecustomize.py").write_text(HOOK)
        records = Path(hook, "records")
        records.mkdir()
        env = {
            **os.environ,
            "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
            "PYTHONPATH": os.pathsep.join(
                filter(None, [hook, str(REPO / "src"), os.environ.get("PYTHONPATH", "")])
            ),
            "ACEVAL_BENCH_LOG": str(records),
        }
        start = time.perf_counter()
        done = subprocess.run(
            [TIME, "-f", "%e %U %S %M", "-o", report.name, *command],
            cwd=cwd,
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - start
        if done.returncode:
            raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
        _, user, system, rss = report.read().split()[-4:]
        processes = [json.loads(p.read_text()) for p in records.glob("*.json")]
        return Measured(wall, float(user) + float(system), int(rss) / 1024, processes)


def job_of(record: dict) -> tuple[str, str] | None:
    """``(step, dataset)`` of a Python process's record: the aceval command (or the peer's
    adapter) and the dataset its paths name; None for a process that is not a job (Snakemake,
    the bench's own helpers)."""
    argv = record["argv"]
    if not argv or argv[0].endswith(("snakemake/__main__.py", "snakemake")) or argv[0] == "-c":
        return None
    if argv[0].endswith(os.path.join("aceval", "__main__.py")):
        step = argv[1] if len(argv) > 1 else "aceval"
    else:
        step = "peer_" + Path(argv[0]).stem
    for arg in argv[1:]:
        parts = Path(arg).parts
        for folder in ("resources", "results"):
            if folder in parts[:-1]:
                return step, parts[parts.index(folder) + 1]
    out = argv[argv.index("--out") + 1] if "--out" in argv[:-1] else ""
    return step, Path(out).name or "?"


def jobs_table(measured: Measured) -> str:
    """Where a run's CPU went: every job's process (its own CPU and its waited-for children's),
    per dataset and step: jobs, summed wall and CPU seconds, the largest peak RSS; then
    Snakemake's own CPU (the run's total, by GNU time, less the jobs')."""
    import pandas as pd

    rows = [
        (*job, r["wall"], r["cpu"] + r["children_cpu"], r["rss_mib"])
        for r in measured.processes
        if (job := job_of(r)) is not None
    ]
    if not rows:
        return "  (no job processes recorded)"
    table = pd.DataFrame(rows, columns=["step", "dataset", "wall_s", "cpu_s", "rss_mib"])
    summed = table.groupby(["dataset", "step"]).agg(
        jobs=("wall_s", "size"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"),
        max_rss_mib=("rss_mib", "max"),
    )  # fmt: skip
    jobs_cpu = table["cpu_s"].sum()
    return (
        summed.round(1).to_string()
        + f"\n  in all: {len(table)} jobs, {jobs_cpu:.1f} CPU-s; the whole run {measured.cpu:.1f}"
        f" CPU-s (GNU time), of which Snakemake itself and its shells "
        f"{measured.cpu - jobs_cpu:.1f}; {measured.wall:.1f} s wall"
    )


#: --config items every run gets (--peers-root)
CONFIG: list[str] = []


def snakemake(workdir: Path, config: Path | None = None, *options: str) -> list[str]:
    command = [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile")]
    command += ["--directory", str(workdir), "--cores", "2", "--quiet"]
    if config is not None:
        command += ["--configfile", str(config), "--replace-workflow-config"]
    extra = [*CONFIG]
    if "--config" in options:  # one --config with every item
        at = options.index("--config")
        extra += list(options[at + 1 :])
        options = options[:at]
    return command + list(options) + (["--config", *extra] if extra else [])


def executor_plugins() -> str:
    """The Snakemake executor plugins installed beside this interpreter ('none')."""
    from importlib.metadata import distributions

    prefix = "snakemake-executor-plugin-"
    names = {d.metadata["Name"].lower().replace("_", "-") for d in distributions()}
    return ", ".join(sorted(n[len(prefix) :] for n in names if n.startswith(prefix))) or "none"


def lab_config(workdir: Path, dataset: Path, subjects_per_job: int) -> Path:
    """A config running one dataset on disk with Kong's analyses, as a lab would; aceval's own
    analyses only (the peers are timed apart: bench_peers.py)."""
    default = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    config = {
        "datasets": {
            "lab": {
                "path": str(dataset),
                "analyses": ["kong"],
                "subjects_per_job": subjects_per_job,
            }
        },
        "calibration": default["calibration"],
        "objectives": default["objectives"],
        "peers": [],
    }
    path = workdir / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def simulate(out: Path, subjects: int, file_format: str | None = None) -> Measured:
    """`aceval simulate kong` (seed 1, 2 processes); ``file_format``: its --format, where the
    measured checkout has one (before Parquet, it wrote CSV only)."""
    command = [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(out), "--seed",
               "1", "--subjects", str(subjects), "--jobs", "2"]  # fmt: skip
    if file_format and "--format" in subprocess.run(
        [sys.executable, "-m", "aceval", "simulate", "--help"],
        capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO / "src")},
    ).stdout:  # fmt: skip
        command += ["--format", file_format]
    return run(command)


FLOOR = """
import sys
import pandas as pd
import pyarrow.parquet as pq
import numpy as np
COLUMNS = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
for root in sys.argv[1:]:
    recordings = pd.read_csv(f"{root}/recordings.tsv", sep="\\t")
    for path in recordings["path"].unique():
        if path.endswith(".parquet"):
            table = pq.ParquetFile(f"{root}/{path}", pre_buffer=False)
            table = table.read(columns=COLUMNS, use_threads=False)
            values = np.column_stack([c.to_numpy().astype(float) for c in table.columns])
        else:
            values = pd.read_csv(f"{root}/{path}").to_numpy(float)
        acc = values[:, 1:4]
        acc.T @ acc
"""


def floor(*datasets: Path) -> float:
    """Wall seconds of one process reading every recording of ``datasets`` once (:data:`FLOOR`)."""
    return run([sys.executable, "-c", FLOOR, *map(str, datasets)]).wall


def largest_process(measured: Measured) -> float:
    """The peak RSS (MiB) of the largest process of a measured command: GNU time's (the
    command's and the largest of the processes it waited for), or a job's own record."""
    return max([measured.rss, *(r["rss_mib"] for r in measured.processes)])


def git_head(repo: Path) -> str:
    done = subprocess.run(["git", "-C", str(repo), "log", "-1", "--format=%h %ad", "--date=short"],
                          capture_output=True, text=True)  # fmt: skip
    return done.stdout.strip() or "not a git checkout"


def disk(folder: Path) -> tuple[int, float]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files) / 1e9


def rerun_times(workdir: Path, *options: str) -> str:
    """Three up-to-date re-runs of a finished workflow: the median and range of their wall,
    and the median CPU (Snakemake's start, its DAG and its checks of every output)."""
    again = sorted(
        (run(snakemake(workdir, None, *options)) for _ in range(3)), key=lambda m: m.wall
    )
    cpu = sorted(m.cpu for m in again)[1]
    return (
        f"{again[1].wall:.2f} s (median of 3: {again[0].wall:.2f}-{again[2].wall:.2f}; "
        f"{cpu:.2f} CPU-s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, nargs="*", default=[5, 20, 50, 200])
    parser.add_argument("--skip-default", action="store_true")
    parser.add_argument(
        "--without-peers",
        action="store_true",
        help="part 1 without the peer tools only (its up-to-date re-runs on that run)",
    )
    parser.add_argument("--skip-lab", action="store_true", help="skip part 3 (Kong, 5 subjects)")
    parser.add_argument("--repo", type=Path, default=HERE, help="the checkout measured")
    parser.add_argument(
        "--plot", type=Path, default=HERE / "benchmarks" / "scaling.png", help="the scaling plot"
    )
    parser.add_argument("--peers-root", type=Path, help="the peers' environments")
    parser.add_argument(
        "--log",
        type=Path,
        default=HERE / "benchmarks" / "last_run.txt",
        help="where the printed lines go (default: benchmarks/last_run.txt of this checkout)",
    )
    args = parser.parse_args()
    global REPO
    REPO = args.repo.resolve()
    if args.peers_root:
        CONFIG.append(f"peers_root={args.peers_root.resolve()}")
    lines = [f"checkout measured: {REPO} ({git_head(REPO)}); load average at the start "
             f"{os.getloadavg()[0]:.1f}"]  # fmt: skip

    def say(text: str) -> None:
        print(text, flush=True)
        lines.append(text)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.skip_default and not args.without_peers:
            clean = run(snakemake(tmp / "default"))
            say(f"default workflow from clean: {clean.wall:.1f} s, {clean.cpu:.1f} CPU-s "
                f"(largest process {largest_process(clean):.0f} MiB); up-to-date re-run: "
                f"{rerun_times(tmp / 'default')}; Snakemake executor plugins installed: "
                f"{executor_plugins()}")  # fmt: skip
            say("  its jobs, summed per dataset and step (each process's CPU, getrusage):")
            say(jobs_table(clean))
        if not args.skip_default:
            bare = run(snakemake(tmp / "default_no_peers", None, "--config", "peers=[]"))
            say(f"the same without the peer tools (--config peers=[]): {bare.wall:.1f} s, "
                f"{bare.cpu:.1f} CPU-s from clean (largest process "
                f"{largest_process(bare):.0f} MiB)")  # fmt: skip
            if args.without_peers:
                again = rerun_times(tmp / "default_no_peers", "--config", "peers=[]")
                say(f"  up-to-date re-run without the peers: {again}")
            say(jobs_table(bare))
            generated = sorted((tmp / "default_no_peers" / "resources").iterdir())
            whole = floor(*generated)
            say(f"floor of the whole default (one process reading every recording of "
                f"{', '.join(p.name for p in generated)} once and forming its scatter) "
                f"{whole:.1f} s; the default without the peers {bare.wall:.1f} s; ratio "
                f"{bare.wall / whole:.1f}")  # fmt: skip

        # a lab's export, and the simulator's default
        for file_format in () if args.skip_lab else ("csv", "parquet"):
            kong = tmp / f"kong5_{file_format}"
            simulate(kong, 5, file_format)
            alone = floor(kong)
            work = tmp / f"kong5_{file_format}_work"
            work.mkdir()
            analysis = run(snakemake(work, lab_config(work, kong, 1)))
            say(f"Kong simulation, 5 subjects, recordings {file_format}: floor (one process "
                f"reading every recording once and forming its scatter) {alone:.1f} s; workflow "
                f"from clean {analysis.wall:.1f} s; ratio {analysis.wall / alone:.1f}")  # fmt: skip
            say(jobs_table(analysis))

        rows = []
        for n in args.subjects:
            data = tmp / f"scale{n}"
            sim = simulate(data, n)
            files, gigabytes = disk(data)
            work = tmp / f"scale{n}_work"
            work.mkdir()
            per_job = max(1, math.ceil(n / 20))  # at most about 20 calibration jobs
            flow = run(snakemake(work, lab_config(work, data, per_job)))
            peak = max(largest_process(sim), largest_process(flow))
            rows.append((n, sim.wall, flow.wall, peak, files, gigabytes))
            say(f"{n} subjects: simulate {sim.wall:.0f} s ({sim.cpu:.0f} CPU-s) + workflow "
                f"{flow.wall:.0f} s ({flow.cpu:.0f} CPU-s) = {sim.wall + flow.wall:.0f} s; peak "
                f"RSS {peak:.0f} MiB; {files} files, {gigabytes:.2f} GB ({per_job} subject(s) "
                f"per calibration batch)")  # fmt: skip
            say(jobs_table(flow))
            for folder in (data, work):
                subprocess.run(["rm", "-rf", str(folder)], check=True)
        if len(rows) >= 2:
            (n0, s0, w0, *_), (n1, s1, w1, *_) = rows[-2], rows[-1]
            say(f"marginal cost per subject ({n0} -> {n1}): simulate {(s1 - s0) / (n1 - n0):.2f} "
                f"s, workflow {(w1 - w0) / (n1 - n0):.2f} s")  # fmt: skip
            plot(rows, args.plot)
    say(f"load average at the end {os.getloadavg()[0]:.1f}")
    args.log.write_text("\n".join(lines) + "\n")


def plot(rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r[0] for r in rows]
    figure, panel = plt.subplots(figsize=(5.5, 3.6))
    panel.plot(n, [r[1] for r in rows], "o-", label="simulate (2 processes)")
    panel.plot(n, [r[2] for r in rows], "s-", label="workflow (snakemake --cores 2)")
    panel.plot(n, [r[1] + r[2] for r in rows], "^-", label="both")
    panel.set(xlabel="simulated subjects (Kong protocol)", ylabel="wall time (s)")
    panel.grid(alpha=0.3)
    panel.legend(fontsize=8)
    figure.suptitle("aceval end to end on 2 cores (benchmarks/bench_workflow.py)", fontsize=9)
    figure.tight_layout()
    figure.savefig(out, dpi=120, metadata={"Software": None})


if __name__ == "__main__":
    main()
