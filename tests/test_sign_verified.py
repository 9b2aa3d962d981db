"""The right axis's sign verified by walking alone (no shank, no first phase): a simulated
subject's feet and waist in straight walking, declared as mounted and with the sign flipped.
Every calibration of the declared sign is ``right_axis_sign_verified``; every one of the flipped
sign (all 180 deg off: same flags and cones otherwise) is ``backward``, none verified."""

import shutil

import numpy as np
import pandas as pd
import pytest

from aceval.cli import main

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
    assert set(declared.loc[astray, "imu"]) == {"IMU3"} and (~astray).sum() == 33


def test_walking_catches_the_flipped_sign_of_feet_and_waist(calibrated):
    """The case of a lab's feet declared -y instead of +y with no shank sensors: every
    calibration 180 deg off, caught by ``backward`` (not only unverified)."""
    flipped, declared = calibrated["flipped"], calibrated["declared"]
    assert not flipped["right_axis_sign_verified"].astype(bool).any()
    key = ["imu", "method", "repetitions"]
    both = flipped.merge(declared, on=key, suffixes=("", "_declared"))
    both = both[~both["flag_declared"].str.contains("right_axis_mismatch")]  # astray either way
    assert len(both) == 33 and both["flag"].str.contains("backward").all()
    R = both[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
    R0 = both[[f"r{i}{j}_declared" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
    finite = np.isfinite(R).all(axis=1) & np.isfinite(R0).all(axis=1)
    turned = np.einsum("nij,nkj->nik", R[finite].reshape(-1, 3, 3), R0[finite].reshape(-1, 3, 3))
    angle = np.degrees(np.arccos(np.clip((np.trace(turned, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    assert finite.sum() > 0 and np.allclose(angle, 180.0, atol=0.5)
