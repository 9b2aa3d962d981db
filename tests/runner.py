"""How the tests run the workflow: the README's command (``snakemake --cores 2``), with the
Snakefile of this checkout, in a folder of the test's own, by the interpreter running the tests."""

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: the real recordings, beside the project (../shared/data/README.md)
DATA = REPO.parent / "shared" / "data"
#: the README's workflow command (tests/test_habits.py checks that the README says exactly this)
README_WORKFLOW = ["snakemake", "--cores", "2"]


def snakemake(
    workdir: Path, *args: str, config: bool = True, env: dict | None = None
) -> subprocess.CompletedProcess:
    """Run the README's workflow command in ``workdir`` (with its config.yaml unless ``config`` is
    False: then the repository's config/config.yaml)."""
    command = [sys.executable, "-m", *README_WORKFLOW, "-s", str(REPO / "Snakefile")]
    command += ["--directory", str(workdir)]
    if config:
        command += ["--configfile", str(workdir / "config.yaml"), "--replace-workflow-config"]
    # the rules call `python -m aceval`: make that the interpreter running the tests
    env = env or os.environ
    env = {**env, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"}
    return subprocess.run(command + list(args), capture_output=True, text=True, env=env)
