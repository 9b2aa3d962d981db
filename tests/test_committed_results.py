"""The committed results/ are what the workflow produces: regenerate them from clean in a temporary
folder (the default run, about a minute on 2 cores; the real-data run, about 40 s) and compare byte
for byte."""

from pathlib import Path

import pytest
import yaml

from .test_workflow import REPO, snakemake

pytestmark = pytest.mark.slow  # regenerates every committed result from clean

DATA = REPO.parent / "shared" / "data"
PEERS = REPO / ".venv-peers"

COMMITTED = [
    "*/SUMMARY.md",
    "*/validation.txt",
    "*/tables/*.csv",
    "*/tables/*.md",
    "*/figures/*.png",
]


def files(root: Path, config: str) -> dict[str, bytes]:
    """The committed kinds of file of the datasets that ``config`` runs."""
    datasets = yaml.safe_load((REPO / "config" / config).read_text())["run"]
    return {
        str(p.relative_to(root)): p.read_bytes()
        for dataset in datasets
        for pattern in COMMITTED
        for p in (root / dataset).glob(pattern.removeprefix("*/"))
    }


def compare(tmp_path: Path, config: str) -> None:
    committed, regenerated = files(REPO / "results", config), files(tmp_path / "results", config)
    assert committed, "no committed results found"
    assert sorted(regenerated) == sorted(committed)
    differing = [name for name in committed if committed[name] != regenerated[name]]
    assert not differing, f"regenerated results differ from the committed ones: {differing}"


def _peers_ready() -> None:
    """The committed results list the peer tools: their environments must exist to regenerate
    them (a fresh clone builds them with `snakemake --cores 2 peer_envs`; .ci/run does)."""
    missing = [
        env
        for env in ("gaitmap", "qmt", "opensim")
        if not (PEERS / env / "bin" / "python").exists()
    ]
    if missing:
        pytest.fail(
            f"the committed results list the peers, whose environments are missing "
            f"({', '.join(missing)} under {PEERS}): run `snakemake --cores 2 peer_envs` first"
        )


def test_default_workflow_regenerates_the_committed_results(tmp_path):
    _peers_ready()
    run = snakemake(tmp_path, config=False)  # the default config/config.yaml
    assert run.returncode == 0, run.stderr[-3000:]
    compare(tmp_path, "config.yaml")


@pytest.mark.skipif(
    not DATA.is_dir(), reason=f"real recordings not found at {DATA} (see ../shared/data/README.md)"
)
def test_real_workflow_regenerates_the_committed_results(tmp_path):
    _peers_ready()
    run = snakemake(
        tmp_path,
        "--configfile",
        str(REPO / "config" / "real.yaml"),
        "--config",
        f"data_root={DATA}",
        config=False,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    compare(tmp_path, "real.yaml")
