import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from .runner import DATA, REPO, snakemake

# what these fixtures need is imported in them: pytest-xdist's controller loads this file too, and
# runs no test


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def clean(tmp_path_factory):
    """The small simulated datasets and their calibrations (tests/datasets.py), built once in a
    folder of this run that pytest-xdist's workers share."""
    from .datasets import CleanDatasets

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):  # a worker's own folder is inside the run's
        root = root.parent
    return CleanDatasets(root / "shared")


@dataclass(frozen=True)
class Regeneration:
    """The committed configurations regenerated from clean: where, and the command's arguments."""

    workdir: Path
    args: tuple[str, ...]
    configs: tuple[str, ...]
    seconds: float


@pytest.fixture(scope="session")
def regenerated(clean) -> Regeneration:
    """Every committed configuration (config/config.yaml and, where the real recordings are
    present, config/real.yaml) regenerated from clean once per test run (whichever pytest-xdist
    worker asks first runs it, another waits for it), peers included, in one Snakemake run so that
    both cores stay busy: the datasets are independent, so each one's results are those of its own
    configuration's run. The first run on a machine also builds the peers' environments (the
    workflow's rule peer_env); later sessions reuse them."""
    import yaml

    configs = ("config.yaml", "real.yaml") if DATA.is_dir() else ("config.yaml",)
    datasets = [
        name for c in configs for name in yaml.safe_load((REPO / "config" / c).read_text())["run"]
    ]
    args = ("--configfile", *(str(REPO / "config" / c) for c in configs))
    args += ("--config", f"run=[{','.join(datasets)}]", f"data_root={DATA}")
    report = clean.cache / "regeneration.json"

    def regenerate(workdir: Path) -> None:
        workdir.mkdir()
        start = time.perf_counter()
        run = snakemake(workdir, *args, config=False)
        seconds = time.perf_counter() - start
        said = {"returncode": run.returncode, "stderr": run.stderr[-4000:], "seconds": seconds}
        report.write_text(json.dumps(said))

    workdir = clean.shared("regenerated", regenerate)
    run = json.loads(report.read_text())
    if run["returncode"] != 0:
        pytest.fail(f"the committed configurations did not regenerate:\n{run['stderr']}")
    return Regeneration(workdir, args, configs, run["seconds"])


def pytest_xdist_auto_num_workers(config) -> int | None:
    """pyproject's ``-n auto``: pytest-xdist's worker per core, but none for a run of tests named
    one by one (``file::test``: a test being debugged, its output and ``--pdb`` at hand)."""
    if config.args and all("::" in arg for arg in config.args):
        return 0
    return None


#: the file whose tests make the regenerated results (minutes), which other files' tests read
REGENERATION_FILE = "test_committed_results.py"


def pytest_collection_modifyitems(items) -> None:
    """The order in which pytest-xdist hands the test files to its workers (pyproject's ``--dist
    loadfile --no-loadscope-reorder``: a file's tests in one worker, one file after another, in
    the order of their first test here). First the regeneration's file, its regeneration first;
    then the files with slow tests, then the quick ones: the long ones do not come last to one
    worker while the others have nothing left. Elsewhere, the tests that read the regenerated
    results come last in their file: the worker that asks first makes them, another waits."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}

    def rank(item) -> tuple[int, int]:
        reads = "regenerated" in item.fixturenames
        if item.path.name == REGENERATION_FILE:
            return 0, 0 if reads else 1
        return 1 if item.path in slow_files else 2, 1 if reads else 0

    items.sort(key=rank)
