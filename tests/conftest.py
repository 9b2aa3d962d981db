import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from .runner import DATA, REPO, snakemake


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@dataclass(frozen=True)
class Regeneration:
    """The committed configurations regenerated from clean: where, and the command's arguments."""

    workdir: Path
    args: tuple[str, ...]
    configs: tuple[str, ...]
    seconds: float


@pytest.fixture(scope="session")
def regenerated(tmp_path_factory) -> Regeneration:
    """Every committed configuration (config/config.yaml and, where the real recordings are
    present, config/real.yaml) regenerated from clean once per session, peers included, in one
    Snakemake run so that both cores stay busy: the datasets are independent, so each one's
    results are those of its own configuration's run. The first run on a machine also builds the
    peers' environments (the workflow's rule peer_env); later sessions reuse them."""
    configs = ("config.yaml", "real.yaml") if DATA.is_dir() else ("config.yaml",)
    datasets = [
        name for c in configs for name in yaml.safe_load((REPO / "config" / c).read_text())["run"]
    ]
    args = ("--configfile", *(str(REPO / "config" / c) for c in configs))
    args += ("--config", f"run=[{','.join(datasets)}]", f"data_root={DATA}")
    workdir = tmp_path_factory.mktemp("regenerated")
    start = time.perf_counter()
    run = snakemake(workdir, *args, config=False)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        pytest.fail(f"the committed configurations did not regenerate:\n{run.stderr[-4000:]}")
    return Regeneration(workdir, args, configs, seconds)
