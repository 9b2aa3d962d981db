"""Each importer's unit conversion on a few synthetic lines written here (no ../shared/data
needed), and a missing required column of every sheet refused by name, in the quick tier
(issue 44: before, both were tested only on the real recordings or in the slow sweep)."""

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from aceval.data.contract import GRAVITY, OPTIONAL_SHEETS, SHEETS, DatasetError
from aceval.data.dataset import load_dataset, read_sheets
from aceval.importers import FormatError, gaitmap, hugadb, qmt, vicon, xsens

from .minidataset import make_dataset

# --- HuGaDB: int16 counts at +-2 g and +-2000 deg/s ---------------------------------------------

#: a left shank sensor mounted with its axes permuted (sensor -> body; not its own transpose)
MOUNT_LEFT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

HUGADB_SENSORS = ["rf", "rs", "rt", "lf", "ls", "lt"]


def hugadb_file(path: Path, rows: list[list[int]]) -> Path:
    """A HuGaDB v1 file: three header lines, the 39 column names, then tab-separated counts."""
    names = [f"{kind}_{s}_{a}" for s in HUGADB_SENSORS for kind in ("acc", "gyro") for a in "xyz"]
    lines = ["#Activity\twalking ", "#ActivityID\t1 ", "#Date 08-22-18-24"]
    lines.append("\t".join([*names, "EMG_r", "EMG_l", "act"]))
    lines += ["\t".join(map(str, row)) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_hugadb_counts_become_m_per_s2_and_rad_per_s(tmp_path):
    """16384 counts are 1 g (MPU-6050 at +-2 g) and 16.4 counts 1 deg/s (at +-2000 deg/s)."""
    sensor = [16384, -8192, 0, 164, -1640, 0]  # 1 g, -0.5 g, 0; 10, -100, 0 deg/s
    row = sensor * 6 + [120, 122, 8]
    other = [0, 0, 16384, 0, 0, 32767] * 6 + [0, 0, 8]
    data = hugadb.read_hugadb(hugadb_file(tmp_path / "HuGaDB_v1_walking_01_00.txt", [row, other]))
    assert data.date == "08-22-18-24" and data.activity.tolist() == [8, 8]
    for code in hugadb.SENSORS:
        np.testing.assert_allclose(data.acc(code)[0], [GRAVITY, -0.5 * GRAVITY, 0.0])
        np.testing.assert_allclose(data.gyr(code)[0], np.radians([10.0, -100.0, 0.0]))
        np.testing.assert_allclose(data.gyr(code)[1, 2], np.radians(32767 / 16.4))
    assert GRAVITY == 9.81


def test_hugadb_reads_each_sensor_from_its_own_columns(tmp_path):
    """Sensor k's counts are 1000 k + axis: the right foot, shank, thigh, then the left."""
    row = [1000 * k + j for k in range(6) for j in range(6)] + [0, 0, 1]
    data = hugadb.read_hugadb(hugadb_file(tmp_path / "HuGaDB_v1_walking_01_00.txt", [row]))
    for k, code in enumerate(["RF", "RS", "RT", "LF", "LS", "LT"]):
        acc, gyr = data.counts[code]
        assert acc[0].tolist() == [1000 * k, 1000 * k + 1, 1000 * k + 2]
        assert gyr[0].tolist() == [1000 * k + 3, 1000 * k + 4, 1000 * k + 5]


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda rows: [r[:-1] for r in rows], "line 5: 2 row.s. with missing or non-numeric"),
        (lambda rows: [rows[0], [*rows[1], 7]], "line 6: 40 fields, expected 39"),
        (lambda rows: [[*r[:3], 1.5, *r[4:]] for r in rows], "int16 counts"),
        (lambda rows: [[*r[:3], 40000, *r[4:]] for r in rows], "int16 counts"),
        (lambda rows: [], "no samples"),
    ],
)
def test_hugadb_refuses_bad_lines_naming_the_file(tmp_path, edit, message):
    rows = [[0] * 38 + [1], [0] * 38 + [1]]
    path = hugadb_file(tmp_path / "HuGaDB_v1_walking_01_00.txt", edit(rows))
    with pytest.raises(FormatError, match=rf"{path.name}.*{message}"):
        hugadb.read_hugadb(path)


# --- Xsens MT Manager exports: already SI, passed through unchanged ------------------------------


def test_xsens_export_values_pass_through_in_si(tmp_path):
    header = (
        "// Update Rate: 100.0Hz\nPacketCounter,SampleTimeFine,Acc_X,Acc_Y,Acc_Z,Gyr_X,Gyr_Y,Gyr_Z"
    )
    lines = ["1,,9.652746,1.5,-1.25,0.013810,-0.5,2.0", "2,,0.0,0.0,-9.81,0.0,0.0,0.0"]
    path = tmp_path / "S01-000_00B40C47.txt"
    path.write_text(header + "\n" + "\n".join(lines) + "\n")
    fields, values = xsens.read_mt_export(path)
    assert xsens.export_rate(fields, values, path) == 100.0
    assert values[["Acc_X", "Acc_Y", "Acc_Z"]].to_numpy().tolist() == [
        [9.652746, 1.5, -1.25],
        [0.0, 0.0, -9.81],
    ]
    assert values[["Gyr_X", "Gyr_Y", "Gyr_Z"]].to_numpy()[0].tolist() == [0.013810, -0.5, 2.0]
    assert values["PacketCounter"].tolist() == [1, 2]
    path.write_text(header.replace("Gyr_Z", "Mag_Z") + "\n" + "\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=f"{path.name}: line 2.*missing column.*Gyr_Z"):
        xsens.read_mt_export(path)


#: one trial's sensors: (sheet row, mounting sensor -> body): a mounting with no symmetry, so that
#: a value read from another axis, sensor or unit shows
XSENS_SHEET = {
    "00B4A301": ("RS\tmain\tshank\tright\tlower_body\t+y", np.eye(3)),
    "00B4A302": ("LS\tmain\tshank\tleft\tlower_body\t+y", MOUNT_LEFT),
    "00B4A303": ("LB\tmain\twaist\tcenter\tupper_body\t+y", np.eye(3)),
}


@pytest.mark.parametrize("regions", [("lower_body", "upper_body"), ("lower_body",)])
def test_one_xsens_trial_imports_the_exported_values_and_the_sheet_as_written(tmp_path, regions):
    """`aceval import xsens` of one trial (standing, then walking) end to end: every recording is
    a run of the export's own samples, unchanged (SI: m/s^2 and rad/s, not converted again),
    under the IMU, side and region its sensor sheet gives; dataset.yaml declares the ranges of
    the regions the sheet has (legs only: an upper_body range made its own output unreadable)."""
    from .labexports import export
    from .runner import aceval
    from .test_xsens_lab import signals

    exports = tmp_path / "exports"
    exports.mkdir()
    source = {}
    worn = {s: v for s, v in XSENS_SHEET.items() if v[0].split("\t")[4] in regions}
    for k, (sensor_id, (_, mount)) in enumerate(worn.items()):
        acc, gyr = signals(4.0, 6.0, mount=mount, seed=k)
        export(exports / f"S02-000_{sensor_id}.txt", sensor_id, 100, acc, gyr, "comma")
        source[sensor_id] = np.column_stack([acc, gyr]).round(6)  # as exported, 6 decimals
    sheet = "sensor_id\timu\tsensor_set\tsegment\tside\tregion\tright_axis\n"
    sheet += "".join(f"{s}\t{row}\n" for s, (row, _) in worn.items())
    (tmp_path / "sensors.tsv").write_text(sheet)
    args = ["--sensors", tmp_path / "sensors.tsv", "--subject", "S02", "--out", tmp_path / "out"]
    result = aceval("import", "xsens", exports, *args)
    assert result.code == 0, result.err
    dataset = load_dataset(tmp_path / "out", check_files=True)
    imus = pd.read_csv(tmp_path / "out" / "imus.tsv", sep="\t", dtype=str).set_index("imu")
    assert sorted(dataset.meta["acc_range_g"]) == sorted(regions)
    for sensor_id, (row, _) in worn.items():
        imu, sensor_set, segment, side, region, axis = row.split("\t")
        columns = ["sensor_set", "segment", "side", "region", "right_axis"]
        assert imus.loc[imu, columns].tolist() == [sensor_set, segment, side, region, axis]
        recordings = dataset.recordings[dataset.recordings["imu"] == imu]
        assert set(recordings["test"]) == {"T0", "T6"}
        for path in recordings["path"]:
            data = dataset.read_recording(path)
            values = np.column_stack([data.acc, data.gyr])
            at = int(np.argmin(np.abs(source[sensor_id] - values[0]).max(axis=1)))
            written = source[sensor_id][at : at + len(values)]  # the dataset keeps 6 digits
            np.testing.assert_allclose(values, written, rtol=1e-5, atol=1e-6, err_msg=path)
    assert dataset.meta["units"] == {"acc": "m/s^2", "gyr": "rad/s"}


# --- qmt's .mat (SI) and Vicon's markers (mm -> m) ------------------------------------------------


def test_qmt_mat_reads_each_struct_in_si(tmp_path):
    t = np.arange(4) / 100.0
    acc = np.array([[0.0, 0.0, 9.81], [1.0, 2.0, 3.0], [0.5, 0.5, 0.5], [0, 0, 0]])
    gyr = np.array([[0.1, 0.2, 0.3], [0, 0, 0], [1, 1, 1], [-1, 0, 1]])
    path = tmp_path / "example.mat"
    savemat(path, {"t": t, "thigh_r": {"acc": acc, "gyr": gyr}, "note": "x"})
    times, segments = qmt.read_qmt(path)
    np.testing.assert_allclose(times, t)
    assert list(segments) == ["thigh_r"]
    np.testing.assert_allclose(segments["thigh_r"][0], acc)
    np.testing.assert_allclose(segments["thigh_r"][1], gyr)
    savemat(path, {"t": t, "thigh_r": {"acc": acc[:3], "gyr": gyr}})
    with pytest.raises(FormatError, match=r"thigh_r: acc \(3, 3\)"):
        qmt.read_qmt(path)


def test_vicon_markers_in_millimetres_become_metres(tmp_path):
    path = tmp_path / "markers.mat"
    savemat(path, {"LASI": np.array([[1000.0, -250.0, 12.5]] * 3), "label": np.ones((3, 2))})
    markers = vicon.read_markers(path)
    assert list(markers) == ["LASI"]  # (N, 3) arrays only
    np.testing.assert_allclose(markers["LASI"][0], [1.0, -0.25, 0.0125])


# --- gaitmap's example: gyroscope deg/s -> rad/s, markers mm -> m ---------------------------------


def test_gaitmap_reads_deg_per_s_as_rad_per_s_and_mm_as_m(tmp_path):
    n_imu = 8
    imu = pd.DataFrame(
        np.tile([0.0, 0.0, 9.81, 90.0, -180.0, 45.0], (n_imu, 1)),
        columns=pd.MultiIndex.from_product(
            [["left_sensor"], [f"{s}_{a}" for s in ("acc", "gyr") for a in "xyz"]]
        ),
    )
    imu.to_csv(tmp_path / "imu_sample_not_rotated.csv")
    n_mocap = int(np.ceil(n_imu / gaitmap.IMU_RATE_HZ * gaitmap.MOCAP_RATE_HZ)) + 1
    labels = [f"l_{m}" for m in gaitmap.FRAME]
    mocap = pd.DataFrame(
        np.tile([1000.0, 500.0, -20.0], (n_mocap, len(labels))),
        columns=pd.MultiIndex.from_product([labels, ["x", "y", "z"]]),
    )
    mocap.to_csv(tmp_path / "mocap_sample.csv")
    sheet = pd.DataFrame([{"name": "left_sensor", "prefix": "l", "imu": "IMU_L"}])
    signals, markers = gaitmap._read(tmp_path, sheet)
    gyr, acc = signals["IMU_L"]
    np.testing.assert_allclose(gyr[0], np.radians([90.0, -180.0, 45.0]))
    np.testing.assert_allclose(acc[0], [0.0, 0.0, 9.81])
    assert markers["l_FCC"].shape == (n_imu, 3)
    np.testing.assert_allclose(markers["l_FCC"], np.tile([1.0, 0.5, -0.02], (n_imu, 1)))


# --- a missing required column of every sheet, refused by name ------------------------------------


def _without(path: Path, *columns: str) -> None:
    """The sheet with ``columns`` renamed (a lab's spelling the contract does not know)."""
    sheet = pd.read_csv(path, sep="\t", dtype=str, keep_default_na=False)
    sheet.rename(columns={c: f"my_{c}" for c in columns}).to_csv(path, sep="\t", index=False)


def _ground_truth(root: Path) -> None:
    rows = {"subject": "S1", "sensor_set": "frontal", "imu": "IMU4"}
    rows |= {f"r{i}{j}": float(i == j) for i in (1, 2, 3) for j in (1, 2, 3)}
    pd.DataFrame([rows]).to_csv(root / "ground_truth.tsv", sep="\t", index=False)
    (root / "functional_axes.tsv").write_text("test\tsegment\taxis\nT1\tthigh\t+y\n")
    (root / "verticals.tsv").write_text(
        "subject\ttest\trep\tstatic_test\tstatic_rep\nS1\tT1\t1\tT0\t1\n"
    )


@pytest.fixture(scope="module")
def sheets_only(tmp_path_factory) -> Path:
    """The mini dataset's yaml and sheets, with a ground truth, a functional design and a
    vertical per repetition (the recordings are not read when only the sheets are checked)."""
    root = make_dataset(tmp_path_factory.mktemp("mini") / "mini")
    _ground_truth(root)
    return root


def _copy_sheets(source: Path, target: Path) -> Path:
    target.mkdir()
    for path in source.iterdir():
        if path.suffix in (".tsv", ".yaml"):
            shutil.copy(path, target / path.name)
    return target


ALL_SHEETS = {**SHEETS, **OPTIONAL_SHEETS}


@pytest.mark.parametrize("sheet", ALL_SHEETS)
def test_every_sheet_refuses_a_missing_required_column(tmp_path, sheets_only, sheet):
    """Its last required column missing: one error, naming the sheet and the column, and the
    dataset refused; every required column missing: all of them named."""
    required = ALL_SHEETS[sheet]
    root = _copy_sheets(sheets_only, tmp_path / "one")
    _without(root / sheet, required[-1])
    _, report = read_sheets(root)
    assert [(f.where, f.cause.split(" (has")[0]) for f in report.errors] == [
        (sheet, f"missing column(s) {required[-1]}")
    ]
    with pytest.raises(DatasetError, match=rf"{sheet}: missing column\(s\) {required[-1]} \(has "):
        load_dataset(root)
    root = _copy_sheets(sheets_only, tmp_path / "all")
    _without(root / sheet, *required)
    _, report = read_sheets(root)
    assert [(f.where, f.cause.split(" (has")[0]) for f in report.errors] == [
        (sheet, f"missing column(s) {', '.join(required)}")
    ]


def test_the_sheets_read_without_a_missing_column(tmp_path, sheets_only):
    """The same sheets with every column present: no error (the cases above break only one)."""
    dataset, report = read_sheets(_copy_sheets(sheets_only, tmp_path / "mini"))
    assert report.ok and dataset is not None and dataset.ground_truth is not None


@pytest.mark.parametrize(
    "module, columns",
    [(xsens, xsens.SHEET_COLUMNS), (qmt, qmt.SHEET_COLUMNS)],
    ids=["xsens", "qmt"],
)
def test_the_importers_sensor_sheets_refuse_a_missing_column(tmp_path, module, columns):
    for column in columns:
        present = [c for c in columns if c != column]
        path = tmp_path / f"sensors_{column}.tsv"
        path.write_text("# a comment\n" + "\t".join(present) + "\n" + "\t".join(present) + "\n")
        with pytest.raises(FormatError, match=rf"{path.name}: missing column\(s\) {column} "):
            module.read_sensor_sheet(path)
    path = tmp_path / "sensors.tsv"
    path.write_text("\t".join(columns) + "\n" + "\t".join(f" {c} " for c in columns) + "\n")
    assert module.read_sensor_sheet(path).iloc[0].tolist() == columns  # stripped
