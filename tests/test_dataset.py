import numpy as np
import pytest

from aceval.calibrate.pipeline import calibrate
from aceval.cli import main
from aceval.data.contract import DatasetError
from aceval.data.dataset import load_dataset, read_as_missing, validate
from aceval.signals.reduction import summarise_recordings

from .minidataset import make_dataset, write_csv


@pytest.fixture
def mini(tmp_path):
    return make_dataset(tmp_path / "mini")


def errors_of(root):
    _, report = validate(root)
    return [str(f) for f in report.errors], [str(f) for f in report.warnings]


def test_read_as_missing_names_what_pandas_reads_back_as_nan():
    names = ["S1", "NA", "n/a", "null", "nan", "None", "", "NaN_1", "N.A.", "na", 'a,"b"', " "]
    assert read_as_missing(names) == {"NA", "n/a", "null", "nan", "None", ""}


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


def test_warnings_for_saturation_and_short_recordings(mini):
    acc = np.tile([0.0, 0.0, -1.0], (50, 1))
    acc[10:13, 0] = 8.0  # at the +-8 g range
    write_csv(mini / "s1_t1_r2.csv", acc, np.zeros((50, 3)))
    errors, warnings = errors_of(mini)
    assert errors == []
    assert any(
        "s1_t1_r2.csv" in w and "3 samples at the accelerometer range +-8 g" in w for w in warnings
    )
    assert any("s1_t1_r2.csv" in w and "very short recording: 0.49 s" in w for w in warnings)


def test_load_dataset_raises_with_report(mini):
    edit(mini / "imus.tsv", "\t+y", "\tup")
    with pytest.raises(DatasetError, match="right_axis 'up'"):
        load_dataset(mini)


def test_ground_truth_must_be_rotations(mini):
    (mini / "ground_truth.tsv").write_text(
        "subject\tsensor_set\timu\tr11\tr12\tr13\tr21\tr22\tr23\tr31\tr32\tr33\n"
        "S1\tfrontal\tIMU4\t1\t0\t0\t0\t1\t0\t0\t0\t-1\n"
    )
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
