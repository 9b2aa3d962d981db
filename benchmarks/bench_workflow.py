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

For 1 and 3, where the time went: Snakemake's benchmark file of every job
(logs/<dataset>/benchmarks/), summed per dataset and step.

``--repo`` measures another checkout of aceval (its Snakefile, and its src/ first on PYTHONPATH
for every command, jobs included), so that a "before" and an "after" are measured by the same
script; ``--peers-root`` names the peers' environments (default: the measured checkout's
.venv-peers). Everything runs in temporary folders; the repository's results/ are not touched.
Peak RSS is the larger of GNU time's maximum resident set of the command and the processes it
waited for and the largest job's in Snakemake's benchmark files: GNU time alone missed the results
jobs (819 MiB at 200 subjects on commit 53d5bda, where its tables job alone, timed by GNU time,
peaked at 1347 MiB; benchmarks/README.md).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parents[1]
#: the checkout measured (--repo)
REPO = HERE
TIME = "/usr/bin/time"


def run(command: list[str], cwd: Path | None = None) -> tuple[float, float]:
    """Run ``command``; (wall seconds, peak RSS in MiB). Fails loudly on a non-zero exit."""
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
        "PYTHONPATH": os.pathsep.join(
            filter(None, [str(REPO / "src"), os.environ.get("PYTHONPATH", "")])
        ),
    }
    with tempfile.NamedTemporaryFile("r") as report:
        start = time.perf_counter()
        done = subprocess.run(
            [TIME, "-f", "%M", "-o", report.name, *command],
            cwd=cwd,
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - start
        if done.returncode:
            raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
        return wall, int(report.read().split()[-1]) / 1024


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


def simulate(out: Path, subjects: int, file_format: str | None = None) -> tuple[float, float]:
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
    return run([sys.executable, "-c", FLOOR, *map(str, datasets)])[0]


def per_step(workdir: Path) -> str:
    """Where a run's time went, from Snakemake's own per-job benchmark files
    (logs/<dataset>/benchmarks/<step>[_<subject>].tsv): per dataset and step, the jobs, their
    summed wall and CPU seconds and the largest job's peak RSS.
    """
    import pandas as pd

    rows = []
    for path in sorted(workdir.glob("logs/*/benchmarks/*.tsv")):
        step = path.stem
        for prefix in (
            "calibrate",
            "peer_gaitmap_pca",
            "peer_qmt_hinge",
            "peer_opensense_imuplacer",
        ):
            step = prefix if step.startswith(prefix) else step
        record = pd.read_csv(path, sep="\t").iloc[0]
        rows.append(
            (path.parent.parent.name, step, record["s"], record["cpu_time"], record["max_rss"])
        )
    if not rows:
        return "  (no benchmark files)"
    table = pd.DataFrame(rows, columns=["dataset", "step", "wall_s", "cpu_s", "rss_mib"])
    summed = table.groupby(["dataset", "step"]).agg(
        jobs=("wall_s", "size"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"),
        max_rss_mib=("rss_mib", "max"),
    )  # fmt: skip
    return summed.round(1).to_string()


def largest_job_rss(workdir: Path) -> float:
    """The largest peak RSS (MiB) in a run's Snakemake benchmark files (0 without any)."""
    import pandas as pd

    paths = sorted(workdir.glob("logs/*/benchmarks/*.tsv"))
    return max((float(pd.read_csv(p, sep="\t")["max_rss"].iloc[0]) for p in paths), default=0.0)


def git_head(repo: Path) -> str:
    done = subprocess.run(["git", "-C", str(repo), "log", "-1", "--format=%h %ad", "--date=short"],
                          capture_output=True, text=True)  # fmt: skip
    return done.stdout.strip() or "not a git checkout"


def disk(folder: Path) -> tuple[int, float]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files) / 1e9


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
    lines = [f"checkout measured: {REPO} ({git_head(REPO)})"]

    def say(text: str) -> None:
        print(text, flush=True)
        lines.append(text)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.skip_default and not args.without_peers:
            clean, rss = run(snakemake(tmp / "default"))
            rss = max(rss, largest_job_rss(tmp / "default"))
            again = sorted(run(snakemake(tmp / "default"))[0] for _ in range(3))
            say(f"default workflow from clean: {clean:.1f} s (largest process {rss:.0f} MiB); "
                f"up-to-date re-run: {again[1]:.2f} s (median of 3: {again[0]:.2f}-"
                f"{again[2]:.2f}; Snakemake executor plugins installed: "
                f"{executor_plugins()})")  # fmt: skip
            say("  its jobs, summed per dataset and step (Snakemake's benchmark files):")
            say(per_step(tmp / "default"))
        if not args.skip_default:
            bare, _ = run(snakemake(tmp / "default_no_peers", None, "--config", "peers=[]"))
            say(f"the same without the peer tools (--config peers=[]): {bare:.1f} s from clean")
            if args.without_peers:
                again = sorted(
                    run(snakemake(tmp / "default_no_peers", None, "--config", "peers=[]"))[0]
                    for _ in range(3)
                )
                say(
                    f"  up-to-date re-run without the peers: {again[1]:.2f} s (median of 3: "
                    f"{again[0]:.2f}-{again[2]:.2f})"
                )
            say(per_step(tmp / "default_no_peers"))
            generated = sorted((tmp / "default_no_peers" / "resources").iterdir())
            whole = floor(*generated)
            say(f"floor of the whole default (one process reading every recording of "
                f"{', '.join(p.name for p in generated)} once and forming its scatter) "
                f"{whole:.1f} s; the default without the peers {bare:.1f} s; ratio "
                f"{bare / whole:.1f}")  # fmt: skip

        # a lab's export, and the simulator's default
        for file_format in () if args.skip_lab else ("csv", "parquet"):
            kong = tmp / f"kong5_{file_format}"
            simulate(kong, 5, file_format)
            alone = floor(kong)
            work = tmp / f"kong5_{file_format}_work"
            work.mkdir()
            analysis, _ = run(snakemake(work, lab_config(work, kong, 1)))
            say(f"Kong simulation, 5 subjects, recordings {file_format}: floor (one process "
                f"reading every recording once and forming its scatter) {alone:.1f} s; workflow "
                f"from clean {analysis:.1f} s; ratio {analysis / alone:.1f}")  # fmt: skip
            say(per_step(work))

        rows = []
        for n in args.subjects:
            data = tmp / f"scale{n}"
            sim, sim_rss = simulate(data, n)
            files, gigabytes = disk(data)
            work = tmp / f"scale{n}_work"
            work.mkdir()
            per_job = max(1, math.ceil(n / 20))  # at most about 20 calibration jobs
            wall, rss = run(snakemake(work, lab_config(work, data, per_job)))
            peak = max(sim_rss, rss, largest_job_rss(work))
            rows.append((n, sim, wall, peak, files, gigabytes))
            say(f"{n} subjects: simulate {sim:.0f} s + workflow {wall:.0f} s = {sim + wall:.0f} s; "
                f"peak RSS {peak:.0f} MiB; {files} files, {gigabytes:.2f} GB "
                f"({per_job} subject(s) per calibration job)")  # fmt: skip
            say(per_step(work))
            for folder in (data, work):
                subprocess.run(["rm", "-rf", str(folder)], check=True)
        if len(rows) >= 2:
            (n0, s0, w0, *_), (n1, s1, w1, *_) = rows[-2], rows[-1]
            say(f"marginal cost per subject ({n0} -> {n1}): simulate {(s1 - s0) / (n1 - n0):.2f} "
                f"s, workflow {(w1 - w0) / (n1 - n0):.2f} s")  # fmt: skip
            plot(rows, args.plot)
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
