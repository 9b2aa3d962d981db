"""Importers on the real files of ../shared/data (skipped when absent), their errors on broken
files, the Vicon ground truth on analytic cases, and `aceval calibrate` / `aceval apply`."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.dataset import load_dataset, validate
from aceval.importers import FormatError
from aceval.importers.hugadb import import_hugadb, read_hugadb
from aceval.importers.shared import straight_strides, walking_bouts
from aceval.importers.vicon import body_axes, optical_angular_velocity, sensor_to_segment
from aceval.importers.xsens import read_mt_export

from .runner import aceval

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
HUGADB, NEURA = DATA / "hugadb", DATA / "neura_gaittoolbox"
_data_present = pytest.mark.skipif(
    not DATA.is_dir(),
    reason=f"real recordings not found at {DATA} "
    "(public data the project does not ship; see ../shared/data/README.md)",
)


def needs_data(test):
    """Real recordings from ../shared/data: skipped when absent, slow (imports them)."""
    return pytest.mark.slow(_data_present(test))


def run(*args):
    """``aceval *args`` in this process, as a subprocess runs it (tests/runner.py)."""
    result = aceval(*args)
    return SimpleNamespace(returncode=result.code, stdout=result.out, stderr=result.err)


@pytest.fixture(scope="module")
def hugadb(clean):
    """HuGaDB imported (once per test run), and its report's rows."""
    if not HUGADB.is_dir():
        pytest.skip(f"HuGaDB not found at {HUGADB}")

    def imported(folder: Path) -> None:
        (folder / "dataset").mkdir(parents=True)
        pd.DataFrame(import_hugadb(HUGADB, folder / "dataset").rows).to_pickle(folder / "rows.pkl")

    folder = clean.shared("hugadb", imported)
    return folder / "dataset", pd.read_pickle(folder / "rows.pkl")


@needs_data
def test_hugadb_import_is_a_valid_dataset_with_faults_reported(hugadb):
    out, report = hugadb
    dataset, validation = validate(out)
    assert validation.ok, validation.format()
    # participant 03's corrupted gyroscopes (the README's known fault) are detected and left out
    p03 = report[report["subject"] == "v1_walking_03_00"]
    assert set(p03.loc[p03["status"] == "excluded", "imu"]) >= {"RS", "RF"}
    assert not (
        (dataset.recordings["subject"] == "v1_walking_03_00")
        & dataset.recordings["imu"].isin(["RS", "RF"])
    ).any()
    # clipping at +-2 g is reported for the feet of every imported walking session
    flagged = report[(report["status"] == "flagged") & report["cause"].str.contains("clipped")]
    assert {"RF", "LF"} & set(flagged["imu"])
    # the sit-to-stand session: 4 standing runs -> T0, 4 cycles -> T3; walking sessions: flagged T0w
    various = dataset.recordings[dataset.recordings["subject"] == "v2_various_01_00"]
    assert various.groupby("test")["rep"].max().to_dict() == {"T0": 4, "T3": 4}
    walking = dataset.recordings[dataset.recordings["subject"] == "v1_walking_01_00"]
    assert set(walking["test"]) == {"T0w", "T6"} and walking["rep"].max() == 5
    assert "FALLBACK" in dataset.tests.loc["T0w", "description"]
    # SI units: 1 g while standing
    standing = dataset.read_recording(various[various["test"] == "T0"]["path"].iloc[0])
    assert np.linalg.norm(np.median(standing.acc, axis=0)) == pytest.approx(9.81, rel=0.05)


@needs_data
def test_hugadb_right_axis_matches_the_shank_swing(hugadb):
    """In swing the shank rotates forward, positive about the body's right axis: the largest
    angular velocities about right_axis (-y) are positive."""
    out, _ = hugadb
    dataset = load_dataset(out)
    recordings = dataset.recordings
    for imu in ("RS", "LS"):
        path = recordings[
            (recordings["subject"] == "v1_walking_01_00")
            & (recordings["test"] == "T6")
            & (recordings["imu"] == imu)
        ]["path"].iloc[0]
        about_right = -dataset.read_recording(path).gyr[:, 1]
        assert np.percentile(about_right, 99) > -np.percentile(about_right, 1)


@needs_data
def test_neura_import_with_ground_truth(tmp_path):
    out = tmp_path / "neura"
    result = run(
        "import",
        "xsens",
        NEURA / "rawimu",
        "--sensors",
        REPO / "config/real/neura_sensors.tsv",
        "--subject",
        "S02",
        "--vicon",
        NEURA / "rawvicon/S02-Trial-Walk-1.mat",
        "--out",
        out,
    )
    assert result.returncode == 0, result.stderr
    dataset = load_dataset(out, check_files=True)
    assert dataset.ground_truth is not None and len(dataset.ground_truth) == 9
    report = pd.read_csv(out / "import_report.tsv", sep="\t", dtype=str)
    assert (
        report.loc[report["imu"] == "00B40C49", "cause"].item()
        == "byte-identical duplicate of 00B40C44"
    )
    method = pd.read_csv(out / "ground_truth_method.tsv", sep="\t").set_index(["sensor_set", "imu"])
    method["flag"] = method["flag"].fillna("")
    assert (method["heading_vs_walk_deg"] < 10).all()
    # the two truths: the optical point acceleration and the marker frame agree for the pelvis and
    # thighs; the shanks' marker frame twists about the long axis while walking, 17-24 deg apart
    shanks = method[method["segment"] == "shank"]
    assert len(shanks) == 4 and (shanks["methods_differ_deg"] > 12).all()
    assert shanks["flag"].str.contains("methods_differ").all()
    assert (shanks["twist_mean_deg"].abs() > 4).all()
    # the truth's uncertainty (its strides, other points, +-1 sample) says when it is unstable
    unstable = method["flag"].str.contains("truth_unstable")
    assert (unstable == (method["truth_uncertainty_deg"] > 5)).all()
    assert (method["truth_uncertainty_deg"] < 5).all() and (method["lag_samples"] == 2).all()
    # the independent check (the long axis' angular velocity, no marker frame) agrees with the
    # truth on every leg sensor, and shows the marker frame's shank truths 16-24 deg off
    legs = method[method["segment"] != "waist"]
    assert (legs["long_axis_check_deg"] <= 2).all()
    assert (shanks["marker_frame_long_axis_check_deg"] > 12).all()
    assert "ground truth" in set(
        pd.read_csv(out / "import_report.tsv", sep="\t", dtype=str)["status"]
    )
    assert method.loc[("main", "pelvis"), "methods_differ_deg"] < 5
    # where the sensors sit: the main shank sensors near the ankle, the second ones higher up
    assert (method.loc[("main", ["shank_r", "shank_l"]), "lever_arm_m"] < 0.15).all()
    assert (method.loc[("shank2", ["shank_r", "shank_l"]), "lever_arm_m"] > 0.2).all()
    assert (shanks["pair_heading_deg"] < 10).all() and (shanks["pair_tilt_deg"] < 10).all()
    # the sheet's right_axis is the sensor axis nearest the true body y
    for (_, sensor_set, imu), row in dataset.ground_truth.iterrows():
        y = row[[f"r2{j}" for j in (1, 2, 3)]].to_numpy(float)
        axis = int(np.argmax(np.abs(y)))
        assert dataset.right_axis(sensor_set, imu) == ("+" if y[axis] > 0 else "-") + "xyz"[axis]


@needs_data
@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda text: text[: len(text) // 2], "truncated or garbled"),
        (lambda text: text.replace("\n", "\nabc\t", 8), "40 fields, expected 39"),
        (lambda text: text.replace("\t", "\tx", 1), "non-numeric"),
    ],
)
def test_broken_hugadb_file_gives_a_clear_error(tmp_path, damage, message):
    source = HUGADB / "HuGaDB_v1_walking_06_00.txt"
    broken = tmp_path / "src" / source.name
    broken.parent.mkdir()
    text = source.read_text()
    lines = text.splitlines(keepends=True)
    broken.write_text("".join(lines[:4]) + damage("".join(lines[4:])))
    with pytest.raises(FormatError, match=rf"{broken.name}: line \d+: .*{message}"):
        read_hugadb(broken)
    result = run("import", "hugadb", broken.parent, "--out", tmp_path / "out")
    assert result.returncode == 1 and broken.name in result.stderr
    assert not (tmp_path / "out").exists()  # a failed import leaves nothing


@needs_data
def test_truncated_xsens_export_gives_a_clear_error(tmp_path):
    source = NEURA / "rawimu" / "S02-Trial-Walk-1-000_00B40C47.txt"
    broken = tmp_path / source.name
    text = source.read_text()
    broken.write_text(text[: len(text) // 3])
    with pytest.raises(FormatError, match=rf"{broken.name}: line \d+: \d+ fields"):
        read_mt_export(broken)
    (tmp_path / "header.txt").write_text("// Update Rate: 100.0Hz\nPacketCounter,Acc_X\n1,2\n")
    with pytest.raises(FormatError, match="missing column"):
        read_mt_export(tmp_path / "header.txt")


def mt_manager_2019(source: Path, target: Path) -> None:
    """``source`` (a comma-separated export) written as MT Manager 2019.2 writes its text exports:
    tab-separated, FreeAcc, VelInc and Euler columns beside Acc, Gyr, Mag and Quat, a
    ``// Coordinate system: ENU`` header line, and a tab at the end of every line."""
    lines = source.read_text().splitlines()
    comments = [line for line in lines if line.startswith("//")]
    table = pd.read_csv(source, comment="/", dtype=str, keep_default_na=False)
    extra = {f"{name}_{axis}": "0.000000" for name in ("FreeAcc", "VelInc") for axis in "EXY"[:3]}
    table = table.assign(**extra, Roll="1.0", Pitch="2.0", Yaw="3.0")
    header = ["// Coordinate system: ENU", *comments]
    body = table.to_csv(sep="\t", index=False, lineterminator="\t\n")
    target.write_text("\n".join(header) + "\n" + body)


@_data_present
def test_tab_separated_mt_manager_2019_export_reads_as_the_comma_one(tmp_path):
    source = NEURA / "rawimu" / "S02-Trial-Walk-1-000_00B40C47.txt"
    tabbed = tmp_path / source.name
    mt_manager_2019(source, tabbed)
    assert "\t" in tabbed.read_text().splitlines()[6] and "FreeAcc_E" in tabbed.read_text()
    comma_header, comma = read_mt_export(source)
    tab_header, tab = read_mt_export(tabbed)
    pd.testing.assert_frame_equal(tab, comma)
    assert (comma_header["separator"], tab_header["separator"]) == (
        "comma-separated",
        "tab-separated",
    )
    assert tab_header["Coordinate system"] == "ENU"
    (tmp_path / "semi.txt").write_text(
        "// Update Rate: 100.0Hz\nPacketCounter;Acc_X;Acc_Y\n1;2;3\n"
    )
    with pytest.raises(FormatError, match="line 2: the column header is neither"):
        read_mt_export(tmp_path / "semi.txt")
    (tmp_path / "few.txt").write_text("// Update Rate: 100.0Hz\nPacketCounter\tAcc_X\n1\t2\n")
    with pytest.raises(FormatError, match="read as tab-separated.*found PacketCounter, Acc_X"):
        read_mt_export(tmp_path / "few.txt")


def test_walking_bouts_equal_whole_strides_and_turns_left_out():
    strides = [(k * 100, (k + 1) * 100) for k in range(12)]
    assert walking_bouts(strides) == [(0, 200), (200, 400), (400, 600), (600, 800), (800, 1000)]
    yaw = np.zeros(1200)
    yaw[300:500] = np.radians(90.0)  # a 180 deg turn over strides 3 and 4 (1 s at 100 Hz... 2 s)
    straight = straight_strides(strides, yaw, fs_hz=100.0)
    assert (300, 400) not in straight and (400, 500) not in straight and len(straight) == 10
    bouts = walking_bouts(straight)
    assert all(b - a == 200 for a, b in bouts)  # no repetition spans the turn
    assert all(not (a < 400 < b) for a, b in bouts)


def test_gyroscope_alignment_recovers_a_known_mounting(rng):
    """Optical angular velocity of a segment, and a gyroscope mounted with a known rotation:
    the fit returns that rotation, with the vertical pair matched exactly."""
    t = np.arange(2000) / 100.0
    omega_seg = np.column_stack([0.5 * np.sin(2 * t), 3 * np.sin(6 * t + 1), 0.8 * np.cos(3 * t)])
    mounting = Rotation.from_euler("xyz", [20, -35, 110], degrees=True)  # sensor -> segment
    gyr = mounting.inv().apply(omega_seg) + rng.normal(0, 0.01, omega_seg.shape)
    up_seg = np.array([0.1, 0.0, 1.0]) / np.linalg.norm([0.1, 0.0, 1.0])
    fitted, rms = sensor_to_segment(omega_seg, gyr, (up_seg, mounting.inv().apply(up_seg)))
    assert np.degrees((fitted * mounting.inv()).magnitude()) < 0.2
    assert rms < 0.05


def test_optical_angular_velocity_of_a_constant_rotation():
    rate = np.array([0.3, -1.2, 2.0])  # rad/s in the segment frame
    frames = Rotation.from_rotvec(np.outer(np.arange(300) / 100.0, rate))
    assert np.allclose(optical_angular_velocity(frames, 100.0), rate, atol=1e-9)


def test_body_axes_from_a_tilted_medial_lateral_axis():
    B = body_axes(np.array([0.0, -0.99, 0.14]))  # world z up; the right ASIS a little higher
    assert np.allclose(B @ B.T, np.eye(3)) and np.linalg.det(B) > 0
    assert np.allclose(B[2], [0, 0, -1]) and np.allclose(B[1], [0, -1, 0])
    assert np.allclose(B[0], [1, 0, 0])  # x = y x z: forward


@pytest.mark.slow
def test_calibrate_command_options_and_apply(tmp_path):
    """`aceval calibrate --method --tests --subsets` on a small simulation, then `aceval apply`:
    a body-frame copy calibrated again gives the identity."""
    data = tmp_path / "box"
    assert run("simulate", "box", "--out", data, "--repetitions", "3").returncode == 0
    every = tmp_path / "all.csv"
    assert run("calibrate", data, "--out", every).returncode == 0
    table = pd.read_csv(every)
    for option, kept in (("kong", {"kong"}), ("triad", {"triad"}), ("ricci_lm", {"ricci_lm"})):
        out = tmp_path / f"{option}.csv"
        result = run(
            "calibrate",
            data,
            "--out",
            out,
            "--method",
            option,
            "--subsets",
            "full",
            "--tests",
            "EDGE",
        )
        assert result.returncode == 0, result.stderr
        assert "calibrations" in result.stderr and "median_error_deg" in result.stderr
        chosen = pd.read_csv(out)
        assert set(chosen["method"]) == kept and set(chosen["test"]) == {"EDGE"}
        assert (chosen["repetitions"] == "R1+R2+R3").all()
        expected = table[
            table["method"].isin(kept)
            & (table["test"] == "EDGE")
            & (table["repetitions"] == "R1+R2+R3")
        ]
        assert np.allclose(
            chosen.filter(regex=r"^r\d\d$").to_numpy(), expected.filter(regex=r"^r\d\d$").to_numpy()
        )
    body = tmp_path / "body"
    result = run("apply", data, "--calibrations", every, "--out", body)
    assert result.returncode == 0, result.stderr
    again = tmp_path / "again.csv"
    assert (
        run("calibrate", body, "--out", again, "--method", "kong", "--subsets", "full").returncode
        == 0
    )
    applied = pd.read_csv(body / "applied_calibrations.tsv", sep="\t")
    recalibrated = pd.read_csv(again).merge(applied[["subject", "sensor_set", "imu", "test"]])
    R = recalibrated.filter(regex=r"^r\d\d$").to_numpy(float).reshape(-1, 3, 3)
    assert np.allclose(R, np.eye(3), atol=2e-3)  # the copies are in the body frame
    assert run("apply", data, "--calibrations", every, "--out", data / "inside").returncode == 2
    # a dataset that fails validation: non-zero exit with the validator's message
    (tmp_path / "bad").mkdir()
    result = run("calibrate", tmp_path / "bad", "--out", tmp_path / "x.csv")
    assert result.returncode == 1 and "dataset.yaml" in result.stderr
    assert not (tmp_path / "x.csv").exists()


QMT, GAITMAP = DATA / "qmt_fullbody", DATA / "gaitmap_feet"


@needs_data
def test_qmt_import_standing_transitions_and_walking(tmp_path):
    out = tmp_path / "qmt"
    result = run(
        "import", "qmt", QMT, "--sensors", REPO / "config/real/qmt_sensors.tsv", "--out", out
    )
    assert result.returncode == 0, result.stderr
    dataset, validation = validate(out)
    assert validation.ok, validation.format()
    reps = dataset.recordings.groupby("test")["rep"].max().to_dict()
    assert reps["T0"] == 1 and reps["T3"] == 2 and 3 <= reps["T6"] <= 5
    assert dataset.first_phase("T3") == "" and dataset.first_phase("T6") == "gait"
    standing = dataset.read_recording(
        dataset.recordings.query("test == 'T0' and imu == 'pelvis'")["path"].item()
    )
    assert standing.t[-1] > 3.0 and np.linalg.norm(
        np.median(standing.acc, axis=0)
    ) == pytest.approx(9.81, rel=0.03)
    # the two transitions: the right thigh goes from vertical to seated and back
    thigh = dataset.recordings.query("test == 'T3' and imu == 'thigh_r'").sort_values("rep")["path"]
    first, last = (dataset.read_recording(p).acc for p in thigh)
    angle = lambda a, b: np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))  # noqa: E731
    assert angle(first[:20].mean(0), first[-20:].mean(0)) > 60  # stand-to-sit
    assert angle(last[:20].mean(0), last[-20:].mean(0)) > 60  # sit-to-stand
    report = pd.read_csv(out / "import_report.tsv", sep="\t", dtype=str)
    assert set(report.loc[report["status"] == "skipped", "imu"]) >= {"hand_left", "forearm_right"}
    # the hand-tuned reference, read as segment-to-sensor, puts each segment's up near gravity
    loose = pd.read_csv(out / "loose_reference.tsv", sep="\t")
    assert len(loose) == 10 and (loose["standing_up_angle_deg"] < 10).all()
    assert dataset.ground_truth is None  # a loose reference is never a truth


@needs_data
def test_gaitmap_import_with_two_truths_that_agree(tmp_path):
    out = tmp_path / "feet"
    result = run("import", "gaitmap", GAITMAP, "--sensors", REPO / "config/real/gaitmap_feet_sensors.tsv",
                 "--out", out)  # fmt: skip
    assert result.returncode == 0, result.stderr
    dataset, validation = validate(out)
    assert validation.ok, validation.format()
    assert (
        dataset.fs_hz == 204.8
        and dataset.ground_truth is not None
        and len(dataset.ground_truth) == 2
    )
    assert dataset.recordings.groupby("test")["rep"].max().to_dict()["T6"] >= 3
    method = pd.read_csv(out / "ground_truth_method.tsv", sep="\t")
    # the feet's two truths agree (no soft tissue between heel, toe and fifth metatarsal markers)
    assert (method["methods_differ_deg"] < 5).all() and (method["truth_uncertainty_deg"] < 3).all()
    assert (method["truth_n_strides"] >= 5).all() and (method["long_axis_check_deg"] <= 2).all()
    assert (method["lever_arm_m"].between(0.03, 0.25)).all()
    # the sheet's right_axis is the sensor axis nearest the true body y
    for (_, sensor_set, imu), row in dataset.ground_truth.iterrows():
        y = row[[f"r2{j}" for j in (1, 2, 3)]].to_numpy(float)
        axis = int(np.argmax(np.abs(y)))
        assert dataset.right_axis(sensor_set, imu) == ("+" if y[axis] > 0 else "-") + "xyz"[axis]
