"""docs/your_data.md, run as written: its sheets and configuration are written from its code
blocks, its commands run one by one in a folder holding a lab's exports written from the
simulator (tests/labexports.py: three subjects, a standing trial / standing at the start / no
quiet standing, comma and tab, with and without the rate line, a sensor a sample short, the
lumbar sensor under the lab's own name). One `aceval import xsens` and the workflow give its
SUMMARY.md, in the folder the configuration names, nothing in the clone; the calibrations match
the simulation's truth."""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from aceval.data.contract import R_COLUMNS
from aceval.data.rotations import error_angle_deg

from .labexports import simulate, truth, write_lab
from .runner import REPO
from .tableexports import other_truth, write_other_lab

DOC = REPO / "docs" / "your_data.md"
BLOCK = re.compile(r"```(\w+)( [^\n]+)?\n(.*?)\n```", re.S)
#: the heading that starts the second walk-through (another vendor's exports)
SECOND = "\n# Another vendor's exports"


def doc_blocks(part: int = 1) -> tuple[dict[str, str], list[str]]:
    """The files (code blocks with a name after the language) and the commands (every line of
    its bash blocks, in order) of the doc's first walk-through (Xsens) or its second (part 2)."""
    files, commands = {}, []
    text = DOC.read_text().split(SECOND)[part - 1]
    for language, name, body in BLOCK.findall(text):
        if name:
            files[name.strip()] = body + "\n"
        elif language == "bash":
            commands += [line for line in body.replace("\\\n", " ").splitlines() if line.strip()]
    return files, commands


def test_the_doc_names_its_files_and_commands():
    files, commands = doc_blocks()
    assert set(files) == {"trials.tsv", "sensors.tsv", "my_lab.yaml"}
    assert [shlex.split(c)[:2] for c in commands] == [
        ["aceval", "import"], ["aceval", "validate"], ["aceval", "right-axis"],
        ["snakemake", "-s"], ["aceval", "apply"], ["aceval", "calibrate"], ["aceval", "apply"],
    ]  # fmt: skip
    assert "--decision aceval_out/results/my_lab/tables/decision.csv" in commands[4]
    assert "aceval_out/results/my_lab/SUMMARY.md" in DOC.read_text()
    files, commands = doc_blocks(2)
    assert set(files) == {"mapping.yaml", "trials.tsv", "sensors.tsv", "other_lab.yaml"}
    assert [shlex.split(c)[:3] for c in commands] == [
        ["aceval", "import", "table"], ["aceval", "validate", "other_lab"],
        ["aceval", "right-axis", "other_lab"], ["snakemake", "-s", "$ACEVAL/Snakefile"],
    ]  # fmt: skip


def run_the_doc(lab: Path, part: int) -> dict[str, str]:
    """Write the walk-through's files into ``lab`` and run its commands there as a user would
    (nothing may land in the clone's results/); what each command said, by its verb."""
    files, commands = doc_blocks(part)
    for name, text in files.items():
        (lab / name).write_text(text)
    env = {**os.environ, "ACEVAL": str(REPO)}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    env.pop("ACEVAL_LAUNCH_DIR", None)
    before = sorted(p.name for p in (REPO / "results").iterdir())
    said = {}
    for command in commands:
        run = subprocess.run(
            ["bash", "-c", command], cwd=lab, env=env, capture_output=True, text=True
        )
        assert run.returncode == 0, f"{command}\n{run.stderr[-3000:]}"
        said[shlex.split(command)[1]] = run.stdout + run.stderr
    assert sorted(p.name for p in (REPO / "results").iterdir()) == before  # nothing in the clone
    return said


@pytest.mark.slow
def test_every_command_of_the_doc_takes_the_exports_to_summary(tmp_path):
    lab = tmp_path / "lab"
    write_lab(lab / "exports", simulate(tmp_path))
    said = run_the_doc(lab, 1)
    # the import: every variant read, the short sensor trimmed, nothing left uncalibrated
    assert "trimmed to the" in said["import"] and "will not be calibrated" not in said["import"]
    assert "the rate given by hand, 100 Hz, fits the recordings" in said["import"]
    report = pd.read_csv(lab / "my_lab" / "import_report.tsv", sep="\t", dtype=str)
    assert (report["status"] == "imported").sum() == 5 * 10
    # the right axes the doc's sheet declares are the ones the recordings give: every sign from
    # walking alone (the lower back's from the pendulum, the feet's from their pitch)
    assert said["right-axis"].count(" sure ") == 5 and "is declared" not in said["right-axis"]
    assert said["right-axis"].count("foot pitch") == 2 and "trunk pendulum" in said["right-axis"]
    results = lab / "aceval_out" / "results" / "my_lab"
    summary = (results / "SUMMARY.md").read_text()
    assert "Xsens MT Manager exports" in summary
    _calibrations_match_the_truth(results, tmp_path / "simulated")


@pytest.mark.slow
def test_the_second_walk_through_takes_another_vendors_exports_to_summary(tmp_path):
    """Another vendor's text files, one per sensor, with a rate line and a JSON of phases per
    trial: the mapping and the two sheets of the doc take them to SUMMARY.md; the turns are cut
    out by the sheet, each walk takes its own trial's standing, and the calibrations match the
    simulation's truth."""
    lab = tmp_path / "lab"
    simulated = simulate(tmp_path, repetitions=4)
    write_other_lab(lab / "exports", simulated)
    said = run_the_doc(lab, 2)
    assert "6 file(s) beside the exports are not exports" in said["import"]
    assert "12 motion repetition(s) take the vertical of their own recording's" in said["import"]
    assert "turns by" not in said["import"]  # the segments leave the turns out
    report = pd.read_csv(lab / "other_lab" / "import_report.tsv", sep="\t", dtype=str)
    assert (report["status"] == "imported").sum() == 5 * 3 * 6  # 5 sensors, 3 rows x 6 trials
    # every sign from the walking itself (the feet's pitch, the trunk's pendulum, the shanks'
    # swing), each as the simulation mounted it
    assert said["right-axis"].count(" sure ") == 5 and "is declared" not in said["right-axis"]
    assert "trunk pendulum" in said["right-axis"] and " no " not in said["right-axis"]
    results = lab / "aceval_out" / "results" / "other_lab"
    summary = (results / "SUMMARY.md").read_text()
    assert "imported by aceval import table" in summary
    assert "Each repetition has its own vertical (z0)" in summary
    table = pd.concat(
        [pd.read_csv(p, dtype={"subject": str}) for p in (results / "calibrations").glob("P0?.csv")]
    )
    kong = table[(table["method"] == "kong") & (table["repetitions"] == "R1+R2+R3+R4")]
    both = kong.merge(other_truth(simulated), on=["subject", "imu"], suffixes=("", "_true"))
    assert len(both) == 15 and (both["z0_tests"] == "quiet (per repetition)").all()
    errors = error_angle_deg(
        both[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3),
        both[[f"{c}_true" for c in R_COLUMNS]].to_numpy(float).reshape(-1, 3, 3),
    )
    assert (errors < 10).all(), both.assign(error=errors)[["subject", "imu", "error"]]


def _calibrations_match_the_truth(results: Path, simulated: Path) -> None:
    """Kong's calibrations from all repetitions against the simulated mountings: within 10 deg
    for the subjects who stood still; P03's walking vertical costs its legs more (docs'
    numbers), not its lower back."""
    table = pd.concat(
        [pd.read_csv(p, dtype={"subject": str}) for p in (results / "calibrations").glob("P0?.csv")]
    )
    kong = table[(table["method"] == "kong") & (table["repetitions"] == "R1+R2+R3")]
    both = kong.merge(truth(simulated), on=["subject", "imu"], suffixes=("", "_true"))
    both["error"] = error_angle_deg(
        both[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3),
        both[[f"{c}_true" for c in R_COLUMNS]].to_numpy(float).reshape(-1, 3, 3),
    )
    assert len(both) == 15
    errors = both.set_index(["subject", "imu"])["error"]
    assert (errors[["P01", "P02"]] < 10).all(), errors
    legs = [imu for imu in errors.index.levels[1] if imu != "lower_back"]
    assert errors["P03"][legs].min() > np.median(errors[["P01", "P02"]])
    assert errors[("P03", "lower_back")] < 10
