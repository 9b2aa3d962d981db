"""Issue 50's cases (a fourth sweep of bad input, run as users run aceval): each one ends in an
error naming the file, line and cause, a flag, or the right number. The commands run through the
sweep's runner (tests/sweep.py: ``aceval``), the datasets are its :class:`Workspace`'s; the cases
that need the workflow are marked slow. config/README.md's table of checks gives each new check's
false-alarm and catch rates (``python benchmarks/input_check_rates.py``).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from aceval.cli import main
from aceval.methods import registry
from aceval.workflow_plan import Configuration, duplicate_keys

from .runner import REPO, snakemake
from .sweep import (
    GYR,
    Workspace,
    aceval,
    calibrations,
    change_recordings,
    checksums,
    drop_yaml_key,
    read_recording,
    recordings_of,
    sheet,
    write_recording,
    write_sheet,
)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Workspace:
    return Workspace(tmp_path_factory.mktemp("round4"))


def said_lines(result) -> list[str]:
    return result.said.splitlines()


def assert_clean_error(result, *says: str, code: int = 1) -> None:
    """A non-zero exit saying every one of ``says``, no traceback."""
    assert result.code == code and not result.traceback, result.said[-3000:]
    for text in says:
        assert text in result.said, f"{text!r} not in:\n{result.said[-3000:]}"


# --- 1. segment names ----------------------------------------------------------------------------


def walking_shank(ws: Workspace, tmp: Path, segment: str) -> Path:
    """A one-sided walking dataset: the right shank only, T0 and T6, its right axis declared
    '-y' (the truth: '+y'), its segment spelled ``segment``."""
    lab = ws.copy("small", tmp)
    recordings = sheet(lab / "recordings.tsv")
    keep = (recordings["imu"] == "IMU5") & recordings["test"].isin(["T0", "T6"])
    write_sheet(recordings[keep], lab / "recordings.tsv")
    write_sheet(pd.DataFrame({"test": ["T6"], "imu": ["IMU5"]}), lab / "calibrates.tsv")
    imus = sheet(lab / "imus.tsv")
    imus = imus[imus["imu"] == "IMU5"].assign(segment=segment, right_axis="-y")
    write_sheet(imus, lab / "imus.tsv")
    truth = sheet(lab / "ground_truth.tsv")
    write_sheet(truth[truth["imu"] == "IMU5"], lab / "ground_truth.tsv")
    meta = yaml.safe_load((lab / "dataset.yaml").read_text())
    meta["acc_range_g"] = {"lower_body": meta["acc_range_g"]["lower_body"]}
    (lab / "dataset.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    return lab


@pytest.mark.parametrize("segment", ["Shank", "SHANK", "shánk"])
def test_a_segment_spelled_otherwise_is_refused_with_its_line(workspace, tmp_path, segment):
    """Before: 'Shank' switched the direction check in walking off (every method 180 deg off,
    '0 flagged')."""
    lab = walking_shank(workspace, tmp_path, segment)
    says = ("imus.tsv line 2", f"segment {segment!r}", "'shank'")
    assert_clean_error(aceval("validate", lab), *says)
    assert_clean_error(aceval("calibrate", lab, "--out", tmp_path / "out.csv"), *says)
    assert not (tmp_path / "out.csv").exists()


def test_with_the_segment_spelled_shank_every_row_is_flagged_backward(workspace, tmp_path):
    lab = walking_shank(workspace, tmp_path, "shank")
    result = aceval("calibrate", lab, "--out", tmp_path / "out.csv", "--subsets", "full")
    assert result.code == 0, result.said[-3000:]
    table = calibrations(tmp_path / "out.csv")
    assert sorted(table["method"]) == sorted(registry.own())
    assert table["flag"].str.split(";").map(lambda f: "backward" in f).all(), table["flag"]


def test_unknown_segment_and_side_text(workspace, tmp_path):
    """A side spelled otherwise is refused; a segment aceval does not know is a warning that says
    what is not judged for it (and proposes the known name it is close to)."""
    lab = workspace.copy("small", tmp_path)
    imus = sheet(lab / "imus.tsv")
    imus.loc[imus["imu"] == "IMU5", "side"] = "Right"
    write_sheet(imus, lab / "imus.tsv")
    assert_clean_error(aceval("validate", lab), "imus.tsv line 4", "side 'Right'", "'right'")
    imus.loc[imus["imu"] == "IMU5", ["side", "segment"]] = ["right", "shanks"]
    write_sheet(imus, lab / "imus.tsv")
    result = aceval("validate", lab)
    assert result.code == 0, result.said[-3000:]
    assert any(
        "imus.tsv line 4" in line and "segment 'shanks'" in line and "'shank'?" in line
        for line in said_lines(result)
    ), result.said


# --- 3. a key given twice in a workflow configuration ---------------------------------------------


TWICE = """run: [my_lab]
datasets:
  my_lab:
    path: {first}
    analyses: [kong]
  my_lab:
    path: {second}
    analyses: [kong]
peers: []
"""


def test_a_config_key_given_twice_is_named_with_file_and_lines(tmp_path):
    config = tmp_path / "my_lab.yaml"
    config.write_text(TWICE.format(first="/data/a", second="/data/b"))
    assert duplicate_keys(str(config)) == [
        f"{config} line 6: key 'datasets.my_lab' is given twice (first at line 3): YAML keeps "
        "the last one without a word, so the first is never used; remove or rename one"
    ]
    assert duplicate_keys(str(REPO / "config" / "config.yaml")) == []
    assert duplicate_keys(str(REPO / "config" / "real.yaml")) == []


def test_summary_says_which_data_each_dataset_comes_from(tmp_path):
    config = {
        "datasets": {
            "my_lab": {"path": str(tmp_path / "lab"), "analyses": ["kong"]},
            "sim": {"simulate": {"protocol": "kong", "seed": 3}, "analyses": ["kong"]},
        },
        "objectives": {"test_retest_k": 3},
    }
    plan = Configuration(config, str(REPO))
    notes = [o for o in plan.results_options("my_lab") if o.startswith("--note=Data:")]
    assert notes == [f"--note=Data: the dataset folder {tmp_path / 'lab'} (config "
                     "`datasets.my_lab.path`)."]  # fmt: skip
    assert "protocol kong, seed 3" in plan.data_note("sim")


@pytest.mark.slow
def test_the_workflow_refuses_a_config_with_a_key_given_twice(workspace, tmp_path):
    config = tmp_path / "my_lab.yaml"
    config.write_text(TWICE.format(first=workspace.small(), second=workspace.kong()))
    run = snakemake(tmp_path, "--configfile", str(config), "--dry-run", config=False)
    output = run.stdout + run.stderr
    assert run.returncode != 0
    assert f"{config} line 6: key 'datasets.my_lab' is given twice (first at line 3)" in output


# --- 5. a very short repetition ----------------------------------------------------------------


def cut_around_peak(table: pd.DataFrame, samples: int = 49) -> pd.DataFrame:
    peak = int(np.argmax(np.linalg.norm(table[GYR].to_numpy(float), axis=1)))
    start = max(0, peak - samples // 2)
    return table.iloc[start : start + samples].reset_index(drop=True)


def test_a_repetition_of_half_a_second_is_left_out_with_its_reason(workspace, tmp_path):
    """Before: warned 'very short', and the axis methods' leg-swing calibrations of the thigh
    moved 5.0 deg (TRIAD 4.1) with no flag. Now the recording is left out (``too_short``, on
    screen and in the recordings table) and every calibration of that unit is the one from the
    other repetitions: the same numbers as with the row removed from recordings.tsv."""
    lab = workspace.copy("small", tmp_path / "cut")
    (target,) = recordings_of(lab, "IMU4", "T5", rep=1)
    change_recordings([target], cut_around_peak)
    out, rows = tmp_path / "out.csv", tmp_path / "recordings.csv"
    result = aceval("calibrate", lab, "--out", out, "--recordings-out", rows, "--subsets", "full")
    assert result.code == 0, result.said[-3000:]
    assert any(
        "left out" in line and target.name in line and "shorter than 1 s" in line
        for line in said_lines(result)
    ), result.said[-3000:]
    summaries = pd.read_csv(rows, keep_default_na=False)
    left_out = summaries[summaries["flag"] == "too_short"]
    assert list(zip(left_out["imu"], left_out["test"], left_out["rep"])) == [("IMU4", "T5", 1)]

    without = workspace.copy("small", tmp_path / "without")
    recordings = sheet(without / "recordings.tsv")
    drop = (recordings["imu"] == "IMU4") & (recordings["test"] == "T5") & (recordings["rep"] == "1")
    write_sheet(recordings[~drop], without / "recordings.tsv")
    reference = tmp_path / "reference.csv"
    assert aceval("calibrate", without, "--out", reference, "--subsets", "full").code == 0
    unit = ["subject", "sensor_set", "imu", "test", "method", "repetitions"]
    got, expected = calibrations(out), calibrations(reference)
    thigh = got[(got["imu"] == "IMU4") & (got["test"] == "T5")]
    assert not thigh["repetitions"].str.contains("R1").any()
    columns = unit + [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)] + ["flag"]
    pd.testing.assert_frame_equal(
        got[columns].sort_values(unit).reset_index(drop=True),
        expected[columns].sort_values(unit).reset_index(drop=True),
    )


# --- 6. a gyroscope in rad/s declared deg/s ------------------------------------------------------


def heel_strikes(table: pd.DataFrame) -> pd.DataFrame:
    """A heel strike where the shank turns fastest: 8 g for one sample on acc_x, with the jolt of
    the gyroscope a real one has (40 deg/s in that sample)."""
    table = table.copy()
    at = int(np.argmax(np.linalg.norm(table[GYR].to_numpy(float), axis=1)))
    table.loc[at, "acc_x"] += 8.0
    table.loc[at, "gyr_y"] += 40.0
    return table


def test_a_gyroscope_in_rad_s_declared_deg_s_is_named(workspace, tmp_path):
    """Before: validate passed with 0 warnings of units, calibrate said 'no movement' for every
    recording, and the heel strikes were reported as acceleration spikes."""
    lab = workspace.copy("small", tmp_path)
    drop_yaml_key(lab, "gyr_range_dps")
    change_recordings(recordings_of(lab, "IMU5", "T6"), heel_strikes)
    clean = aceval("validate", lab)
    assert clean.code == 0 and "spike" not in clean.said and "units.gyr" not in clean.said
    change_recordings(recordings_of(lab), lambda t: t.assign(**{c: np.radians(t[c]) for c in GYR}))
    findings = tmp_path / "findings.tsv"
    result = aceval("validate", lab, "--findings-out", findings)
    assert result.code == 0, result.said[-3000:]
    motion = sheet(lab / "recordings.tsv").query("test != 'T0'")
    # on screen one line per kind of warning (with its count); every one in the findings file
    on_screen = [line for line in said_lines(result) if "are units.gyr (deg/s) right?" in line]
    assert len(on_screen) == 1 and f"WARNING {len(motion)} x" in on_screen[0], result.said[-3000:]
    doubted = [line for line in findings.read_text().splitlines() if "are units.gyr" in line]
    assert len(doubted) == len(motion), findings.read_text()[-3000:]
    assert all("Read as rad/s" in line for line in doubted)
    assert "spike" not in result.said
    calibrated = aceval("calibrate", lab, "--out", tmp_path / "out.csv")
    assert_clean_error(calibrated, "nothing to calibrate")
    left_out = [s for s in said_lines(calibrated) if s.startswith("aceval calibrate: left out")]
    assert len(left_out) == len(motion) and all("units.gyr" in line for line in left_out)


# --- 7. a left-handed gyroscope ------------------------------------------------------------------


def walking_frontal(ws: Workspace, tmp: Path) -> Path:
    """The Kong dataset's frontal set, standing and walking only (both legs: the side check)."""
    lab = ws.copy("kong", tmp)
    recordings = sheet(lab / "recordings.tsv")
    keep = (recordings["sensor_set"] == "frontal") & recordings["test"].isin(["T0", "T6"])
    write_sheet(recordings[keep], lab / "recordings.tsv")
    return lab


def test_a_left_handed_gyroscope_is_named_not_a_side_exchange(workspace, tmp_path):
    """Walking only, the right shank's gyr_y negated (its swing axis): before, 'on the other leg
    (left and right exchanged)?'."""
    lab = walking_frontal(workspace, tmp_path)
    change_recordings(
        recordings_of(lab, "IMU5", sensor_set="frontal"), lambda t: t.assign(gyr_y=-t["gyr_y"])
    )
    out = tmp_path / "out.csv"
    result = aceval("calibrate", lab, "--out", out, "--subsets", "full")
    assert result.code == 0, result.said[-3000:]
    about = [line for line in said_lines(result) if "frontal IMU5" in line]
    assert about and "left-handed" in about[0] and "left and right exchanged" not in about[0]
    table = calibrations(out)
    shank = table[(table["imu"] == "IMU5") & (table["sensor_set"] == "frontal")]
    assert shank["flag"].str.split(";").map(lambda f: "swing_reversed" in f).all()
    assert not table["flag"].str.contains("opposite_side_timing").any()


def test_legs_exchanged_in_walking_still_say_so(workspace, tmp_path):
    lab = walking_frontal(workspace, tmp_path)
    recordings = sheet(lab / "recordings.tsv")
    frontal = recordings["sensor_set"] == "frontal"
    recordings.loc[frontal, "imu"] = recordings.loc[frontal, "imu"].replace(
        {"IMU5": "IMU8", "IMU8": "IMU5"}
    )
    write_sheet(recordings, lab / "recordings.tsv")
    out = tmp_path / "out.csv"
    result = aceval("calibrate", lab, "--out", out, "--subsets", "full")
    assert result.code == 0, result.said[-3000:]
    table = calibrations(out)
    for imu in ("IMU5", "IMU8"):
        rows = table[(table["imu"] == imu) & (table["sensor_set"] == "frontal")]
        assert rows["flag"].str.contains("opposite_side_timing").all(), rows["flag"]
    assert not table["flag"].str.contains("swing_reversed").any()


# --- 8. resuming a killed workflow ----------------------------------------------------------------


def test_the_default_profile_reruns_incomplete_jobs_and_the_docs_say_how_to_resume():
    profile = yaml.safe_load((REPO / "profiles" / "default" / "config.yaml").read_text())
    assert profile["rerun-incomplete"] is True
    reference = (REPO / "docs" / "reference.md").read_text()
    assert "**After a killed workflow**" in reference and "snakemake --unlock" in reference
    assert "snakemake --unlock" in (REPO / "README.md").read_text()


@pytest.mark.slow
def test_a_killed_workflow_resumes_after_unlock(workspace, tmp_path):
    """kill -9 of snakemake and its jobs while calibrating, then `--unlock` and the same command:
    the run completes (the default profile reruns the incomplete jobs)."""
    work = tmp_path / "work"
    work.mkdir()
    config = {
        "run": ["lab"],
        "datasets": {"lab": {"path": str(workspace.small()), "analyses": ["kong"]}},
        "peers": [],
    }
    (work / "config.yaml").write_text(yaml.safe_dump(config))
    command = [sys.executable, "-m", "snakemake", "--cores", "2", "-s", str(REPO / "Snakefile")]
    command += ["--directory", str(work), "--configfile", str(work / "config.yaml")]
    command += ["--replace-workflow-config"]  # as tests/runner.py runs it, in its environment
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    killed = subprocess.Popen(
        command,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # its jobs too: kill -9 of the whole run
        env={**os.environ, "PATH": path},
    )
    deadline = time.time() + 300
    calibrations_dir = work / "results" / "lab" / "calibrations"
    while time.time() < deadline and not (
        calibrations_dir.is_dir() and any(calibrations_dir.iterdir())
    ):
        time.sleep(0.05)  # until a calibration job is under way
    os.killpg(killed.pid, signal.SIGKILL)
    killed.wait()
    locked = snakemake(work)
    assert locked.returncode != 0 and "--unlock" in locked.stdout + locked.stderr
    assert snakemake(work, "--unlock").returncode == 0
    resumed = snakemake(work)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert (work / "results" / "lab" / "SUMMARY.md").is_file()


# --- 9. Ctrl-C --------------------------------------------------------------------------------


def test_ctrl_c_during_calibrate_is_one_line_and_exit_130(workspace, tmp_path, monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("aceval.calibrate.pipeline.calibrate", interrupted)
    out = tmp_path / "out" / "calibrations.csv"
    argv = ["calibrate", str(workspace.small()), "--out", str(out), "--findings-out"]
    try:
        code = main([*argv, str(tmp_path / "out" / "findings.tsv")])
    except KeyboardInterrupt:  # before: it went up as a traceback
        code = "KeyboardInterrupt raised"
    assert code == 130
    err = capsys.readouterr().err
    assert err.splitlines()[-1] == "aceval calibrate: interrupted (Ctrl-C); no output written"
    assert "Traceback" not in err
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


@pytest.mark.slow
def test_sigint_of_calibrate_prints_one_line_and_leaves_nothing(workspace, tmp_path):
    lab = workspace.kong()
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "aceval", "calibrate", str(lab), "--out", str(out / "c.csv")],
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 60
    while time.time() < deadline and not list(out.glob(".aceval-*")):
        time.sleep(0.01)  # until it has reserved its output: the work has begun
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=60) == 130
    assert process.stderr.read() == "aceval calibrate: interrupted (Ctrl-C); no output written\n"
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


# --- 10. subject labels that hold a path ------------------------------------------------------------


@pytest.mark.parametrize("label", ["../S1", "a/b", "S1\\x", ".."])
def test_a_subject_label_holding_a_path_is_refused_at_validate(workspace, tmp_path, label):
    lab = workspace.copy("small", tmp_path)
    for name in ("subjects.tsv", "recordings.tsv", "ground_truth.tsv"):
        table = sheet(lab / name)
        write_sheet(table.assign(subject=table["subject"].replace({"S1": label})), lab / name)
    assert_clean_error(
        aceval("validate", lab, "--sheets-only"),
        "subjects.tsv line 2",
        f"subject {label!r} holds a path",
    )


# --- 11. what the sheets declare, and time -----------------------------------------------------------


def test_an_empty_calibrates_sheet_is_refused_at_validate(workspace, tmp_path):
    lab = workspace.copy("small", tmp_path)
    (lab / "calibrates.tsv").write_text("test\timu\n")
    assert_clean_error(aceval("validate", lab, "--sheets-only"), "calibrates.tsv", "no rows")


def test_fewer_repetitions_than_declared_are_named(workspace, tmp_path):
    lab = workspace.copy("small", tmp_path)
    recordings = sheet(lab / "recordings.tsv")
    drop = (recordings["imu"] == "IMU4") & (recordings["test"] == "T5") & (recordings["rep"] == "3")
    write_sheet(recordings[~drop], lab / "recordings.tsv")
    result = aceval("validate", lab, "--sheets-only")
    assert result.code == 0, result.said[-3000:]
    expected = (
        "recordings.tsv: subject S1, set frontal, IMU IMU4: 2 repetition(s) of T5 recorded "
        "(R1, R2), tests.tsv declares 3"
    )
    assert [line for line in said_lines(result) if "declares" in line] == [
        f"WARNING {expected}: a repetition missing from recordings.tsv?"
    ]


@pytest.mark.parametrize("jump_s", [0.3, 0.8, 5.0])
def test_a_jump_in_time_is_reported_with_its_line(workspace, tmp_path, jump_s):
    lab = workspace.copy("small", tmp_path)
    (target,) = recordings_of(lab, "IMU4", "T5", rep=2)
    table = read_recording(target)
    table.loc[200:, "t"] += jump_s
    write_recording(table, target)
    result = aceval("validate", lab)
    assert result.code == 0, result.said[-3000:]
    found = [line for line in said_lines(result) if target.name in line and "t jumps" in line]
    assert len(found) == 1, result.said[-3000:]
    assert f"t jumps by {jump_s + 0.01:.3g} s at line 202" in found[0]


# --- 12. Ricci's static posture -------------------------------------------------------------------


@pytest.fixture(scope="module")
def ricci(workspace) -> Path:
    path = workspace.cache / "ricci"
    if not path.is_dir():
        made = aceval("simulate", "ricci", "--out", path, "--subjects", 1, "--seed", 1)
        assert made.code == 0, made.err
    return path


def test_ricci_static_posture_is_not_judged_standing(ricci, tmp_path):
    """Ricci's static trial lies supine (functional_axes.tsv declares the direction of its
    specific force per segment): before, 'taken seated or leaning, not standing?' for every
    IMU but the forearms, and '(0 flagged)'."""
    before = checksums(ricci)
    result = aceval("calibrate", ricci, "--out", tmp_path / "out.csv")
    assert result.code == 0, result.said[-3000:]
    assert "seated or leaning" not in result.said
    assert not [line for line in said_lines(result) if line.startswith("aceval calibrate: flagged")]
    assert (calibrations(tmp_path / "out.csv")["flag"] == "").all()
    assert checksums(ricci) == before


def test_ricci_design_flags_what_the_sensor_checks_find(ricci, tmp_path):
    """What aceval calibrate says it flags is in the table on Ricci's design too."""
    lab = tmp_path / "lab"
    shutil.copytree(ricci, lab)
    change_recordings(
        recordings_of(lab, "SU2"), lambda t: t.assign(acc_x=t["acc_y"], acc_y=t["acc_x"])
    )
    result = aceval("calibrate", lab, "--out", tmp_path / "out.csv")
    assert result.code == 0, result.said[-3000:]
    assert "flagged C01 main SU2" in result.said
    table = calibrations(tmp_path / "out.csv")
    flagged = table["flag"].str.split(";").map(lambda f: "gyro_acc_inconsistent" in f)
    assert flagged[table["imu"] == "SU2"].all() and not flagged[table["imu"] != "SU2"].any()
