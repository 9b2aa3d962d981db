"""The right axis's sign verified by walking alone (no shank, no first phase): a simulated
subject's feet and waist in straight walking, declared as mounted and with the sign flipped.
Every calibration of the declared sign is ``right_axis_sign_verified``; every one of the flipped
sign (all 180 deg off: same flags and cones otherwise) is ``backward``, none verified."""

import shutil

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.cli import main
from aceval.data.contract import R_COLUMNS

IMUS = ("IMU3", "IMU6", "IMU9")  # the frontal set's waist and feet


def walking_only(full, root, flip: bool):
    """``full``'s frontal feet and waist, quiet standing and walking only (every IMU calibrated
    by walking), their right axes as mounted or negated."""
    root.mkdir()
    for name in ("dataset.yaml", "tests.tsv", "subjects.tsv"):
        shutil.copy(full / name, root / name)
    (root / "data").symlink_to(full / "data")
    imus = pd.read_csv(full / "imus.tsv", sep="\t", dtype=str)
    imus = imus[imus["imu"].isin(IMUS) & (imus["sensor_set"] == "frontal")]
    if flip:
        imus["right_axis"] = imus["right_axis"].map({"-y": "+y", "+y": "-y"})
    imus.to_csv(root / "imus.tsv", sep="\t", index=False)
    recordings = pd.read_csv(full / "recordings.tsv", sep="\t", dtype=str)
    keep = recordings["imu"].isin(IMUS) & (recordings["sensor_set"] == "frontal")
    recordings[keep & recordings["test"].isin(["T0", "T6"])].to_csv(
        root / "recordings.tsv", sep="\t", index=False
    )
    (root / "calibrates.tsv").write_text("test\timu\n" + "".join(f"T6\t{i}\n" for i in IMUS))
    yaml = (root / "dataset.yaml").read_text().replace("- lateral\n", "")
    (root / "dataset.yaml").write_text(yaml)
    return root


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("walking")
    full = tmp / "sim"
    argv = ["simulate", "kong", "--out", str(full), "--subjects", "1", "--repetitions", "3"]
    assert main([*argv, "--seed", "5"]) == 0
    out = {}
    for flip in (False, True):
        root = walking_only(full, tmp / ("flipped" if flip else "declared"), flip)
        csv = tmp / f"{root.name}.csv"
        assert main(["calibrate", str(root), "--out", str(csv)]) == 0
        out[root.name] = pd.read_csv(csv, keep_default_na=False)
    return out


def test_walking_verifies_the_declared_sign_of_feet_and_waist(calibrated):
    """Verified wherever the calibration's y is the declared axis; the axis methods' waist in
    walking (their gyroscope axis is no medial-lateral axis there: ``low_rho``) turns y away from
    it (``right_axis_mismatch``), and the pendulum calls those calibrations backward too."""
    declared = calibrated["declared"]
    assert set(declared["imu"]) == set(IMUS)
    astray = declared["flag"].str.contains("right_axis_mismatch")
    assert (declared["right_axis_sign_verified"].astype(bool) == ~astray).all()
    assert (declared["flag"].str.contains("backward") == astray).all()
    # astray: the waist only, at most one calibration of each method (any method of the registry)
    assert set(declared.loc[astray, "imu"]) == {"IMU3"}
    assert astray.sum() <= declared["method"].nunique() and (~astray).sum() > 0


def test_walking_catches_the_flipped_sign_of_feet_and_waist(calibrated):
    """The case of a lab's feet declared -y instead of +y with no shank sensors: every
    calibration 180 deg off, caught by ``backward`` (not only unverified)."""
    flipped, declared = calibrated["flipped"], calibrated["declared"]
    assert not flipped["right_axis_sign_verified"].astype(bool).any()
    key = ["imu", "method", "repetitions"]
    both = flipped.merge(declared, on=key, suffixes=("", "_declared"))
    astray = both["flag_declared"].str.contains("right_axis_mismatch")  # astray either way
    assert len(both) == len(declared) == len(flipped)  # the same calibrations, turned
    both = both[~astray]
    assert len(both) and both["flag"].str.contains("backward").all()
    R = both[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
    R0 = both[[f"r{i}{j}_declared" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
    finite = np.isfinite(R).all(axis=1) & np.isfinite(R0).all(axis=1)
    turned = np.einsum("nij,nkj->nik", R[finite].reshape(-1, 3, 3), R0[finite].reshape(-1, 3, 3))
    angle = np.degrees(np.arccos(np.clip((np.trace(turned, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    assert finite.sum() > 0 and np.allclose(angle, 180.0, atol=0.5)


def test_a_walking_cue_votes_as_a_first_phase_and_verifies_only_a_declared_y():
    """direction_checks by hand: a foot's and a trunk's right directions vote like a +y first
    phase (45 deg to vote); verified where they agree and y is within 60 deg of the declared
    axis; a shank is judged by its swing, not by them."""
    from aceval.signals.checks import direction_checks

    right = np.array([0.0, 1.0, 0.0])
    turned = Rotation.from_euler("z", 180, degrees=True).as_matrix()  # y -> -y
    R = np.stack([np.eye(3), turned, np.eye(3), np.eye(3)])
    gait = np.array([[right, right], [right, right], [right, -right], [[0.0, 0.7, 0.71]] * 2])
    found = direction_checks(
        np.array(["gait"] * 4, dtype=object),
        np.array(["foot", "foot", "waist", "head"], dtype=object),
        np.full((4, 2, 3), np.nan),
        None,
        np.ones((4, 2)),
        R,
        np.tile(right, (4, 1)),
        gait_axes=gait,
    )
    assert found["flag"].tolist() == ["", "backward;right_axis_mismatch", "", ""]
    assert found["first_phase_agreement"].tolist()[:3] == [1.0, 0.0, 0.5]
    assert np.isnan(found["first_phase_agreement"][3])  # 45 deg off: no vote
    assert found["sign_verified"].tolist() == [True, False, False, False]
    shank = direction_checks(
        np.array(["gait"], dtype=object), np.array(["shank"], dtype=object),
        np.full((1, 2, 3), np.nan), None, np.ones((1, 2)), R[:1], right[None],
        gait_axes=-gait[:1],
    )  # fmt: skip
    assert np.isnan(shank["first_phase_agreement"][0]) and not shank["sign_verified"][0]


def test_a_verified_sign_carries_to_the_tests_of_the_imu_that_cannot_tell():
    """A thigh verified by its sit-to-stand (first phase) is verified in walking (unjudged) too,
    within 90 deg; not where the IMU has a backward calibration, nor a row 120 deg away."""
    from aceval.calibrate.pipeline import propagate_verified

    far = Rotation.from_euler("x", 120, degrees=True).as_matrix()
    rows = []
    for test, agreement, sure, R, method in (
        ("T3", 1.0, True, np.eye(3), "kong"),
        ("T6", np.nan, False, np.eye(3), "kong"),
        ("T6", np.nan, False, far, "triad"),
    ):
        rows.append({"subject": "S1", "sensor_set": "main", "imu": "thigh_r", "test": test,
                     "repetitions": "R1+R2", "n_reps": 2, "method": method, "flag": "",
                     "first_phase_agreement": agreement, "right_axis_sign_verified": sure,
                     **dict(zip(R_COLUMNS, R.ravel()))})  # fmt: skip
    table = pd.DataFrame(rows)
    assert propagate_verified(table)["right_axis_sign_verified"].tolist() == [True, True, False]
    backward = pd.concat(
        [table, table.iloc[:1].assign(test="T5", flag="backward", right_axis_sign_verified=False)],
        ignore_index=True,
    )
    assert propagate_verified(backward)["right_axis_sign_verified"].tolist() == [
        True, False, False, False
    ]  # fmt: skip
