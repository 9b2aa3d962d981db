"""`aceval import table`: any vendor's delimited-text exports through a mapping file, on small
synthetic exports (tests/tableexports.py) in two layouts: one tab-separated file per sensor with
a rate line and a packet counter, and an APDM-like CSV with every sensor in one file, a time
column and a units line. Segments of a recording cut by the sheet (start_s, end_s), files that
are not exports named, the mapping checked with the line and key of each problem, lost packets
and a rate given by hand that does not fit the recordings refused."""

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.cli import main
from aceval.data.dataset import load_dataset

from .tableexports import MAPPINGS, apdm_csv, vendor_txt
from .test_xsens_lab import FS, MOUNTS

SENSORS = {"S101": ("shank", "right", "+y"), "S102": ("foot", "right", "-z")}


def swinging(standing_s, walking_s, mount, seed, lever=(0.0, 0.0, 0.3)):
    """Quiet standing, then a segment swinging about the body's right axis (forward fast, back
    slowly) at 1 Hz about a joint ``lever`` (m, body frame, z down) above the sensor, which
    feels gravity, the swing's tangential and its centripetal acceleration; seen by a sensor
    mounted with ``mount`` (sensor -> body); SI."""
    rng = np.random.default_rng(seed)
    t = np.arange(int((standing_s + walking_s) * FS)) / FS
    pulse = np.clip(np.sin(2 * np.pi * (t - standing_s)), 0, None) ** 3
    rate = np.where(t >= standing_s, 4.0 * (pulse - 0.212), 0.0)
    body = Rotation.from_rotvec(np.outer(np.cumsum(rate) / FS, [0, 1.0, 0]))
    omega = np.outer(rate, [0, 1.0, 0])
    alpha = np.outer(np.gradient(rate) * FS, [0, 1.0, 0])
    lever = np.asarray(lever)
    moving = np.cross(alpha, lever) + np.cross(omega, np.cross(omega, lever))
    acc = (body.inv().apply([0, 0, -9.81]) + moving) @ mount + rng.normal(0, 0.05, (len(t), 3))
    gyr = omega @ mount + rng.normal(0, 0.005, (len(t), 3))
    return acc, gyr


def recorded(seed=0, standing_s=3.0, walking_s=6.0):
    """{sensor: (acc, gyr)}: quiet standing, then a swinging segment (:func:`swinging`)."""
    return {
        s: swinging(standing_s, walking_s, MOUNTS[axis], seed + k)
        for k, (s, (_, _, axis)) in enumerate(SENSORS.items())
    }


def sheets(folder, trials: str, mapping: str):
    (folder / "trials.tsv").write_text(trials)
    rows = ["sensor_id\tsegment\tside\tright_axis"]
    rows += [f"{s}\t{seg}\t{side}\t{axis}" for s, (seg, side, axis) in SENSORS.items()]
    (folder / "sensors.tsv").write_text("\n".join(rows) + "\n")
    (folder / "mapping.yaml").write_text(mapping)


@pytest.fixture
def run(capsys):
    def run(folder, *options):
        args = ["import", "table", folder / "exports", "--mapping", folder / "mapping.yaml"]
        args += ["--trials", folder / "trials.tsv", "--sensors", folder / "sensors.tsv"]
        code = main([str(a) for a in [*args, "--out", folder / "out", *options]])
        captured = capsys.readouterr()
        assert "Traceback" not in captured.err
        return SimpleNamespace(code=code, err=captured.err, out=folder / "out")

    return run


SEGMENTS = (
    "subject\ttrial\ttest\tstatic\tfirst_phase\tstart_s\tend_s\n"
    "P1\tP1/t1\tquiet\tfile\t\t0\t2.5\n"
    "P1\tP1/t1\twalk\t\tgait\t3\t6\n"
    "P1\tP1/t1\twalk\t\tgait\t6\t9\n"
)


def test_one_file_per_sensor_with_a_rate_line_and_segments_cut_by_the_sheet(tmp_path, run):
    phases = {"standing": [0, 2.5], "walk": [[3, 6], [6, 9]]}
    vendor_txt(tmp_path / "exports" / "P1", "t1", recorded(), phases, counter=65000)
    sheets(tmp_path, SEGMENTS, MAPPINGS["vendor_txt"])
    result = run(tmp_path)
    assert result.code == 0, result.err
    dataset = load_dataset(result.out, check_files=True)
    assert dataset.fs_hz == 100.0  # the rate line
    reps = dataset.recordings.groupby("test")["rep"].max().to_dict()
    assert reps == {"quiet": 1, "walk": 2}  # two segments of one recording: two repetitions
    lengths = {
        (r.test, r.rep): len(dataset.read_recording(r.path).t)
        for r in dataset.recordings.query("imu == 'shank_r'").itertuples()
    }
    assert lengths == {("quiet", 1): 250, ("walk", 1): 300, ("walk", 2): 300}
    assert "P1/t1.json: not an export" in result.err  # the phases file: named, not read
    report = pd.read_csv(result.out / "import_report.tsv", sep="\t", dtype=str)
    assert report.loc[report["source"] == "P1/t1.json", "status"].item() == "skipped"


def test_every_sensor_in_one_csv_with_a_time_column_and_a_units_line(tmp_path, run):
    apdm_csv(tmp_path / "exports" / "P1", "walk_1", recorded())
    trials = "subject\ttrial\ttest\tstatic\tfirst_phase\nP1\tP1/walk_1\twalk\t2\tgait\n"
    sheets(tmp_path, trials, MAPPINGS["apdm_csv"])
    result = run(tmp_path)
    assert result.code == 0, result.err
    dataset = load_dataset(result.out, check_files=True)
    assert dataset.fs_hz == pytest.approx(100.0)
    assert set(dataset.imus.index.get_level_values("imu")) == {"shank_r", "foot_r"}
    assert dataset.recordings.groupby("test")["rep"].max().to_dict() == {"standing": 1, "walk": 1}


@pytest.mark.parametrize(
    "change, message",
    [
        (("unit: rad/s", "unit: radians"), "line 6, key gyr.unit: 'radians' is not one of"),
        (("rate_line: 'Acquisition frequency: ([0-9.]+) ?Hz'", "rate_line: 'Hz'"),
         "line 2, key rate_line: 'Hz' has no group"),
        (("counter_wrap: 65536", "counter_wrap: lots"), "line 4, key counter_wrap: 'lots' is not"),
        (("[Acc_X,", "['{sensor}/X',"), "line 5, key acc.columns.0: '{sensor}/X': {sensor} is"),
        (("sensor_from: file_name", "sensor_from: name"), "line 1, key sensor_from: 'name'"),
    ],
)  # fmt: skip
def test_a_broken_mapping_names_its_line_key_and_cause(tmp_path, run, change, message):
    vendor_txt(tmp_path / "exports" / "P1", "t1", recorded(), {})
    sheets(tmp_path, SEGMENTS, MAPPINGS["vendor_txt"].replace(*change))
    result = run(tmp_path)
    assert result.code == 1 and not result.out.exists()
    assert message in result.err, result.err


def test_lost_packets_are_named_with_their_sizes(tmp_path, run):
    vendor_txt(tmp_path / "exports" / "P1", "t1", recorded(), {}, lose=("S102", 400, 3))
    sheets(tmp_path, SEGMENTS, MAPPINGS["vendor_txt"])
    result = run(tmp_path)
    assert result.code == 1 and not result.out.exists()
    assert "t1_S102.txt (S102): 1 jump(s) of its PacketCounter, 3 sample(s) lost" in result.err
    assert "3 lost after sample 400" in result.err


@pytest.mark.parametrize("declared", [50, 200, 60])
def test_a_rate_given_by_hand_that_does_not_fit_the_recordings_is_refused(tmp_path, run, declared):
    """The recordings are at 100 Hz; their files do not say so (no rate line)."""
    vendor_txt(tmp_path / "exports" / "P1", "t1", recorded(walking_s=20.0), {})
    mapping = MAPPINGS["vendor_txt"].replace(
        "rate_line: 'Acquisition frequency: ([0-9.]+) ?Hz'", f"rate: {declared}"
    )
    trials = "subject\ttrial\ttest\tstatic\tfirst_phase\nP1\tP1/t1\twalk\t2\tgait\n"
    sheets(tmp_path, trials, mapping)
    refused = run(tmp_path)
    assert refused.code == 1 and not refused.out.exists()
    assert f"the rate given by hand, {declared} Hz, does not fit the recordings" in refused.err
    assert "the gyroscope's units" not in refused.err  # a rate off by 2 or 1.7 is the rate
    (tmp_path / "mapping.yaml").write_text(mapping.replace(f"rate: {declared}", "rate: 100"))
    accepted = run(tmp_path)
    assert accepted.code == 0 and "the rate given by hand, 100 Hz, fits the recordings" in (
        accepted.err
    )


def test_a_gyroscope_in_deg_s_declared_rad_s_is_named_as_a_unit_error(tmp_path, run):
    """The rate given by hand is right (100 Hz); the exports hold deg/s where the mapping says
    rad/s: the recordings then imply a rate 57.3 times off, which the refusal names as the
    units' factor."""
    in_deg_s = {s: (acc, np.degrees(gyr)) for s, (acc, gyr) in recorded(walking_s=20.0).items()}
    vendor_txt(tmp_path / "exports" / "P1", "t1", in_deg_s, {})
    mapping = MAPPINGS["vendor_txt"].replace(
        "rate_line: 'Acquisition frequency: ([0-9.]+) ?Hz'", "rate: 100"
    )
    trials = "subject\ttrial\ttest\tstatic\tfirst_phase\nP1\tP1/t1\twalk\t2\tgait\n"
    sheets(tmp_path, trials, mapping)
    refused = run(tmp_path)
    assert refused.code == 1 and not refused.out.exists()
    assert "Or the gyroscope's units:" in refused.err and "57.3" in refused.err, refused.err


def test_an_accelerometer_that_reads_gravity_is_turned_into_specific_force(tmp_path, run):
    """acc_at_rest: down (a phone API's gravity): the dataset holds the specific force, the same
    as the same recording exported the usual way."""
    signals = recorded()
    apdm_csv(tmp_path / "a" / "exports" / "P1", "walk_1", signals)
    apdm_csv(
        tmp_path / "b" / "exports" / "P1", "walk_1", {s: (-a, g) for s, (a, g) in signals.items()}
    )
    trials = "subject\ttrial\ttest\tstatic\tfirst_phase\nP1\tP1/walk_1\twalk\t2\tgait\n"
    sheets(tmp_path / "a", trials, MAPPINGS["apdm_csv"])
    sheets(tmp_path / "b", trials, MAPPINGS["apdm_csv"] + "acc_at_rest: down\n")
    read = []
    for lab in ("a", "b"):
        result = run(tmp_path / lab)
        assert result.code == 0, result.err
        dataset = load_dataset(result.out)
        path = dataset.recordings.query("test == 'standing' and imu == 'shank_r'")["path"].item()
        read.append(dataset.read_recording(path).acc)
    np.testing.assert_allclose(read[0], read[1])
    assert np.median(read[0], axis=0) @ [0, 0, -1.0] > 9  # up: -z of the body frame, z down
