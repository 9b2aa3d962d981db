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


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's worker reads the groups
def pytest_collection_modifyitems(items) -> None:
    """Which tests pytest-xdist runs in one worker (``--dist loadgroup``), and in which order
    (``--no-loadscope-reorder``: as collected here). In one worker: the tests that read the
    regenerated results (the other workers need not wait for the regeneration), and the quick
    tests of one module (short: the module's imports and fixtures are most of their cost; the
    slow ones are spread over the workers one by one). First the regeneration (minutes), then
    the other slow tests, then the quick ones: the long ones do not come last to one worker while
    the others have nothing left."""
    for item in items:
        if "regenerated" in item.fixturenames:
            item.add_marker(pytest.mark.xdist_group("regenerated"))
        elif not item.get_closest_marker("xdist_group") and not item.get_closest_marker("slow"):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))

    def rank(item) -> int:
        if any(m.args == ("regenerated",) for m in item.iter_markers("xdist_group")):
            return 0
        return 1 if item.get_closest_marker("slow") else 2

    items.sort(key=rank)
