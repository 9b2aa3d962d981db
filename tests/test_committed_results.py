"""The committed results/ are what the default workflow produces: regenerate them from clean in a
temporary folder (the whole default run, about a minute on 2 cores) and compare byte for byte."""

from pathlib import Path

from .test_workflow import REPO, snakemake

COMMITTED = ["*/SUMMARY.md", "*/validation.txt", "*/tables/*.csv", "*/tables/*.md"]


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for pattern in COMMITTED for p in root.glob(pattern)}


def test_default_workflow_regenerates_the_committed_results(tmp_path):
    run = snakemake(tmp_path, config=False)  # the default config/config.yaml
    assert run.returncode == 0, run.stderr[-3000:]
    committed, regenerated = files(REPO / "results"), files(tmp_path / "results")
    assert committed, "no committed results found"
    assert sorted(regenerated) == sorted(committed)
    differing = [name for name in committed if committed[name] != regenerated[name]]
    assert not differing, f"regenerated results differ from the committed ones: {differing}"
