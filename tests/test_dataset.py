
import numpy as np
import pytest

from aceval.cli import main
from aceval.dataset import DatasetError, load_dataset, validate
from aceval.pipeline import calibrate, summarise_recordings

from .minidataset import make_dataset, write_csv


@pytest.fixture
def mini(tmp_path):
    return make_dataset(tmp_path / "mini")


def errors_of(root):
    _, report = validate(root)
    return [str(f) for f in report.errors], [str(f) for f in report.warnings]


def test_valid_dataset_reads_in_SI(mini):
    errors, warnings = errors_of(mini)
    assert errors == [] and warnings == []
    dataset = load_dataset(mini)
    recording = dataset.read_recording("s1_t0.csv")
    np.testing.assert_allclose(recording.acc[0], [0, 0, -9.81])  # 1 g -> m/s^2
    recording = dataset.read_recording("s1_t1_r1.csv")
    assert np.abs(recording.gyr).max() == pytest.approx(np.radians(40), rel=1e-3)  # deg/s -> rad/s
    assert dataset.right_axis("frontal", "IMU4") == "+y"


def test_raw_files_are_not_modified(mini):
    before = {p: p.read_bytes() for p in mini.iterdir()}
    validate(mini)
    calibrate(load_dataset(mini), summarise_recordings(load_dataset(mini)))
    assert {p: p.read_bytes() for p in mini.iterdir()} == before


def edit(path, old, new):
    path.write_text(path.read_text().replace(old, new))


@pytest.mark.parametrize("breakage, where, cause", [
    (lambda r: (r / "s1_t1_r2.csv").unlink(), "s1_t1_r2.csv", "file is missing"),
    (lambda r: (r / "s1_t1_r2.csv").write_bytes(b"\x00\xff\xfe garbage"), "s1_t1_r2.csv", "cannot be read as CSV"),
    (lambda r: (r / "s1_t1_r2.csv").write_text("t,acc_x,acc_y\n0,1,2\n"), "s1_t1_r2.csv", "missing column(s) acc_z"),
    (lambda r: edit(r / "s1_t1_r1.csv", "gyr_z", "gyro_z"), "s1_t1_r1.csv", "missing column(s) gyr_z"),
    (lambda r: edit(r / "recordings.tsv", "\tpath", "\tfile"), "recordings.tsv", "missing column(s) path"),
    (lambda r: edit(r / "s1_t1_r1.csv", "\n0.05,", "\nnan,"), "s1_t1_r1.csv", "NaN, inf or non-numeric"),
    (lambda r: edit(r / "s1_t1_r1.csv", "\n0.05,", "\n0.04,"), "s1_t1_r1.csv", "duplicate time at line 7"),
    (lambda r: edit(r / "s1_t1_r1.csv", "\n0.05,", "\n0.01,"), "s1_t1_r1.csv", "decreasing time at line 7"),
    (lambda r: edit(r / "dataset.yaml", "sampling_rate_hz: 100", "sampling_rate_hz: 50"), "s1_t0.csv",
     "sampling rate in t is 100 Hz, dataset.yaml declares 50 Hz"),
    (lambda r: edit(r / "recordings.tsv", "S1\tfrontal\tT1\t2\tIMU9", "x"), None, None),
    (lambda r: edit(r / "recordings.tsv", "T1\t2\tIMU4", "T1\t2\tIMU9"), "recordings.tsv line 4",
     "imu 'IMU9' is not defined in imus.tsv"),
    (lambda r: edit(r / "recordings.tsv", "S1\tfrontal\tT1\t2", "S2\tfrontal\tT1\t2"), "recordings.tsv line 4",
     "subject 'S2' is not defined in subjects.tsv"),
    (lambda r: edit(r / "recordings.tsv", "T1\t2\tIMU4", "T7\t2\tIMU4"), "recordings.tsv line 4",
     "test 'T7' is not defined in tests.tsv"),
    (lambda r: edit(r / "recordings.tsv", "T1\t2\tIMU4\ts1_t1_r2.csv", "T1\t1\tIMU4\ts1_t1_r2.csv"),
     "recordings.tsv line 4", "duplicate recording S1 frontal T1 1 IMU4"),
    (lambda r: edit(r / "recordings.tsv", "S1\tfrontal\tT0\t1\tIMU4\ts1_t0.csv\n", ""), "calibrates.tsv",
     "no static test (T0) recording"),
    (lambda r: edit(r / "dataset.yaml", "acc: g", "acc: m/s^2"), "s1_t0.csv", "acceleration at rest is 0.102 g"),
    (lambda r: edit(r / "imus.tsv", "\t+y", "\tright"), "imus.tsv line 2", "right_axis 'right' is not one of"),
    (lambda r: edit(r / "tests.tsv", "T1\tmotion", "T1\tmoving"), "tests.tsv line 3", "kind 'moving'"),
    (lambda r: edit(r / "calibrates.tsv", "T1\tIMU4", "T1\tIMU5"), "calibrates.tsv line 2", "IMU 'IMU5' is not defined"),
    (lambda r: edit(r / "dataset.yaml", "acc: g", "acc: mg"), "dataset.yaml", "units.acc must be one of"),
    (lambda r: (r / "imus.tsv").unlink(), "imus.tsv", "sheet is missing"),
    (lambda r: edit(r / "tests.tsv", "T1\tmotion\t2\tbow\n", "T1\tmotion\t2\tbow\nT1\tmotion\t3\tbow again\n"),
     "tests.tsv line 4", "test 'T1' is defined twice"),
    (lambda r: edit(r / "subjects.tsv", "S1\t175\n", "S1\t175\nS1\t180\n"), "subjects.tsv line 3",
     "subject 'S1' is defined twice"),
])
def test_each_error_names_where_and_cause(mini, breakage, where, cause):
    breakage(mini)
    errors, _ = errors_of(mini)
    if where is None:  # a no-op edit: still valid
        assert errors == []
        return
    assert any(where in e and cause in e for e in errors), errors


def test_warnings_for_saturation_and_short_recordings(mini):
    acc = np.tile([0.0, 0.0, -1.0], (50, 1))
    acc[10:13, 0] = 8.0  # at the +-8 g range
    write_csv(mini / "s1_t1_r2.csv", acc, np.zeros((50, 3)))
    errors, warnings = errors_of(mini)
    assert errors == []
    assert any("s1_t1_r2.csv" in w and "3 samples at the accelerometer range +-8 g" in w for w in warnings)
    assert any("s1_t1_r2.csv" in w and "very short recording: 0.49 s" in w for w in warnings)


def test_load_dataset_raises_with_report(mini):
    edit(mini / "imus.tsv", "\t+y", "\tup")
    with pytest.raises(DatasetError, match="right_axis 'up'"):
        load_dataset(mini)


def test_ground_truth_must_be_rotations(mini):
    (mini / "ground_truth.tsv").write_text(
        "subject\tsensor_set\timu\tr11\tr12\tr13\tr21\tr22\tr23\tr31\tr32\tr33\n"
        "S1\tfrontal\tIMU4\t1\t0\t0\t0\t1\t0\t0\t0\t-1\n")
    errors, _ = errors_of(mini)
    assert any("ground_truth.tsv line 2" in e and "not a rotation matrix" in e for e in errors)


def test_validate_cli_exit_codes(mini, capsys, tmp_path):
    report = tmp_path / "validation.txt"
    assert main(["validate", str(mini), "--out", str(report)]) == 0
    assert report.read_text().startswith("dataset mini: 0 error(s)")
    report.unlink()
    edit(mini / "imus.tsv", "\t+y", "\tup")
    assert main(["validate", str(mini), "--out", str(report)]) == 1
    assert "right_axis 'up'" in capsys.readouterr().err  # errors go to stderr
    assert not report.exists()  # no report file for an invalid dataset: the workflow stops


def test_static_motion_is_flagged_not_calibrated(mini):
    write_csv(mini / "s1_t1_r2.csv", np.tile([0.0, 0.0, -1.0], (300, 1)), np.zeros((300, 3)))
    dataset = load_dataset(mini)
    summaries = summarise_recordings(dataset)
    flagged = summaries[summaries["flag"] != ""]
    assert list(flagged["flag"]) == ["no_movement"]
    assert "s1_t1_r2.csv" in flagged["message"].iloc[0]
    calibrations, _ = calibrate(dataset, summaries)
    assert set(calibrations["repetitions"]) == {"R1"}  # the static 'motion' drops out
