"""The Snakemake workflow end to end on tiny configs in temporary folders (about a minute)."""

import hashlib
import os
import shutil
from pathlib import Path

import pandas as pd
import pytest
import yaml

from aceval.data.safety import MARKER

from .datasets import succeeded
from .runner import snakemake

pytestmark = pytest.mark.slow  # runs the workflow


def write_config(workdir: Path, datasets: dict, test_retest_k: int = 2) -> None:
    """A small config of these datasets. The peers are left out: these tests check the workflow's
    behaviour; the committed regeneration (tests/test_committed_results.py) runs them."""
    workdir.mkdir(parents=True, exist_ok=True)
    config = {
        "datasets": datasets,
        "peers": [],
        "calibration": {
            "trim": {"threshold": 0.1, "closing_s": 1.0, "window_s": 0.5, "min_peak_deg_s": 20}
        },
        "objectives": {
            "correlation": "concatenated",
            "test_retest_k": test_retest_k,
            "segment_pairs": {"thighs-shanks": {"segments": ["thigh", "shank"], "t_ap": ["T5"]}},
        },
    }
    (workdir / "config.yaml").write_text(yaml.safe_dump(config))


def digest(folder: Path) -> str:
    sha = hashlib.sha256()
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            sha.update(str(path.relative_to(folder)).encode() + path.read_bytes())
    return sha.hexdigest()


@pytest.fixture(scope="module")
def tiny(clean) -> Path:
    """2 simulated subjects, 3 repetitions of each test, CSV (a lab's export, broken by the tests
    file by file)."""
    options = ["--seed", 1, "--subjects", 2, "--repetitions", 3, "--format", "csv"]
    return clean.shared("tiny", lambda at: succeeded("simulate", "kong", "--out", at, *options))


def lab_copy(source: Path, target: Path, drop=None, copy_data=False) -> Path:
    """A lab-style copy of a dataset: the sheets copied (recordings filtered by ``drop``), the data
    folder linked (or copied, to break it)."""
    target.mkdir(parents=True)
    for sheet in source.glob("*.tsv"):
        shutil.copy(sheet, target / sheet.name)
    shutil.copy(source / "dataset.yaml", target / "dataset.yaml")
    if copy_data:
        shutil.copytree(source / "data", target / "data")
    else:
        (target / "data").symlink_to(source / "data")
    if drop is not None:
        recordings = pd.read_csv(target / "recordings.tsv", sep="\t", dtype=str)
        recordings[~drop(recordings)].to_csv(target / "recordings.tsv", sep="\t", index=False)
    return target


def test_workflow_end_to_end_then_nothing_to_do(tiny, tmp_path):
    """A lab dataset whose subject S2 has no T5: every table, figure and summary is written; T5
    analyses count S1 only; a second run has nothing to do; raw data are untouched. (The simulated
    datasets, the box among them, run in the committed regeneration: tests/test_committed_results.py.)
    """
    lab = lab_copy(
        tiny, tmp_path / "lab", drop=lambda r: (r["subject"] == "S2") & (r["test"] == "T5")
    )
    before = digest(tiny)
    work = tmp_path / "work"
    write_config(
        work,
        {"lab": {"path": str(lab), "analyses": ["kong"]}},
    )
    run = snakemake(work)
    assert run.returncode == 0, run.stderr[-3000:]
    results = work / "results"
    for n in (3, 6, 7, 8, 9, 10, 11):
        assert (results / "lab" / "tables" / f"table{n}.md").stat().st_size > 0
    for n in (6, 8, 9, 10):
        assert (results / "lab" / "figures" / f"figure{n}.png").stat().st_size > 0
    assert (
        "SIMULATED" in (results / "lab" / "tables" / "table9.md").read_text()
    )  # dataset.yaml says so

    table9 = pd.read_csv(results / "lab" / "tables" / "table9.csv").set_index(["t_ex", "segment"])
    # thighs: 2 IMUs x 2 sets x C(3, 2) pairs of 2-subsets per subject; T5 has S1 only
    assert table9.loc[("T6", "thigh"), "n"] == 2 * 2 * 2 * 3
    assert table9.loc[("T5", "thigh"), "n"] == 2 * 2 * 1 * 3
    # no temporaries left (the marker of a folder aceval wrote as a whole is not one)
    assert not [p for p in results.rglob(".aceval-*") if p.name != MARKER]
    assert digest(tiny) == before

    # a lab calibrating the same folder with one command (and the config's Obj 4 k, for the axis
    # methods' subsets) gets exactly the workflow's calibrations
    standalone = tmp_path / "standalone.csv"
    succeeded("calibrate", lab, "--out", standalone, "--retest-k", 2)
    per_subject = sorted((results / "lab" / "calibrations").glob("S?.csv"))
    workflow = pd.concat([pd.read_csv(p) for p in per_subject], ignore_index=True)
    # (a subject whose flags are all empty reads them as numbers: the dtypes differ, the values not)
    pd.testing.assert_frame_equal(pd.read_csv(standalone), workflow, check_dtype=False)

    again = snakemake(work, "--dry-run")
    assert again.returncode == 0
    assert "Nothing to be done" in again.stdout + again.stderr


def test_invalid_dataset_stops_before_any_calibration(tiny, tmp_path):
    broken = lab_copy(tiny, tmp_path / "broken", copy_data=True)
    missing = broken / "data" / "S2" / "lateral" / "T4_R2_IMU5.csv"
    missing.unlink()
    work = tmp_path / "work"
    write_config(work, {"broken": {"path": str(broken), "analyses": ["kong"]}})
    run = snakemake(work)
    assert run.returncode != 0
    output = run.stdout + run.stderr
    assert "data/S2/lateral/T4_R2_IMU5.csv" in output and "file is missing" in output
    assert not (work / "results" / "broken" / "calibrations").exists()
    assert not (work / "results" / "broken" / "validation.txt").exists()
    assert not (work / "results" / "broken" / "validation" / "sheets.tsv").exists()


def test_config_is_validated_against_the_schema(tmp_path):
    write_config(tmp_path, {"x": {"simulate": {"protocol": "nope"}}})
    run = snakemake(tmp_path, "--dry-run")
    assert run.returncode != 0
    assert "nope" in run.stdout + run.stderr


def test_any_folder_name_reaches_the_shell_quoted_and_validation_follows_the_files(clean, tmp_path):
    """A dataset folder with a space, quotes, non-ASCII letters and a command substitution runs
    through the whole workflow without running anything it names; a recording changed after a good
    run is validated again (and stops the workflow) instead of being dropped silently."""
    lab = tmp_path / "lab dir 'ü\" $(touch PWNED)"
    shutil.copytree(clean.small(), lab)
    work = tmp_path / "work"
    write_config(
        work,
        {"lab": {"path": str(lab), "analyses": ["kong"], "note": "it's a note; $(touch PWNED2)"}},
    )
    run = snakemake(work)
    assert run.returncode == 0, run.stderr[-3000:]
    assert (work / "results" / "lab" / "tables" / "table9.md").exists()
    assert "it's a note; $(touch PWNED2)" in (work / "results" / "lab" / "SUMMARY.md").read_text()
    assert not list(tmp_path.rglob("PWNED*")) and not list(Path.cwd().glob("PWNED*"))

    results = work / "results" / "lab"
    before = {p: p.stat().st_mtime_ns for p in results.rglob("*") if p.is_file()}
    changed = lab / "data" / "S1" / "frontal" / "T1_R2_IMU2.csv"

    # a same-size edit with its modification time put back is still seen (content hashes)
    stat, text = changed.stat(), changed.read_text()
    digit = text.index("\n0.05,") + 4
    changed.write_text(text[:digit] + ("6" if text[digit] != "6" else "7") + text[digit + 1 :])
    os.utime(changed, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert changed.stat().st_size == stat.st_size
    dry = snakemake(work, "--dry-run")
    assert "calibrate" in dry.stdout and "Nothing to be done" not in dry.stdout, dry.stdout[-2000:]
    changed.write_text(text)
    changed.write_text(changed.read_text().replace(",", ";"))
    again = snakemake(work)
    assert again.returncode != 0
    assert (
        "T1_R2_IMU2.csv" in again.stderr + again.stdout
        and "comma-separated" in again.stderr + again.stdout
    )
    # the gate ran again on the changed file and failed: its report is gone, and nothing was
    # recomputed from the broken file (the previous run's outputs are older than it)
    assert not (results / "validation" / "sheets.tsv").exists()
    after = {p: p.stat().st_mtime_ns for p in results.rglob("*") if p.is_file()}
    assert all(after[p] == before[p] for p in after)

    # a defect only a full read finds (NaN deep in the file): the pass that reads the file stops
    # the workflow, naming the file, the line and the cause
    changed.write_text(changed.read_text().replace(";", ","))
    text = changed.read_text().splitlines()
    text[40] = "nan" + text[40][text[40].index(",") :]
    changed.write_text("\n".join(text) + "\n")
    third = snakemake(work)
    assert third.returncode != 0
    output = third.stderr + third.stdout
    assert (
        "T1_R2_IMU2.csv" in output and "NaN, inf or non-numeric" in output and "line 41" in output
    )
