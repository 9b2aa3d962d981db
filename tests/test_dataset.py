import numpy as np
import pytest

from aceval.calibrate.pipeline import calibrate
from aceval.cli import main
from aceval.data.contract import R_COLUMNS, DatasetError
from aceval.data.dataset import load_dataset, validate
from aceval.data.names import read_as_missing
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


def _as_parquet(csv_path, columns=None, types=None):
    """The recording at ``csv_path`` rewritten as Parquet beside it (``columns``: which to keep;
    ``types``: column -> pyarrow type); returns the new file's name."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pd.read_csv(csv_path)
    table = table[columns] if columns else table
    schema = pa.schema([(c, (types or {}).get(c, pa.float64())) for c in table.columns])
    out = csv_path.with_suffix(".parquet")
    values = {c: table[c] for c in table.columns}
    for c, kind in (types or {}).items():  # as text, its first cell no number
        if kind == pa.string():
            values[c] = ["n/a", *table[c].astype(str)[1:]]
    pq.write_table(pa.table(values, schema=schema), out)
    csv_path.unlink()
    return out.name


def test_a_recording_may_be_gzipped_csv_or_parquet_and_reads_the_same(mini):
    import gzip

    before = load_dataset(mini).read_recording("s1_t1_r1.csv")
    as_csv, _ = calibrate(load_dataset(mini), summarise_recordings(load_dataset(mini)))
    gz = mini / "s1_t1_r1.csv.gz"
    gz.write_bytes(gzip.compress((mini / "s1_t1_r1.csv").read_bytes()))
    parquet = _as_parquet(mini / "s1_t1_r1.csv")
    edit(mini / "recordings.tsv", "s1_t1_r1.csv", parquet)
    edit(mini / "recordings.tsv", "s1_t1_r2.csv", "s1_t1_r1.csv.gz")
    assert errors_of(mini) == ([], [])
    dataset = load_dataset(mini)
    for name in (parquet, "s1_t1_r1.csv.gz"):
        recording = dataset.read_recording(name)
        np.testing.assert_array_equal(recording.gyr, before.gyr)
    calibrations, _ = calibrate(dataset, summarise_recordings(dataset))
    # the same numbers (s1_t1_r2 now reads s1_t1_r1's gzipped copy: the subsets with R2 moved)
    same = calibrations["repetitions"] == "R1"
    np.testing.assert_array_equal(calibrations[same][R_COLUMNS], as_csv[same][R_COLUMNS])


def test_a_parquet_recording_without_a_column_or_with_text_is_an_error_naming_it(mini):
    import pyarrow as pa

    missing = _as_parquet(mini / "s1_t1_r1.csv", columns=["t", "acc_x", "acc_y", "acc_z"])
    text = _as_parquet(mini / "s1_t1_r2.csv", types={"gyr_y": pa.string()})
    edit(mini / "recordings.tsv", "s1_t1_r1.csv", missing)
    edit(mini / "recordings.tsv", "s1_t1_r2.csv", text)
    (mini / "s1_t0.parquet").write_bytes(b"PAR1 not a parquet file")
    edit(mini / "recordings.tsv", "s1_t0.csv", "s1_t0.parquet")
    errors, _ = errors_of(mini)
    assert any(missing in e and "missing column(s) gyr_x, gyr_y, gyr_z" in e for e in errors)
    assert any(text in e and "non-numeric values (first at row 1)" in e for e in errors), errors
    assert any("s1_t0.parquet" in e and "cannot be read as Parquet" in e for e in errors), errors


def test_warnings_of_one_kind_are_one_line_on_screen_and_each_in_the_findings(
    mini, tmp_path, capsys
):
    """48 recordings 'not at rest' flood no screen: one line per kind of warning, with the count,
    the range of its numbers and three places; every one of them in the findings file."""
    from aceval.data.contract import ValidationReport

    report = ValidationReport("lab")
    for k, g in enumerate([1.25, 1.31, 1.29, 1.27]):
        report.warning(
            f"data/walk_R{k}.csv", f"static recording with median |acc| {g} g: not at rest"
        )
    report.warning("dataset.yaml", "unknown key 'x' is ignored")
    report.error("imus.tsv line 3", "right_axis 'up'")
    screen = report.grouped(None, "lab").splitlines()
    assert screen == [
        "dataset lab: 1 error(s), 5 warning(s)",
        "ERROR   imus.tsv line 3: right_axis 'up'",
        "WARNING 4 x: static recording with median |acc| 1.25-1.31 g: not at rest (at "
        "data/walk_R0.csv; data/walk_R1.csv; data/walk_R2.csv; and 1 more)",
        "WARNING dataset.yaml: unknown key 'x' is ignored",
        "(every warning: aceval validate lab --findings-out FILE)",
    ]
    assert len(report.format().splitlines()) == 7  # the file keeps every finding
    assert report.grouped(None, "lab") != report.format()
    single = ValidationReport("lab")
    single.warning("dataset.yaml", "unknown key 'x' is ignored")
    assert single.grouped(None, "lab") == single.format()  # nothing grouped, nothing added


def test_verticals_name_a_motion_repetition_and_a_static_recording(mini):
    """verticals.tsv (a vertical per motion repetition): a good row is read; each bad one is an
    error naming its line and cause, never a traceback."""
    (mini / "verticals.tsv").write_text(
        "subject\ttest\trep\tstatic_test\tstatic_rep\n"
        "S1\tT1\t1\tT0\t1\n"
        "S1\tT0\t1\tT0\t1\n"  # a static test as the motion one
        "S1\tT1\t2\tT1\t1\n"  # a motion test as the static one
        "S1\tT1\tx\tT0\t1\n"
        "S1\tT1\t2\tT0\t3\n"  # no such static recording
        "S1\tT1\t1\tT0\t1\n"  # twice
    )
    _, report = validate(mini, check_files=False)
    errors = [str(e) for e in report.errors]
    assert errors == [
        "ERROR   verticals.tsv line 3: test 'T0' is not a motion test of tests.tsv",
        "ERROR   verticals.tsv line 4: static_test 'T1' is not a static test of tests.tsv",
        "ERROR   verticals.tsv line 5: rep 'x' is not a whole number from 1",
        "ERROR   verticals.tsv line 6: recordings.tsv has no T0 R3 of subject 'S1'",
        "ERROR   verticals.tsv line 7: this motion repetition is listed twice",
    ]
    (mini / "verticals.tsv").write_text(
        "subject\ttest\trep\tstatic_test\tstatic_rep\nS1\tT1\t2\tT0\t1\n"
    )
    assert load_dataset(mini).verticals.values.tolist() == [["S1", "T1", 2, "T0", 1]]
