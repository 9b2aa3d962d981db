"""The project's own promises about itself: the paper map points to code that exists, the rules'
conda environment pins the lock's versions, the examples run, and the README's commands are the
ones CI and the tests use."""

import importlib
import re
import shlex
import subprocess
import sys

import pytest
import yaml

from .runner import README_WORKFLOW, REPO

README = REPO / "README.md"


def test_every_function_file_and_test_in_the_paper_map_exists():
    text = (REPO / "docs" / "paper_map.md").read_text()
    names = set(re.findall(r"`([^`]+)`", text))
    checked = 0
    for name in names:
        for part in (p.strip() for p in name.split(",")):
            if part.startswith("aceval.") and _importable(part):  # a module
                checked += 1
            elif part.startswith("aceval."):
                module, _, attribute = part.rpartition(".")
                while module and not _importable(module):
                    module, _, parent = module.rpartition(".")
                    attribute = f"{parent}.{attribute}"
                target = importlib.import_module(module)
                for piece in attribute.split("."):
                    target = getattr(target, piece)
                checked += 1
            elif part.startswith("tests/") and "::" in part:
                path, _, test = part.partition("::")
                assert re.search(rf"^def {test}\(", (REPO / path).read_text(), re.M), part
                checked += 1
            elif part.startswith("report/reference/"):
                assert (REPO / "src" / "aceval" / part).is_file(), part
                checked += 1
    assert checked > 60


def _importable(module: str) -> bool:
    try:
        importlib.import_module(module)
        return True
    except ImportError:
        return False


def test_the_rules_conda_environment_pins_the_locked_versions():
    lock = dict(
        re.findall(r"^([A-Za-z0-9_.-]+)==(\S+)", (REPO / "requirements.lock").read_text(), re.M)
    )
    lock = {name.lower(): version for name, version in lock.items()}
    env = yaml.safe_load((REPO / "workflow" / "envs" / "aceval.yaml").read_text())
    pins = dict(
        item.split("=", 1) for item in env["dependencies"] if isinstance(item, str) and "=" in item
    )
    pins.pop("python")
    assert pins and all(lock[name] == version for name, version in pins.items()), pins
    for name in ("numpy", "scipy", "pandas", "statsmodels", "matplotlib", "seaborn", "snakemake"):
        assert name in pins


def test_example_one_imu_recovers_the_mounting():
    run = subprocess.run(
        [sys.executable, str(REPO / "examples" / "calibrate_one_imu.py")],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    error = float(re.search(r"error to the true mounting: ([\d.]+) deg", run.stdout).group(1))
    assert error < 0.1


@pytest.mark.slow
def test_example_lab_folder_writes_calibrations_and_a_figure(tmp_path):
    run = subprocess.run(
        [sys.executable, str(REPO / "examples" / "calibrate_lab_folder.py"), "", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "calibrations.csv").stat().st_size > 0 and (
        tmp_path / "calibrations.png"
    ).is_file()
    medians = re.search(r"by method \(deg\): (\{.*\})", run.stdout).group(1)
    assert float(re.search(r"'kong': ([\d.]+)", medians).group(1)) < 10


def test_the_readmes_two_commands_are_the_ones_ci_and_the_tests_run():
    """README's "Commands": `pip install ... && snakemake --cores 2` and `pip install ... &&
    python -m pytest`. .ci/run runs the second one's lines as they are written, the tests run the
    workflow by the first one's command (tests/runner.py), and both install the same way."""
    section = README.read_text().split("## Commands", 1)[1].split("\n## ", 1)[0]
    workflow, tests = re.findall(r"```bash\n(.*?)\n```", section, re.S)[:2]
    workflow_install, workflow_run = workflow.split(" && ")
    test_install, test_run = tests.split(" && ")
    assert shlex.split(workflow_run) == README_WORKFLOW
    assert shlex.split(test_run) == ["python", "-m", "pytest"]
    assert shlex.split(workflow_install) == [
        "." if word == ".[test]" else word for word in shlex.split(test_install)
    ]
    ci = [line.strip() for line in (REPO / ".ci" / "run").read_text().splitlines()]
    assert test_install in ci and test_run in ci
