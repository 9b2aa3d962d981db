"""The small simulated datasets the tests read or break (a copy each), and their calibrations,
each built once per test run in a folder every test of the run shares, pytest-xdist's workers
included: the first test to need one builds it, the others wait for it (conftest.py's
``clean`` fixture). Build a copy (:meth:`CleanDatasets.copy`) before changing anything.
"""

from __future__ import annotations

import fcntl
import shutil
from collections.abc import Callable
from pathlib import Path

from .runner import aceval
from .smalldataset import simulate_small

#: every IMU of the frontal set
FULL_IMUS = tuple(f"IMU{k}" for k in range(1, 10))


def built(path: Path, build: Callable[[Path], object]) -> Path:
    """``path`` (a folder or a file), made by ``build(path)`` the first time any process asks for
    it, under a lock (the others wait for it); what a build that did not finish left is made
    again."""
    done = path.with_name(f".{path.name}.done")
    if done.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(f".{path.name}.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(True)
            build(path)
            done.touch()
    return path


def succeeded(*args) -> None:
    """``aceval *args`` (in this process), which must succeed."""
    result = aceval(*args)
    assert result.code == 0, result.err[-3000:]


class CleanDatasets:
    """The clean datasets in ``root`` (created): each built on first use."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self.cache = self.root / "clean"
        self.cache.mkdir(parents=True, exist_ok=True)

    def kong(self) -> Path:
        """1 subject, both sensor sets, 9 IMUs each, 5 repetitions, Parquet (seed 3)."""
        options = ["--subjects", 1, "--seed", 3]
        return self.shared("kong", lambda at: succeeded("simulate", "kong", "--out", at, *options))

    def small(self) -> Path:
        """1 subject, frontal chest, right thigh and shank, 3 repetitions, CSV (seed 3)."""
        return self.shared("small", simulate_small)

    def full_lab(self) -> Path:
        """1 subject, every IMU of the frontal set in every test, as a lab records them, 5
        repetitions, CSV (seed 3)."""
        options = {"imus": FULL_IMUS, "every_recording": True, "repetitions": 5}
        return self.shared("full_lab", lambda at: simulate_small(at, **options))

    def clean_calibrations(self, name: str) -> Path:
        """``aceval calibrate`` of the dataset ``name`` (all methods, every subset): its CSV."""
        dataset = getattr(self, name)()
        calibrate = lambda at: succeeded("calibrate", dataset, "--out", at)  # noqa: E731
        return self.shared(f"{name}_calibrations.csv", calibrate)

    def shared(self, name: str, build: Callable[[Path], object]) -> Path:
        """A folder or file ``name`` of the tests' own, made by ``build(path)`` on first use."""
        return built(self.cache / name, build)

    def copy(self, name: str, where: Path) -> Path:
        """A copy of the dataset ``name`` at ``where / name``, to change."""
        target = where / name
        shutil.copytree(getattr(self, name)(), target, symlinks=True)
        return target
