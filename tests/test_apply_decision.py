"""`aceval apply --decision`: each IMU's chosen calibration applied, by its verdict; what is
refused (no trustworthy calibration, two answers for one IMU or unit, a second turn of a
body-frame copy) and the hints given (each one followed works); the copies' numbers: gravity at
rest along body z in the file's units, at the source's precision."""

import numpy as np
import pandas as pd
import pytest
import yaml
from scipy.spatial.transform import Rotation

from aceval.apply import recordings_fingerprint
from aceval.cli import main
from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import load_dataset

from .minidataset import write_csv
from .synthetic import pitch_motion

G = 9.81
#: the four IMUs (right thigh, right shank, ...) and their true sensor -> body rotations
MOUNTS = {
    name: Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
    for name, angles in {
        "IMU4": (10, -20, 35),
        "IMU5": (90, 0, -15),
        "IMU6": (-30, 60, 100),
        "IMU7": (175, 5, 0),
    }.items()
}
VERDICTS = {
    "IMU4": ("use", "use"),
    "IMU5": ("use with care", "use with care: right-axis sign not verified by the data"),
    "IMU6": ("not within tolerance", "not within tolerance: cone 31.0 deg > 20 deg"),
    "IMU7": ("no trustworthy calibration", "no trustworthy calibration: every one flagged"),
}


@pytest.fixture
def lab(tmp_path):
    """A dataset in g and deg/s (a lab's units: apply writes them back) whose four IMUs are
    mounted as :data:`MOUNTS`: quiet standing (gravity along body z) and a pitching motion."""
    root = tmp_path / "lab"
    root.mkdir()
    meta = {"name": "lab", "sampling_rate_hz": 100, "units": {"acc": "g", "gyr": "deg/s"},
            "sensor_sets": ["frontal"], "acc_range_g": {"lower_body": 8}}  # fmt: skip
    (root / "dataset.yaml").write_text(yaml.safe_dump(meta))
    sides = {"IMU4": "right", "IMU5": "right", "IMU6": "left", "IMU7": "left"}
    segments = {"IMU4": "thigh", "IMU5": "shank", "IMU6": "thigh", "IMU7": "shank"}
    (root / "imus.tsv").write_text(
        "imu\tsegment\tside\tregion\tright_axis\n"
        + "".join(f"{i}\t{segments[i]}\t{sides[i]}\tlower_body\t+y\n" for i in MOUNTS)
    )
    (root / "tests.tsv").write_text(
        "test\tkind\trepetitions\tdescription\nT0\tstatic\t1\tstand\nT1\tmotion\t1\tbow\n"
    )
    (root / "calibrates.tsv").write_text("test\timu\n" + "".join(f"T1\t{i}\n" for i in MOUNTS))
    (root / "subjects.tsv").write_text("subject\theight_cm\nS1\t175\n")
    rows = ["subject\tsensor_set\ttest\trep\timu\tpath"]
    rng = np.random.default_rng(0)
    for imu, R in MOUNTS.items():
        at_rest = np.tile([0.0, 0.0, -1.0], (300, 1)) @ R + rng.normal(0, 0.002, (300, 3))
        write_csv(root / f"{imu}_t0.csv", at_rest, rng.normal(0, 0.2, (300, 3)))
        moving = pitch_motion(n=400, seed=1) / G @ R + rng.normal(0, 0.002, (400, 3))
        turning = np.column_stack(
            [0 * moving[:, 0], 40 * np.sin(np.linspace(0, 12, 400)), 0 * moving[:, 0]]
        )
        write_csv(root / f"{imu}_t1.csv", moving, turning @ R)
        rows += [
            f"S1\tfrontal\tT0\t1\t{imu}\t{imu}_t0.csv",
            f"S1\tfrontal\tT1\t1\t{imu}\t{imu}_t1.csv",
        ]
    (root / "recordings.tsv").write_text("\n".join(rows) + "\n")
    return root


def decision(path, rows=None, **changes) -> str:
    """A decision.csv (the interface of evaluation/decision.py) with the true rotations."""
    table = []
    for imu, (kind, verdict) in VERDICTS.items():
        table.append({"subject": "S1", "sensor_set": "frontal", "imu": imu, "segment": "thigh",
                      "side": "right", "method": "triad", "test": "T1", "repetitions": "R1",
                      "verdict_kind": kind, "verdict": verdict, "tolerance_deg": 20.0,
                      **dict(zip(R_COLUMNS, MOUNTS[imu].ravel()))} | changes.get(imu, {}))  # fmt: skip
    table = pd.DataFrame(table + (rows or []))
    table.to_csv(path, index=False)
    return str(path)


def run(capsys, *args):
    code = main(["apply", *map(str, args)])
    said = capsys.readouterr().err
    assert "Traceback" not in said
    return code, said


def body_frame(copy, imu, test="t0"):
    return pd.read_csv(copy / f"{imu}_{test}.csv")


def test_apply_takes_each_imus_decided_calibration_and_says_what_it_did(lab, tmp_path, capsys):
    copy = tmp_path / "copy"
    code, said = run(capsys, lab, "--decision", decision(tmp_path / "d.csv"), "--out", copy)
    assert code == 0, said
    assert "S1 frontal IMU4: triad (T1 R1): use" in said
    assert "S1 frontal IMU5: triad (T1 R1): use with care: right-axis sign" in said
    assert "warning: S1 frontal IMU6: applied, but the decision says not within tolerance" in said
    assert "S1 frontal IMU7: not applied: no trustworthy calibration: every one flagged; " in said
    assert "--include-untrusted applies the calibration it names anyway" in said
    assert "d.csv does not say which recordings its calibrations were made from" in said
    kept = pd.read_csv(copy / "recordings.tsv", sep="\t")
    assert sorted(kept["imu"].unique()) == ["IMU4", "IMU5", "IMU6"]
    applied = pd.read_csv(copy / "applied_calibrations.tsv", sep="\t", keep_default_na=False)
    assert applied.set_index("imu")["calibration"].to_dict() == {
        "IMU4": "use", "IMU5": "use with care", "IMU6": "not within tolerance", "IMU7": "none"
    }  # fmt: skip
    assert main(["validate", str(copy)]) == 0
    # the hint, followed, works and says so
    again = tmp_path / "again"
    code, said = run(
        capsys, lab, "--decision", tmp_path / "d.csv", "--out", again, "--include-untrusted"
    )
    assert code == 0 and "warning: S1 frontal IMU7: applied, but the decision says no trust" in said
    assert "IMU7" in set(pd.read_csv(again / "recordings.tsv", sep="\t")["imu"])


def test_a_static_recording_reads_gravity_along_body_z_in_the_files_units(lab, tmp_path, capsys):
    """R on the wrong side (R^T d) turns gravity away from z; the unit scale (9.81 m/s^2 per g)
    multiplied instead of divided reads about -96 instead of -1: both caught here, in g."""
    copy = tmp_path / "copy"
    assert run(capsys, lab, "--decision", decision(tmp_path / "d.csv"), "--out", copy)[0] == 0
    for imu in ("IMU4", "IMU5", "IMU6"):
        acc = body_frame(copy, imu)[["acc_x", "acc_y", "acc_z"]].to_numpy().mean(axis=0)
        np.testing.assert_allclose(acc, [0.0, 0.0, -1.0], atol=0.003)
        turning = body_frame(copy, imu, "t1")[["gyr_x", "gyr_y", "gyr_z"]].to_numpy()
        assert np.abs(turning[:, [0, 2]]).max() < 1e-3 and np.abs(turning[:, 1]).max() > 39


def test_the_copy_keeps_the_sources_precision_and_its_information(lab, tmp_path, capsys):
    """The source has 6 significant digits: the copy 7, not 17 (the copy was 1.7 times the
    dataset's size), and rounds below the source's own rounding."""
    copy = tmp_path / "copy"
    assert run(capsys, lab, "--decision", decision(tmp_path / "d.csv"), "--out", copy)[0] == 0
    source = pd.read_csv(lab / "IMU6_t1.csv", dtype=str)
    body = pd.read_csv(copy / "IMU6_t1.csv", dtype=str)
    digits = body[["acc_x", "gyr_z"]].stack().str.replace(r"[eE].*|[^0-9]", "", regex=True)
    assert digits.str.lstrip("0").str.len().max() == 7
    assert (body["t"] == source["t"]).all()
    exact = source[["acc_x", "acc_y", "acc_z"]].astype(float).to_numpy() @ MOUNTS["IMU6"].T
    written = body[["acc_x", "acc_y", "acc_z"]].astype(float).to_numpy()
    largest = np.abs(source[["acc_x", "acc_y", "acc_z"]].astype(float).to_numpy()).max(axis=1)
    assert (np.abs(written - exact).max(axis=1) <= 0.5e-5 * largest * 1.0001).all()
    size = sum(p.stat().st_size for p in copy.glob("*.csv"))
    original = sum(p.stat().st_size for p in lab.glob("IMU[456]_*.csv"))
    assert size < 1.2 * original


def test_two_answers_for_one_imu_or_one_unit_are_refused_by_line(lab, tmp_path, capsys):
    """A decision or a calibrations file holding a second, corrected row (30 deg apart) was
    applied by its first row without a word."""
    corrected = Rotation.from_euler("z", 30, degrees=True).as_matrix() @ MOUNTS["IMU4"]
    second = {"subject": "S1", "sensor_set": "frontal", "imu": "IMU4", "method": "triad",
              "test": "T1", "repetitions": "R1", "verdict_kind": "use", "verdict": "use",
              **dict(zip(R_COLUMNS, corrected.ravel()))}  # fmt: skip
    code, said = run(
        capsys, lab, "--decision", decision(tmp_path / "d.csv", [second]), "--out", tmp_path / "c"
    )
    assert code == 1 and not (tmp_path / "c").exists()
    assert (
        "d.csv lines 2 and 6: two different calibrations for S1 frontal IMU4 30.0 deg apart" in said
    )
    same = second | dict(zip(R_COLUMNS, MOUNTS["IMU4"].ravel()))  # the same row twice: harmless
    assert (
        run(
            capsys,
            lab,
            "--decision",
            decision(tmp_path / "d2.csv", [same]),
            "--out",
            tmp_path / "c",
        )[0]
        == 0
    )
    calibrations = pd.DataFrame(
        [{"subject": "S1", "sensor_set": "frontal", "imu": "IMU4", "test": "T1", "repetitions": "R1",
          "n_reps": 1, "method": "kong", "flag": "", **dict(zip(R_COLUMNS, R.ravel()))}
         for R in (MOUNTS["IMU4"], corrected)]
    )  # fmt: skip
    calibrations.to_csv(tmp_path / "cal.csv", index=False)
    code, said = run(capsys, lab, "--calibrations", tmp_path / "cal.csv", "--out", tmp_path / "k")
    assert code == 1 and not (tmp_path / "k").exists()
    assert (
        "cal.csv lines 2 and 3: two different calibrations for S1 frontal IMU4 T1 kong R1" in said
    )


def test_a_decision_made_from_other_recordings_is_refused(lab, tmp_path, capsys):
    """A decision names its recordings (recordings_sha1): the lab's own applies without the
    'not checked' warning; another dataset's decision (or one made before a file changed),
    whose IMU names match, is refused by name."""
    own = recordings_fingerprint(load_dataset(lab), "S1")
    table = pd.read_csv(decision(tmp_path / "d.csv"))
    table.assign(recordings_sha1=own).to_csv(tmp_path / "own.csv", index=False)
    code, said = run(capsys, lab, "--decision", tmp_path / "own.csv", "--out", tmp_path / "a")
    assert code == 0 and "not checked" not in said, said
    table.assign(recordings_sha1="0" * 40).to_csv(tmp_path / "other.csv", index=False)
    code, said = run(capsys, lab, "--decision", tmp_path / "other.csv", "--out", tmp_path / "b")
    assert code == 1 and not (tmp_path / "b").exists()
    assert "the calibrations of subject S1 were made from other recordings" in said


def test_a_body_frame_copy_is_not_turned_a_second_time(lab, tmp_path, capsys):
    """Onto a copy apply wrote, with --other-dataset, the recordings were turned a second time
    without a word (the copy has applied_calibrations.tsv)."""
    copy = tmp_path / "copy"
    assert run(capsys, lab, "--decision", decision(tmp_path / "d.csv"), "--out", copy)[0] == 0

    def calibrations(path, R, fingerprint=None):
        rows = [{"subject": "S1", "sensor_set": "frontal", "imu": imu, "test": "T1",
                 "repetitions": "R1", "n_reps": 1, "method": "kong", "flag": "",
                 **dict(zip(R_COLUMNS, R(imu).ravel()))} for imu in ("IMU4", "IMU5", "IMU6")]  # fmt: skip
        table = pd.DataFrame(rows)
        if fingerprint:
            table["recordings_sha1"] = fingerprint
        table.to_csv(path, index=False)
        return path

    original = calibrations(tmp_path / "cal.csv", MOUNTS.get)
    for source in (
        ["--calibrations", original, "--other-dataset"],
        ["--decision", tmp_path / "d.csv"],
    ):
        code, said = run(capsys, copy, *source, "--out", tmp_path / "twice")
        assert code == 1 and not (tmp_path / "twice").exists()
        assert "is a body-frame copy written by aceval apply" in said
        assert "--other-dataset" not in said  # no hint that would fail
    code, said = run(capsys, copy, "--calibrations", original, "--out", tmp_path / "twice")
    assert code == 1 and "is a body-frame copy" in said and "--other-dataset" not in said
    own = calibrations(  # calibrations made from the copy itself: applied
        tmp_path / "own.csv",
        lambda imu: np.eye(3),
        recordings_fingerprint(load_dataset(copy), "S1"),
    )
    assert run(capsys, copy, "--calibrations", own, "--out", tmp_path / "twice")[0] == 0


def test_the_subset_hint_is_offered_only_where_following_it_works(lab, tmp_path, capsys):
    """A calibrations file of `--subsets full` with a flagged calibration: 'an unflagged subset
    (nan of nan) is there: --allow-subset' was offered, and failed on NaN matrices."""
    rows = [{"subject": "S1", "sensor_set": "frontal", "imu": imu, "test": "T1", "repetitions": "R1",
             "n_reps": 1, "method": "kong", "flag": "heading_undetermined" if imu == "IMU5" else "",
             **dict(zip(R_COLUMNS, MOUNTS[imu].ravel()))} for imu in MOUNTS]  # fmt: skip
    pd.DataFrame(rows).to_csv(tmp_path / "full.csv", index=False)
    code, said = run(capsys, lab, "--calibrations", tmp_path / "full.csv", "--out", tmp_path / "a")
    assert code == 0
    assert (
        "IMU5: not applied: T1: its calibration from all 1 repetitions is flagged heading_undet"
        in said
    )
    assert "nan" not in said and "--allow-subset" not in said
    code, said = run(
        capsys,
        lab,
        "--calibrations",
        tmp_path / "full.csv",
        "--out",
        tmp_path / "b",
        "--allow-subset",
    )
    assert code == 0 and "IMU5: not applied" in said


def test_options_of_the_other_source_and_a_foreign_decision_are_refused(lab, tmp_path, capsys):
    path = decision(tmp_path / "d.csv")
    code, said = run(capsys, lab, "--decision", path, "--out", tmp_path / "c", "--method", "kong")
    assert code == 1 and "--method is an option of --calibrations only" in said
    other = decision(tmp_path / "o.csv", **{i: {"subject": "S9"} for i in MOUNTS})
    code, said = run(capsys, lab, "--decision", other, "--out", tmp_path / "c")
    assert code == 1 and "decides none of the IMUs of" in said
    code, said = run(
        capsys,
        lab,
        "--decision",
        decision(tmp_path / "k.csv", IMU4={"verdict_kind": "fine"}),
        "--out",
        tmp_path / "c",
    )
    assert (
        code == 1 and "k.csv line 2: verdict_kind 'fine' is not one of use, use with care" in said
    )


def calibrations_file(path, rows) -> str:
    """A calibrations.csv of `aceval calibrate` (kong's rows): (imu, test, repetitions, flag, R)."""
    table = [
        {
            "subject": "S1",
            "sensor_set": "frontal",
            "imu": imu,
            "segment": "thigh",
            "side": "right",
            "test": test,
            "repetitions": reps,
            "n_reps": reps.count("+") + 1,
            "method": "kong",
            "flag": flag,
            **dict(zip(R_COLUMNS, R.ravel())),
        }
        for imu, test, reps, flag, R in rows
    ]
    pd.DataFrame(table).to_csv(path, index=False)
    return str(path)


def test_the_calibrations_choice_keeps_to_the_test_asked_and_the_largest_subset(
    lab, tmp_path, capsys
):
    """IMU4's calibration from all repetitions of T1 is flagged: --allow-subset applies its largest
    unflagged subset (R1+R2, the true mounting), not the smallest (R1, turned 30 deg); IMU5's
    --test T1 is T1's (true), not T9's (turned)."""
    turned = Rotation.from_euler("z", 30, degrees=True).as_matrix()
    rows = [
        ("IMU4", "T1", "R1+R2+R3", "not_planar", MOUNTS["IMU4"]),
        ("IMU4", "T1", "R1", "", turned @ MOUNTS["IMU4"]),
        ("IMU4", "T1", "R1+R2", "", MOUNTS["IMU4"]),
        ("IMU5", "T9", "R1+R2+R3", "", turned @ MOUNTS["IMU5"]),
        ("IMU5", "T1", "R1+R2+R3", "", MOUNTS["IMU5"]),
    ]
    path = calibrations_file(tmp_path / "c.csv", rows)
    copy = tmp_path / "copy"
    options = ["--calibrations", path, "--test", "T1", "--allow-subset", "--out", copy]
    code, said = run(capsys, lab, *options)
    assert code == 0, said
    applied = pd.read_csv(copy / "applied_calibrations.tsv", sep="\t").set_index("imu")
    assert applied.loc["IMU4", "repetitions"] == "R1+R2" and applied.loc["IMU5", "test"] == "T1"
    for imu in ("IMU4", "IMU5"):
        acc = body_frame(copy, imu)[["acc_x", "acc_y", "acc_z"]].to_numpy().mean(axis=0)
        np.testing.assert_allclose(acc, [0.0, 0.0, -1.0], atol=0.003)


def test_an_imu_the_decision_does_not_name_is_not_applied_and_says_why(lab, tmp_path, capsys):
    named = decision(tmp_path / "d.csv")
    table = pd.read_csv(named)
    table[table["imu"] != "IMU5"].to_csv(named, index=False)
    copy = tmp_path / "copy"
    assert run(capsys, lab, "--decision", named, "--out", copy)[0] == 0
    applied = pd.read_csv(copy / "applied_calibrations.tsv", sep="\t").set_index("imu")
    assert applied.loc["IMU5", "calibration"] == "none"
    assert applied.loc["IMU5", "why"] == f"not in {named}"
