"""`aceval import xsens --trials`: a lab's exports in one call, on small synthetic exports (a
standing start, then a leg swinging about the body's right axis): the rate from wherever the
export has it, sensors trimmed to their shared samples, each static source, segments no test
calibrates named, empty right axes refused with a proposal, and every refusal a message (file,
sensor, what was found, what to do), never a traceback."""

import shutil
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.dataset import load_dataset

from .labexports import export
from .runner import aceval

FS = 100.0
SENSORS = {"00B4A201": ("shank", "right", "+y"), "00B4A202": ("foot", "right", "-z")}


def signals(standing_s=3.0, walking_s=6.0, mount=None, seed=0):
    """Quiet standing, then a shank-like swing about body y (forward fast, back slowly), seen by
    a sensor mounted with ``mount`` (sensor -> body; default the identity); SI."""
    mount = np.eye(3) if mount is None else mount
    rng = np.random.default_rng(seed)
    t = np.arange(int((standing_s + walking_s) * FS)) / FS
    moving = t >= standing_s
    pulse = np.clip(np.sin(2 * np.pi * (t - standing_s)), 0, None) ** 3
    rate = np.where(moving, 4.0 * (pulse - 0.212), 0.0)
    pitch = np.cumsum(rate) / FS
    body = Rotation.from_rotvec(np.outer(pitch, [0, 1.0, 0]))
    acc = body.inv().apply([0, 0, -9.81]) @ mount + rng.normal(0, 0.05, (len(t), 3))
    gyr = np.column_stack([0 * rate, rate, 0 * rate]) @ mount + rng.normal(0, 0.005, (len(t), 3))
    return acc, gyr


MOUNTS = {"+y": np.eye(3), "-z": Rotation.from_euler("x", 90, degrees=True).as_matrix()}


def lab(tmp_path, trials: str, sensors=SENSORS, style="2019", standing_s=3.0, short=None,
        placed=None):  # fmt: skip
    """Exports of every trial named in ``trials`` (a trials.tsv text), the sheets beside them;
    ``placed``: {trial: rotation} the sensors put on again, turned by it, for that trial."""
    exports = tmp_path / "exports"
    sheet = pd.read_csv(pd.io.common.StringIO(trials), sep="\t", dtype=str, keep_default_na=False)
    for k, trial in enumerate(dict.fromkeys(sheet["trial"])):
        turned = (placed or {}).get(trial, np.eye(3))
        for j, (sensor_id, (_, _, axis)) in enumerate(sensors.items()):
            acc, gyr = signals(standing_s, mount=MOUNTS[axis] @ turned, seed=10 * k + j)
            if short == (trial, sensor_id):
                acc, gyr = acc[:-1], gyr[:-1]
            path = exports / f"{trial}-000_{sensor_id}.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            export(path, sensor_id, 100 + 5000 * k, acc, gyr, style)
    (tmp_path / "trials.tsv").write_text(trials)
    rows = ["sensor_id\tsegment\tside\tright_axis"]
    rows += [f"{s}\t{seg}\t{side}\t{axis}" for s, (seg, side, axis) in sensors.items()]
    (tmp_path / "sensors.tsv").write_text("\n".join(rows) + "\n")
    return tmp_path


@pytest.fixture
def run():
    def run(folder, *options):
        args = ["import", "xsens", folder / "exports", "--trials", folder / "trials.tsv"]
        args += ["--sensors", folder / "sensors.tsv", "--out", folder / "out", *options]
        result = aceval(*args)
        assert "Traceback" not in result.err
        return SimpleNamespace(code=result.code, err=result.err, out=folder / "out")

    return run


WALKS = "subject\ttrial\ttest\tstatic\tfirst_phase\n" + "".join(
    f"P1\tP1/walk_{k}\twalk\t2\tgait\n" for k in (1, 2)
)


def test_two_trials_become_two_repetitions_with_the_standing_start_as_static(tmp_path, run):
    folder = lab(tmp_path, WALKS)
    (folder / "trials.tsv").write_text("\ufeff" + WALKS)  # Excel's "CSV UTF-8" starts so
    result = run(folder)
    assert result.code == 0, result.err
    dataset = load_dataset(result.out, check_files=True)
    assert dataset.fs_hz == 100.0  # from SampleTimeFine (ticks of 100 us that wrap at 2^32)
    reps = dataset.recordings.groupby("test")["rep"].max().to_dict()
    assert reps == {"standing": 2, "walk": 2}
    assert dataset.first_phase("walk") == "gait"
    standing = dataset.read_recording(
        dataset.recordings.query("test == 'standing' and imu == 'shank_r'")["path"].iloc[0]
    )
    assert len(standing.t) == 200  # the first 2 s
    calibrates = set(map(tuple, dataset.calibrates.to_numpy()))
    assert calibrates == {("walk", "shank_r"), ("walk", "foot_r")}
    report = pd.read_csv(result.out / "import_report.tsv", sep="\t", dtype=str)
    assert (report["status"] == "imported").sum() == 4


@pytest.mark.parametrize(
    "style, options, message",
    [
        ("bare", [], r"no '// Update Rate: <n>Hz' header line and no SampleTimeFine .* --rate"),
        ("comma", ["--rate", "120"], r"--rate 120 Hz, its '// Update Rate' line 100 Hz"),
        ("2019", ["--rate", "50"], r"--rate 50 Hz, its SampleTimeFine 100 Hz"),
    ],
)
def test_the_rate_is_given_or_found_and_checked(tmp_path, run, style, options, message):
    result = run(lab(tmp_path, WALKS, style=style), *options)
    assert result.code == 1 and not result.out.exists()
    assert pd.Series([result.err]).str.contains(message).item(), result.err
    assert "walk_1-000_00B4A201.txt" in result.err
    assert run(tmp_path, "--rate", "100").code == 0  # the rate that agrees


def test_a_sensor_a_sample_short_is_refused_or_trimmed(tmp_path, run):
    folder = lab(tmp_path, WALKS, short=("P1/walk_2", "00B4A202"))
    refused = run(folder)
    assert refused.code == 1
    assert "trial P1/walk_2 (trials.tsv line 3)" in refused.err
    assert "00B4A202: 899 samples (PacketCounter 5100-5998)" in refused.err
    assert "--trim-to-shared" in refused.err and "899 samples all of them share" in refused.err
    trimmed = run(folder, "--trim-to-shared")
    assert trimmed.code == 0 and "trimmed to the 899 samples" in trimmed.err
    dataset = load_dataset(trimmed.out, check_files=True)
    walk2 = dataset.recordings.query("test == 'walk' and rep == 2")
    assert {len(dataset.read_recording(p).t) for p in walk2["path"]} == {899 - 200}


def test_each_static_source_and_a_subject_without_one(tmp_path, run):
    trials = (
        "subject\ttrial\ttest\tstatic\tfirst_phase\n"
        "P1\tP1/stand\tquiet\tfile\t\n"
        "P1\tP1/walk_1\twalk\t\tgait\n"
        "P2\tP2/walk_1\twalk\twalking\tgait\n"
        "P3\tP3/walk_1\twalk\t\tgait\n"
    )
    refused = run(lab(tmp_path, trials))
    assert refused.code == 1
    assert "subject(s) P3: no quiet standing" in refused.err and "static=walking" in refused.err
    (tmp_path / "trials.tsv").write_text(
        trials.replace("P3\tP3/walk_1\twalk\t\t", "P3\tP3/walk_1\twalk\t5\t")
    )
    late = run(tmp_path)  # 5 s of standing declared; the swing starts at 3 s
    assert late.code == 1
    assert "first 5 s are declared quiet standing" in late.err
    assert "moves from 2.76 s: write at most 1.8" in late.err  # Kong's trimmer, 0.25 s early
    (tmp_path / "trials.tsv").write_text(
        trials.replace("P3\tP3/walk_1\twalk\t\t", "P3\tP3/walk_1\twalk\t2.5\t")
    )
    result = run(tmp_path)
    assert result.code == 0, result.err
    subjects = pd.read_csv(result.out / "subjects.tsv", sep="\t").set_index("subject")
    assert subjects["z0_source"].to_dict() == {
        "P1": "standing trial", "P2": "walking (FALLBACK)",
        "P3": "first 2.5 s (per repetition: its own recording's)",
    }  # fmt: skip
    tests = pd.read_csv(result.out / "tests.tsv", sep="\t").set_index("test")
    assert tests.loc["walking_vertical", "description"].startswith("FALLBACK")
    assert set(tests.index[tests["kind"] == "static"]) == {"quiet", "walking_vertical", "standing"}


def test_a_segment_no_test_calibrates_is_named_on_screen(tmp_path, run):
    sensors = {**SENSORS, "00B4A203": ("lower_back", "center", "+y")}
    result = run(lab(tmp_path, WALKS, sensors=sensors))
    assert result.code == 0, result.err
    assert "IMU lower_back (sensors.tsv line 4) will not be calibrated" in result.err
    assert "write waist as its segment" in result.err
    report = pd.read_csv(result.out / "import_report.tsv", sep="\t", dtype=str)
    assert report.loc[report["status"] == "not calibrated", "imu"].tolist() == ["lower_back"]


def test_an_empty_right_axis_is_refused_with_what_the_recordings_propose(tmp_path, run):
    folder = lab(tmp_path, WALKS)
    sheet = (folder / "sensors.tsv").read_text().replace("\t-z\n", "\t\n")
    (folder / "sensors.tsv").write_text(sheet)
    result = run(folder)
    assert result.code == 1 and not result.out.exists()
    assert "right_axis is empty" in result.err
    assert "sensors.tsv line 3 (foot_r, foot right): the recordings propose -z" in result.err


BROKEN = {
    "an empty export": lambda p: p.write_text(""),
    "a binary export": lambda p: p.write_bytes(bytes(range(256)) * 4),
    "a header only": lambda p: p.write_text(p.read_text().split("\n")[7] + "\n"),
    "a non-numeric value": lambda p: p.write_text(p.read_text().replace("\t0.", "\tx.", 1)),
    "a missing column": lambda p: p.write_text(p.read_text().replace("Gyr_Y", "Gyr_Q")),
    "lost samples": lambda p: p.write_text("\n".join(
        line for k, line in enumerate(p.read_text().split("\n")) if k != 300)),
}  # fmt: skip


@pytest.mark.parametrize("damage", BROKEN)
def test_a_broken_export_is_a_message_naming_it(tmp_path, run, damage):
    folder = lab(tmp_path, WALKS)
    broken = folder / "exports" / "P1" / "walk_2-000_00B4A202.txt"
    BROKEN[damage](broken)
    result = run(folder)
    assert result.code == 1 and not result.out.exists()
    assert result.err.startswith("aceval import xsens: ") and "nothing written" in result.err
    assert "walk_2-000_00B4A202.txt" in result.err, result.err


@pytest.mark.parametrize(
    "trials, message",
    [
        ("subject\ttest\nP1\twalk\n", "missing column(s) trial or file"),
        ("subject\ttrial\ttest\n", "trials.tsv: only its header line, no row below it"),
        ("subject\ttrial\ttest\tstart_s\tend_s\nP1\tP1/walk_1\tquiet\t4\t3\n", "start before end"),
        (
            "subject\ttrial\ttest\tfirst_phase\tstart_s\tend_s\n"
            "P1\tP1/walk_1\twalk\tgait\t0\t5\nP1\tP1/walk_1\twalk\tgait\t4\t8\n",
            "their segments overlap (0-5 s and 4-8 s)",
        ),
        (
            "subject\ttrial\ttest\tfirst_phase\tstart_s\tend_s\nP1\tP1/walk_1\twalk\tgait\t2\t30\n",
            "end_s 30 is after the trial's last sample (9.00 s at 100 Hz)",
        ),
        ("subject\ttrial\ttest\tstatic\nP1\tP1/walk_1\twalk\tlots\n", "static 'lots'"),
        ("subject\ttrial\ttest\tfirst_phase\nP1\tP1/walk_9\twalk\tgait\n", "matches no export"),
        ("subject\ttrial\ttest\nP1\tP1/walk_1\tbow\n", "say which segments it calibrates"),
        ("subject\ttrial\ttest\trep\tfirst_phase\nP1\tP1/walk_1\twalk\t0\tgait\n", "rep '0'"),
        (
            "subject\tfile\ttest\trep\tstatic\tfirst_phase\n"
            "P1\tP1/walk_1-000_00B4A201.txt\twalk\t1\t2\tgait\n"
            "P1\tP1/walk_1-000_00B4A202.txt\twalk\t1\t\tgait\n",
            "one trial (P1, walk R1) with two static sources",
        ),
    ],
)
def test_a_broken_sheet_is_a_message_naming_its_line(tmp_path, run, trials, message):
    folder = lab(tmp_path, WALKS)
    (folder / "trials.tsv").write_text(trials)
    result = run(folder)
    assert result.code == 1 and message in result.err, result.err


def test_one_standing_only_trial_is_a_message_not_a_traceback(tmp_path):
    """The one-trial import (NeuRA's) of a 2.6 s standing-only export."""
    acc, gyr = signals(standing_s=2.6, walking_s=0.0)
    path = tmp_path / "exports" / "stand-000_00B4A201.txt"
    path.parent.mkdir()
    export(path, "00B4A201", 100, acc, gyr, "comma")
    sheet = tmp_path / "sensors.tsv"
    sheet.write_text(
        "sensor_id\timu\tsensor_set\tsegment\tside\tregion\tright_axis\n"
        "00B4A201\tshank_r\tmain\tshank\tright\tlower_body\t+y\n"
    )
    result = aceval("import", "xsens", path.parent, "--sensors", sheet, "--out", tmp_path / "out")
    err = result.err
    assert result.code == 1 and "Traceback" not in err
    assert "sensor(s) 00B4A201 do not move" in err and "--trials" in err


def test_the_vendors_folder_imports_as_written_and_its_sensorspec_proposes_the_sheet(tmp_path, run):
    """A trial given as its export folder, as MT Manager writes it (MT_<station>_000-000_<id>.txt)
    beside a lab's sensorspec.json.txt, a log and the binary recording; one export re-saved
    with a byte-order mark. Without --sensors the sensorspec proposes the sheet."""
    folder = tmp_path / "exports" / "P1" / "exported000"
    folder.mkdir(parents=True)
    for k, (sensor, (_, _, axis)) in enumerate(SENSORS.items()):
        acc, gyr = signals(mount=MOUNTS[axis], seed=k)
        export(folder / f"MT_0120036B_000-000_{sensor}.txt", sensor, 100, acc, gyr, "2019")
    bom = folder / "MT_0120036B_000-000_00B4A202.txt"
    bom.write_text("\ufeff" + bom.read_text())
    (folder / "sensorspec.json.txt").write_text(
        '{"rightshank": "00B4A201.txt", "rightfoot": "00B4A202.txt", "sample_frequency": 100}'
    )
    (folder / "MT_0120036B_000.mtb").write_bytes(b"\xfa\xff\x0d" * 10)
    (folder / "export_log.txt").write_text("Export started 12:01\nExport done\n")
    (tmp_path / "trials.tsv").write_text(
        "subject\ttrial\ttest\tstatic\tfirst_phase\nP1\tP1/exported000\twalk\t2\tgait\n"
    )
    args = ["import", "xsens", tmp_path / "exports", "--trials", tmp_path / "trials.tsv"]
    first = aceval(*args, "--out", tmp_path / "out")
    err = first.err
    assert first.code == 1 and not (tmp_path / "out").exists() and "Traceback" not in err
    assert "no --sensors: the 1 sensorspec file(s)" in err and "written to" in err
    proposed = pd.read_csv(tmp_path / "sensors.tsv", sep="\t", dtype=str, keep_default_na=False)
    assert proposed[["sensor_id", "segment", "side"]].values.tolist() == [
        ["00B4A201", "shank", "right"], ["00B4A202", "foot", "right"]
    ]  # fmt: skip
    assert (proposed["right_axis"] == "").all()
    proposed["right_axis"] = ["+y", "-z"]
    proposed.to_csv(tmp_path / "sensors.tsv", sep="\t", index=False)
    result = run(tmp_path)
    assert result.code == 0, result.err
    report = pd.read_csv(result.out / "import_report.tsv", sep="\t", dtype=str)
    skipped = report[report["status"] == "skipped"].set_index("source")["cause"]
    assert skipped.index.str.rsplit("/", n=1).str[-1].tolist() == [
        "MT_0120036B_000.mtb", "export_log.txt", "sensorspec.json.txt"
    ]  # fmt: skip
    assert "JSON" in skipped.filter(like="sensorspec").item()
    assert (report["status"] == "imported").sum() == 2
    assert "says sensor" not in result.err  # the sheet agrees with the sensorspec
    proposed["side"] = ["right", "left"]  # a slip in the sheet: the sensorspec says rightfoot
    proposed.to_csv(tmp_path / "sensors.tsv", sep="\t", index=False)
    second = aceval(*args, "--sensors", tmp_path / "sensors.tsv", "--out", tmp_path / "out2")
    assert second.code == 0
    assert (
        "sensors.tsv line 3 says sensor 00B4A202 is foot left; P1/exported000/sensorspec.json.txt "
        "says 'rightfoot' (foot right): check which is right" in second.err
    )


def test_each_walk_takes_its_own_standing_when_the_sensors_were_put_on_again(tmp_path, run):
    """Two walks, each with its own quiet standing; between them the sensors were put on again,
    turned 25 deg about their x axis. Averaged, the two standings disagree (static_disagree)
    and each walk's calibration is off; each walk with its own vertical (verticals.tsv, which
    the import writes) gives each its own mounting, and the calibrations say so."""
    from aceval.data.rotations import error_angle_deg

    turn = Rotation.from_euler("x", 25, degrees=True).as_matrix()
    folder = lab(tmp_path, WALKS, placed={"P1/walk_2": turn})
    result = run(folder)
    assert result.code == 0, result.err
    assert "2 motion repetition(s) take the vertical of their own recording's" in result.err
    sheet = pd.read_csv(result.out / "verticals.tsv", sep="\t", dtype=str)
    assert sheet.values.tolist() == [["P1", "walk", "1", "standing", "1"],
                                     ["P1", "walk", "2", "standing", "2"]]  # fmt: skip
    truths = {"R1": np.eye(3), "R2": turn}

    def calibrated(dataset):
        out = tmp_path / f"{dataset.name}.csv"
        done = aceval("calibrate", dataset, "--out", out)
        assert done.code == 0, done.err
        table = pd.read_csv(out, keep_default_na=False)
        kong = table[(table["method"] == "kong") & (table["imu"] == "shank_r")]
        kong = kong.set_index("repetitions").loc[["R1", "R2"]]
        R = kong[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
        truth = np.array([truths[r] for r in kong.index])  # sensor -> body (mount +y: identity)
        return error_angle_deg(R.reshape(-1, 3, 3), truth), kong

    own, kong = calibrated(result.out)
    assert (own < 3).all(), own
    assert not kong["flag"].str.contains("static_disagree").any()
    assert (kong["z0_tests"] == "standing (per repetition)").all()
    pooled = tmp_path / "pooled"
    shutil.copytree(result.out, pooled)
    (pooled / "verticals.tsv").unlink()
    averaged, kong = calibrated(pooled)
    assert (averaged > 10).all(), averaged  # the mean of two verticals 25 deg apart
    assert kong["flag"].str.contains("static_disagree").all()
