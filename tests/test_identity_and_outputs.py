"""Identity that survives and outputs that cannot destroy inputs (issue 41): subject labels by one
rule, the labels in the recordings' fingerprint, apply's choice of calibration, outputs against
each other and against every recording's resolved path."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest

from aceval.apply import chosen_calibrations, fingerprints
from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import load_dataset, validate
from aceval.data.names import subject_key
from aceval.data.safety import (
    UnsafeOutputError,
    check_distinct,
    check_folder_output,
    check_recordings,
)

from .minidataset import make_dataset


@pytest.fixture
def mini(tmp_path):
    return make_dataset(tmp_path / "mini")


def relabel(root, old: str, new: str, sheets=("subjects.tsv", "recordings.tsv")) -> None:
    for sheet in sheets:
        path = root / sheet
        path.write_text(path.read_text().replace(f"\n{old}\t", f"\n{new}\t"))


def test_subject_labels_are_compared_by_one_rule(mini):
    assert subject_key("1") == subject_key("01") == subject_key("001") == subject_key("1.0")
    assert subject_key("S1") != subject_key("S01")
    relabel(mini, "S1", "001", sheets=("subjects.tsv",))
    relabel(mini, "S1", "1", sheets=("recordings.tsv",))
    dataset = load_dataset(mini)  # recordings.tsv's '1' is subjects.tsv's '001'
    assert set(dataset.recordings["subject"]) == {"001"}
    assert dataset.subject_label("01") == "001"
    (mini / "subjects.tsv").write_text((mini / "subjects.tsv").read_text() + "01\t180\n")
    _, report = validate(mini, check_files=False)
    assert any("'001' and '01' are one subject" in str(f) for f in report.errors)


def test_the_fingerprint_hashes_the_labels(mini):
    before = fingerprints(load_dataset(mini), "S1")
    sheet = (mini / "recordings.tsv").read_text()
    (mini / "recordings.tsv").write_text(sheet.replace("\tT1\t1\t", "\tT1\t9\t", 1))
    after = fingerprints(load_dataset(mini), "S1")
    assert after[0] != before[0]  # a repetition relabelled: another fingerprint
    assert after[1] == before[1]  # the same files: what an older aceval hashed


def _calibrations(reps: list[str], flags: list[str]) -> pd.DataFrame:
    rows = []
    for label, flag in zip(reps, flags):
        rows.append(
            {"subject": "S1", "sensor_set": "frontal", "imu": "IMU4", "test": "T1",
             "repetitions": label, "n_reps": len(label.split("+")), "method": "kong",
             "flag": flag, **dict(zip(R_COLUMNS, np.eye(3).ravel()))}
        )  # fmt: skip
    return pd.DataFrame(rows)


def test_apply_takes_the_calibration_from_all_repetitions_or_says_why_not(mini):
    dataset = load_dataset(mini)
    table = _calibrations(["R1", "R2", "R1+R2"], ["", "", ""])
    chosen = chosen_calibrations(dataset, table)
    assert chosen[["repetitions", "calibration"]].values.tolist() == [["R1+R2", "all repetitions"]]
    flagged = _calibrations(["R1", "R2", "R1+R2"], ["", "", "unstable"])
    none = chosen_calibrations(dataset, flagged).iloc[0]
    assert none["calibration"] == "none"
    assert "flagged unstable" in none["why"] and "--allow-subset" in none["why"]
    subset = chosen_calibrations(dataset, flagged, allow_subset=True).iloc[0]
    assert (subset["calibration"], subset["repetitions"]) == ("subset", "R1")
    deleted = _calibrations(["R1", "R2"], ["", ""])  # the row from all repetitions deleted
    assert "not in the calibrations file" in chosen_calibrations(dataset, deleted).iloc[0]["why"]


def test_outputs_never_meet_a_recording_or_each_other(mini, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "data").mkdir(parents=True)
    for name in ("s1_t0.csv", "s1_t1_r1.csv", "s1_t1_r2.csv"):
        shutil.move(mini / name, elsewhere / "data" / name)
    (mini / "data").symlink_to(elsewhere / "data")
    sheet = (mini / "recordings.tsv").read_text().replace("\ts1_", "\tdata/s1_")
    (mini / "recordings.tsv").write_text(sheet)
    with pytest.raises(UnsafeOutputError, match="is the recording"):
        check_recordings({"--out": mini / "data" / "s1_t0.csv"}, mini)
    with pytest.raises(UnsafeOutputError, match="holds recordings"):
        check_recordings({"--out": elsewhere / "data" / "new.csv"}, mini)
    with pytest.raises(UnsafeOutputError, match="replacing it would delete them"):
        check_recordings({"--out": elsewhere}, mini, folders=("--out",))
    check_recordings({"--out": tmp_path / "fine.csv"}, mini)
    with pytest.raises(UnsafeOutputError, match="both name"):
        check_distinct({"--out": tmp_path / "x.csv", "--findings-out": tmp_path / "x.csv"})
    with pytest.raises(UnsafeOutputError, match="inside the folder output"):
        check_distinct({"--out": tmp_path / "copy", "--x": tmp_path / "copy" / "a"}, ("--out",))
    (tmp_path / "link").symlink_to(elsewhere)
    with pytest.raises(UnsafeOutputError, match="symbolic link"):
        check_folder_output(tmp_path / "link", force=True)


def test_a_full_disk_ends_a_command_with_one_line_and_nothing_left(
    mini, tmp_path, monkeypatch, capsys
):
    """ENOSPC while calibrate writes its outputs (monkeypatched: no small filesystem to fill
    here; the sweep fills a file size limit instead): exit 1, the output and the cause named in
    one line, no output and no temporary left."""
    import errno

    from aceval.cli import main

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    out = tmp_path / "out" / "calibrations.csv"
    assert main(["calibrate", str(mini), "--out", str(out)]) == 1
    said = capsys.readouterr().err.strip().splitlines()[-1]
    assert said.startswith("aceval calibrate: ") and "calibrations.csv: No space left" in said
    assert "Traceback" not in said and not list((tmp_path / "out").iterdir())
