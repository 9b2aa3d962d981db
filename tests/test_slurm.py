"""The workflow on a cluster, unchanged, through Snakemake's SLURM executor (profiles/slurm): a
one-node SLURM (Debian's slurm-wlm: slurmctld and slurmd on localhost, with munge) is started for
the test in a temporary folder, a tiny dataset is run through it, and its results must equal a
local run's. Where SLURM is not installed (or this is not root) the test is skipped with the reason;
where it is required (ACEVAL_REQUIRE_SLURM=1, which .ci/run sets after installing it) it fails
instead."""

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from .datasets import succeeded
from .runner import REPO, snakemake

pytestmark = pytest.mark.slow

DAEMONS = ("munged", "slurmctld", "slurmd", "sbatch", "srun", "squeue", "scontrol", "sinfo")
#: set by .ci/run: a missing SLURM fails the test instead of skipping it
REQUIRED = os.environ.get("ACEVAL_REQUIRE_SLURM") == "1"


def _cannot_start(reason: str) -> None:
    """Skip (or, where SLURM is required, fail) with how to enable the test."""
    how = (
        "to run it: apt-get install slurm-wlm munge, as root (.ci/run does, and sets "
        "ACEVAL_REQUIRE_SLURM=1 so that a missing SLURM fails there)"
    )
    (pytest.fail if REQUIRED else pytest.skip)(f"SLURM cannot start: {reason}; {how}")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _log_tail(*paths: Path) -> str:
    return "\n".join(f"{p}:\n{p.read_text()[-1500:]}" for p in paths if p.exists())


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A running one-node SLURM: the environment to submit to it."""
    missing = [name for name in DAEMONS if shutil.which(name) is None]
    if missing:
        _cannot_start(f"{', '.join(missing)} not found")
    if os.geteuid() != 0:
        _cannot_start("slurmd runs jobs as their user and needs root here")
    root = tmp_path_factory.mktemp("slurm")
    for folder in ("state", "spool", "log", "run", "munge", "bin"):
        (root / folder).mkdir()
    key = root / "munge" / "munge.key"
    key.write_bytes(os.urandom(1024))
    key.chmod(0o400)
    socket_path = root / "munge" / "munge.socket"
    subprocess.run(
        [
            "munged",
            f"--key-file={key}",
            f"--socket={socket_path}",
            "--force",
            f"--pid-file={root / 'munge' / 'munged.pid'}",
            f"--log-file={root / 'munge' / 'log'}",
            f"--seed-file={root / 'munge' / 'seed'}",
        ],  # fmt: skip
        check=True,
    )
    memory_mb = int(Path("/proc/meminfo").read_text().split()[1]) // 1024 - 1024
    conf = root / "slurm.conf"
    conf.write_text(
        "\n".join(
            [
                "ClusterName=aceval_test",
                "SlurmctldHost=localhost",
                "SlurmUser=root",
                "SlurmdUser=root",
                "AuthType=auth/munge",
                f"AuthInfo=socket={socket_path}",
                "CredType=cred/munge",
                f"StateSaveLocation={root / 'state'}",
                f"SlurmdSpoolDir={root / 'spool'}",
                f"SlurmctldPidFile={root / 'run' / 'slurmctld.pid'}",
                f"SlurmdPidFile={root / 'run' / 'slurmd.pid'}",
                f"SlurmctldLogFile={root / 'log' / 'slurmctld.log'}",
                f"SlurmdLogFile={root / 'log' / 'slurmd.log'}",
                f"SlurmctldPort={_free_port()}",
                f"SlurmdPort={_free_port()}",
                "ProctrackType=proctrack/linuxproc",
                "TaskPlugin=task/none",
                "SelectType=select/cons_tres",
                "SelectTypeParameters=CR_Core_Memory",
                "JobAcctGatherType=jobacct_gather/none",
                "AccountingStorageType=accounting_storage/none",
                "MinJobAge=600",  # finished jobs stay visible to squeue (no accounting here)
                "ReturnToService=2",
                f"NodeName=localhost CPUs={os.cpu_count()} RealMemory={memory_mb} State=UNKNOWN",
                "PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP",
                "",
            ]
        )
    )
    # the jobstep plugin strips SLURM_* (SLURM_CONF too) before its srun: on a cluster srun finds
    # the site's configuration by itself; this shim, first on PATH, stands in for that
    shim = root / "bin" / "srun"
    shim.write_text(f'#!/bin/sh\nSLURM_CONF="{conf}" exec {shutil.which("srun")} "$@"\n')
    shim.chmod(0o755)
    env = {
        **os.environ,
        "SLURM_CONF": str(conf),
        "PATH": os.pathsep.join(
            [str(root / "bin"), str(Path(sys.executable).parent), os.environ["PATH"]]
        ),
    }
    subprocess.run(["slurmctld", "-f", str(conf)], env=env, check=True)
    subprocess.run(["slurmd", "-f", str(conf), "-N", "localhost"], env=env, check=True)
    deadline = time.time() + 60
    state = ""
    while time.time() < deadline and state != "idle":
        time.sleep(1)
        done = subprocess.run(["sinfo", "-h", "-o", "%T"], env=env, capture_output=True, text=True)
        state = done.stdout.strip()
    if state != "idle":
        pytest.fail(
            f"SLURM did not start (node state {state!r}):\n"
            + _log_tail(root / "log" / "slurmctld.log", root / "log" / "slurmd.log")
        )
    yield env
    subprocess.run(["scontrol", "shutdown"], env=env, capture_output=True)
    pid = root / "munge" / "munged.pid"
    if pid.exists():
        subprocess.run(["kill", pid.read_text().strip()], capture_output=True)


def test_the_workflow_runs_unchanged_through_the_slurm_executor(cluster, tmp_path):
    """Every job goes through sbatch, and the tables, figures and summary are the local run's."""
    data = tmp_path / "tiny"
    succeeded("simulate", "kong", "--out", data, "--seed", 2, "--subjects", 1, "--repetitions", 3)
    default = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    config = {
        # a cluster config names its datasets: the jobs also read config/config.yaml
        "run": ["lab"],
        "datasets": {"lab": {"path": str(data), "analyses": ["kong"]}},
        "calibration": default["calibration"],
        "objectives": {**default["objectives"], "test_retest_k": 2},
        "peers": [],
    }
    results, jobs = {}, {}
    for where in ("local", "slurm"):
        work = tmp_path / where
        work.mkdir()
        (work / "config.yaml").write_text(yaml.safe_dump(config))
        extra = []
        if where == "slurm":
            extra = ["--profile", str(REPO / "profiles" / "slurm"),
                     # this test cluster has no accounting database and no accounts
                     "--slurm-status-command", "squeue", "--slurm-no-account",
                     "--slurm-init-seconds-before-status-checks", "2"]  # fmt: skip
        start = time.perf_counter()
        run = snakemake(work, *extra, env=cluster)
        seconds = time.perf_counter() - start
        assert run.returncode == 0, (run.stdout + run.stderr)[-4000:]
        steps = re.findall(r"(\d+) of \1 steps \(100%\) done", run.stdout + run.stderr)
        jobs[where] = int(steps[-1])
        folder = work / "results" / "lab"
        results[where] = {
            str(p.relative_to(folder)): p.read_bytes()
            for pattern in ("SUMMARY.md", "validation.txt", "tables/*", "figures/*")
            for p in folder.glob(pattern)
        }
        if where == "slurm":
            submitted = (run.stdout + run.stderr).count("has been submitted with SLURM jobid")
            print(f"SLURM: {submitted} jobs submitted, {seconds:.1f} s wall")
            # every job of the local run but `all` (the dataset's job: validate and calibrate its
            # one subject; its results) goes through sbatch
            assert submitted == jobs["local"] - 1 == 2, (run.stdout + run.stderr)[-3000:]
    assert sorted(results["slurm"]) == sorted(results["local"])
    assert results["slurm"] == results["local"]
