"""The peers' file interface (workflow/peers/peer_io.py, which needs NumPy only): the frame it
builds from a peer's vertical and medial-lateral axis."""

import sys

import numpy as np
import pytest

from .runner import REPO

sys.path.insert(0, str(REPO / "workflow" / "peers"))
from peer_io import frame_from_axes  # noqa: E402


def test_an_axis_near_vertical_is_signed_by_its_horizontal_part():
    """A tilted sensor (its declared right axis has a vertical part) and a hinge axis 11 deg from
    the vertical whose raw vector points slightly right while its horizontal part points left:
    the frame's y must point right (before the fix it pointed left, 180 deg off)."""
    down = np.array([0.0, 0.3, 1.0])
    down /= np.linalg.norm(down)
    declared = np.array([0.0, 1.0, 0.0])
    right = declared - (declared @ down) * down
    right /= np.linalg.norm(right)
    axis = down - 0.2 * right  # near the vertical, its horizontal part to the left
    assert axis @ declared > 0 and (axis - (axis @ down) * down) @ right < 0
    R = frame_from_axes(down, axis, declared)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(R), 1.0)
    np.testing.assert_allclose(R[2], down)
    np.testing.assert_allclose(R[1], right, atol=1e-12)
    # and an axis with no vertical part gives the same frame whichever sign it comes with
    np.testing.assert_allclose(frame_from_axes(down, -right, declared), R, atol=1e-12)


def test_peer_rows_pass_the_same_rotation_gate_as_acevals():
    """Issue 32: a peer's calibration whose body y is 90 deg from the declared right axis is
    flagged right_axis_mismatch (and leaves the medians), as aceval's own would be; one within
    60 deg is not, and a peer's own flag is kept beside it."""
    import numpy as np
    import pandas as pd
    from scipy.spatial.transform import Rotation

    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.peer_gates import axis_gates

    turned = Rotation.from_euler("z", 90, degrees=True).as_matrix()  # body y -> sensor -x
    rows = pd.DataFrame(
        [
            {"sensor_set": "s", "imu": "A", "flag": "", **dict(zip(R_COLUMNS, np.eye(3).ravel()))},
            {"sensor_set": "s", "imu": "A", "flag": "", **dict(zip(R_COLUMNS, turned.ravel()))},
            {"sensor_set": "s", "imu": "A", "flag": "not_applicable",
             **dict(zip(R_COLUMNS, np.full(9, np.nan)))},
        ]
    )  # fmt: skip
    gated = axis_gates(rows, lambda sensor_set, imu: "+y")
    assert gated["flag"].tolist() == ["", "right_axis_mismatch", "not_applicable"]
    assert gated["right_axis_angle_deg"].iloc[:2].round(6).tolist() == [0.0, 90.0]
    # the peer's own axis 20 deg from the vertical (body z = sensor z here), or a PCA whose two
    # variances are nearly equal: flagged as aceval's axis methods and Kong's plane would be
    tilted = np.array([0.0, np.sin(np.radians(20)), np.cos(np.radians(20))])
    axes = pd.DataFrame([
        {**rows.iloc[0].to_dict(), "axis_x": 0.0, "axis_y": 1.0, "axis_z": 0.0, "axis_variance_ratio": 0.1},
        {**rows.iloc[0].to_dict(), **dict(zip(["axis_x", "axis_y", "axis_z"], tilted))},
        {**rows.iloc[0].to_dict(), "axis_x": 0.0, "axis_y": 1.0, "axis_z": 0.0, "axis_variance_ratio": 0.8},
    ])  # fmt: skip
    gated = axis_gates(axes, lambda sensor_set, imu: "+y")
    assert gated["flag"].tolist() == ["", "axis_near_vertical", "axis_undetermined"]
    assert gated["axis_vertical_angle_deg"].round(6).tolist()[:2] == [90.0, 20.0]


def test_methods_are_compared_on_the_cells_they_share():
    """Issue 32: a method present on few cells (qmt's hinge: thighs and shanks) is compared with
    the others on those cells only, with the count; each method's own median keeps its count."""
    import pandas as pd

    from aceval.report.methods_section import _shared_cells_line, methods_section

    rows = [
        ("chest", "T1", "kong", 2.0), ("chest", "T1", "triad", 3.0),
        ("thigh", "T5", "kong", 4.0), ("thigh", "T5", "triad", 5.0), ("thigh", "T5", "qmt", 4.5),
        ("shank", "T5", "kong", 6.0), ("shank", "T5", "triad", 1.0), ("shank", "T5", "qmt", 7.0),
    ]  # fmt: skip
    methods = pd.DataFrame(rows, columns=["segment", "test", "method", "median"]).assign(
        sensor_set="s"
    )
    line = _shared_cells_line(methods, ["kong", "triad", "qmt"])
    assert (
        line.startswith("On the 2 cell(s)") and "kong 5.00 deg" in line and "qmt 5.75 deg" in line
    )
    best = methods.assign(
        best_test=methods["test"], best_median_deg=methods["median"], kong_recommends=""
    )
    text = "\n".join(methods_section({"methods": methods, "methods_best": best}))
    assert "kong 4.00 deg (3 cells)" in text and "qmt 5.75 deg (2 cells)" in text
    assert "outside their authors' design" not in text  # no gaitmap or OpenSense rows here
    gaitmap = pd.concat([methods, methods.assign(method="gaitmap_pca")])
    text = "\n".join(methods_section({"methods": gaitmap, "methods_best": best}))
    assert "its rows on chest, shank, thigh are outside that design" in text


def test_qmt_is_flagged_where_the_knee_barely_flexes():
    """Issue 32: qmt's hinge axis needs the knee to flex; the flexion range is read from the two
    gyroscopes about the estimated axes, whatever sign the estimate gave each axis."""
    import types

    sys.modules.setdefault("qmt", types.ModuleType("qmt"))  # the estimator itself is not called
    from qmt_hinge import MIN_KNEE_RANGE_DEG, knee_range_deg

    fs = 100.0
    t = np.arange(0, 4, 1 / fs)
    swing = np.radians(35) * 2 * np.pi * 0.5 * np.cos(2 * np.pi * 0.5 * t)  # leg, rad/s about y
    for flexion_deg, flexed in ((60.0, True), (12.0, False)):
        knee = np.radians(flexion_deg / 2) * 2 * np.pi * 0.5 * np.cos(2 * np.pi * 0.5 * t)
        thigh = np.column_stack([0 * t, swing, 0 * t])
        shank = np.column_stack([0 * t, swing + knee, 0 * t])
        for sign in (1.0, -1.0):  # the estimate's sign of the shank axis
            found = knee_range_deg(thigh, shank, [0, 1, 0], [0, sign, 0], fs)
            assert found == pytest.approx(flexion_deg, rel=0.02)
            assert (found >= MIN_KNEE_RANGE_DEG) == flexed


def test_the_peers_read_the_samples_acevals_methods_read(clean, tmp_path):
    """Issue 32, point 6: the plan gives each motion file's kept ranges (Kong's movement windows,
    clipped samples left out); the samples a peer reads through them are exactly those behind
    aceval's scatter (their count and their scatter sum_k a_k a_k^T)."""
    import pandas as pd
    from peer_io import kept_samples, read_plan, read_recording

    from .runner import aceval

    summaries, plan_path = tmp_path / "recordings.csv", tmp_path / "plan.json"
    outputs = ["--recordings-out", summaries, "--plan-out", plan_path]
    done = aceval("calibrate", clean.small(), "--out", tmp_path / "cal.csv", *outputs)
    assert done.code == 0, done.err[-3000:]
    plan, rows = read_plan(str(plan_path)), pd.read_csv(summaries).set_index(["imu", "test", "rep"])
    checked = 0
    for entry in plan["calibrations"]:
        for rep, path in entry["reps"].items():
            acc, _ = read_recording(plan, path)
            kept = kept_samples(entry, rep)
            summary = rows.loc[(entry["imu"], entry["test"], int(rep))]
            assert len(kept) == summary["n_samples"] < len(acc)
            scatter = (acc[kept].T @ acc[kept]).ravel()
            expected = summary[[f"s{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float)
            np.testing.assert_allclose(scatter, expected, rtol=1e-6)
            checked += 1
    assert checked >= 9


def test_a_peer_row_meets_the_sensor_flags_direction_vote_rho_and_stability_of_its_unit():
    """Issue 39: a peer's rows get what aceval measured about the same recordings: the sensor's
    flags in that test, the unit's gyroscope rho where the peer reports no eigenvalue ratio, the
    direction vote of the repetitions it is made from, and 'unstable' for a subset far from its
    own calibration from all repetitions."""
    import numpy as np
    import pandas as pd
    from scipy.spatial.transform import Rotation

    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.peer_gates import gate_peers
    from aceval.methods.moments import PHASE_COLUMNS

    key = {"subject": "S1", "sensor_set": "s", "imu": "A", "segment": "thigh", "side": "right"}
    eye = dict(zip(R_COLUMNS, np.eye(3).ravel()))
    far = dict(zip(R_COLUMNS, Rotation.from_euler("z", 12, degrees=True).as_matrix().ravel()))
    back = dict(zip(R_COLUMNS, Rotation.from_euler("z", 180, degrees=True).as_matrix().ravel()))

    def peer(test, repetitions, n_reps, rotation):
        return {
            **key,
            "test": test,
            "repetitions": repetitions,
            "n_reps": n_reps,
            "method": "qmt_hinge",
            "flag": "",
            **rotation,
        }

    peers = pd.DataFrame(
        [
            peer("T5", "R1+R2+R3", 3, eye),  # its unit's sensor flag, rho fine
            peer("T5", "R1+R2", 2, far),  # 12 deg from its full set: unstable
            peer("T6", "R1+R2+R3", 3, eye),  # the unit's rho is 0.3: undetermined
            peer("T1", "R1+R2+R3", 3, back),  # turned 180 deg about z: backward
        ]
    )
    own = pd.DataFrame(
        [
            {
                **key,
                "test": "T5",
                "repetitions": "R1+R2+R3",
                "n_reps": 3,
                "method": "kong",
                "rho_motion": 0.8,
                "sensor_flag": "static_not_standing",
            },
            {
                **key,
                "test": "T6",
                "repetitions": "R1+R2+R3",
                "n_reps": 3,
                "method": "kong",
                "rho_motion": 0.3,
                "sensor_flag": "",
            },
            {
                **key,
                "test": "T1",
                "repetitions": "R1+R2+R3",
                "n_reps": 3,
                "method": "kong",
                "rho_motion": 0.9,
                "sensor_flag": "",
            },
        ]
    )
    # T1's first phase is about -y (flexion): each repetition's own axis, signed by its first
    # phase, is -y in the sensor frame; the 180-deg calibration maps the body's y onto -y
    recordings = pd.DataFrame(
        [
            {
                **key,
                "test": "T1",
                "rep": rep,
                "kind": "motion",
                "flag": "",
                **dict(zip(PHASE_COLUMNS, [0.0, -1.0, 0.0])),
            }
            for rep in (1, 2, 3)
        ]
    )
    gated = gate_peers(peers, lambda s, i: "+y", own, recordings, {"T1": "-y"}.get, 3)
    flags = [set(f.split(";")) - {""} for f in gated["flag"]]
    assert flags[0] == {"static_not_standing"}
    assert flags[1] == {"static_not_standing", "unstable"}
    assert gated["full_set_angle_deg"].iloc[1] == pytest.approx(12.0)
    assert "axis_undetermined" in flags[2]
    assert "backward" in flags[3] and gated["first_phase_agreement"].iloc[3] == 0.0
    # the same calibration not turned agrees with every repetition: no flag
    unturned = gate_peers(
        peers.iloc[[0]].assign(test="T1"), lambda s, i: "+y", own, recordings, {"T1": "-y"}.get, 3
    )
    assert unturned["flag"].iloc[0] == "" and unturned["first_phase_agreement"].iloc[0] == 1.0


def test_opensense_says_the_static_pose_lacks_orientations_when_the_motion_has_them(
    tmp_path, request
):
    """Walking with the vendor's orientations but no quiet standing (the static test is the
    mean walking posture): OpenSense is not applicable because the static pose has none, not
    because the recordings have none; without any orientation it says that instead."""
    import json
    import subprocess

    from .test_peer_equivariance import peer_python

    python = peer_python("opensim", request)
    header = "t,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"
    (tmp_path / "static.csv").write_text(header + "\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n")
    (tmp_path / "walk.csv").write_text(
        header
        + ",quat_w,quat_x,quat_y,quat_z\n0,0,0,9.8,0,0,0,1,0,0,0\n0.01,0,0,9.8,0,0,0,1,0,0,0\n"
    )
    imu = {"subject": "P1", "sensor_set": "main", "imu": "pelvis", "segment": "waist",
           "side": "center", "right_axis": [0, 1, 0]}  # fmt: skip
    plan = {"dataset": str(tmp_path), "fs_hz": 100.0, "acc_scale": 1.0, "gyr_scale": 1.0,
            "static": [{**imu, "test": "walking_vertical", "paths": ["static.csv"]}],
            "calibrations": [{**imu, "test": "walk", "static": ["static.csv"],
                              "reps": {"1": "walk.csv"}, "kept": {}, "subsets": [[1]]}]}  # fmt: skip
    notes = []
    for motion in ("walk.csv", "static.csv"):
        plan["calibrations"][0]["reps"]["1"] = motion
        (tmp_path / "plan.json").write_text(json.dumps(plan))
        code = (
            f"import json, sys; sys.path.insert(0, {str(REPO / 'workflow' / 'peers')!r}); "
            "import opensense_imuplacer as o; "
            f"print(json.dumps(o.calibrate(json.load(open({str(tmp_path / 'plan.json')!r})))))"
        )
        rows = json.loads(subprocess.run([str(python), "-c", code], check=True,
                                         capture_output=True, text=True).stdout)  # fmt: skip
        assert [r["flag"] for r in rows] == ["not_applicable"]
        notes.append(rows[0]["note"])
    assert "in this subject's motion recordings but not in its static recordings" in notes[0]
    assert "walking_vertical" in notes[0]
    assert "this dataset's recordings have none" in notes[1]


def test_the_gates_read_the_body_axes_as_rows_of_the_sensor_to_body_rotation():
    """A mounting with no symmetry (body x = sensor z, body y = sensor x, body z = sensor y):
    its rows are the body axes in the sensor frame, its columns are not. Declared right '+x'
    and a peer axis along sensor x pass every gate; read as columns (the transpose), the right
    axis would be sensor z (90 deg off) and the vertical sensor x, the axis itself."""
    import pandas as pd

    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.peer_gates import axis_gates

    R = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # sensor -> body
    assert np.isclose(np.linalg.det(R), 1.0) and not np.allclose(R, R.T)
    row = {"sensor_set": "s", "imu": "A", "flag": "", **dict(zip(R_COLUMNS, R.ravel()))}
    row |= {"axis_x": 1.0, "axis_y": 0.0, "axis_z": 0.0, "axis_variance_ratio": 0.1}
    gated = axis_gates(pd.DataFrame([row]), lambda sensor_set, imu: "+x")
    assert gated["flag"].tolist() == [""]
    assert gated["right_axis_angle_deg"].round(6).tolist() == [0.0]
    assert gated["axis_vertical_angle_deg"].round(6).tolist() == [90.0]
    wrong = axis_gates(pd.DataFrame([row]), lambda sensor_set, imu: "+z")  # the column's axis
    assert wrong["flag"].tolist() == ["right_axis_mismatch"]


def test_the_direction_vote_reads_the_body_y_row_of_an_asymmetric_calibration():
    """body x = sensor z, body y = sensor x, body z = sensor y: the body's y is the sensor's x (the
    rotation's row), not its z (the column). A repetition whose first phase about -y turns about
    sensor -x agrees with it; one about sensor +x says it is backward; read as the column, neither
    would vote."""
    import numpy as np
    import pandas as pd

    from aceval.calibrate.table import SIGN_VERIFIED
    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.peer_gates import direction_gates
    from aceval.methods.moments import PHASE_COLUMNS

    R = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # sensor -> body
    key = {"subject": "S1", "sensor_set": "s", "imu": "A", "segment": "thigh", "test": "T1"}
    peer = {**key, "repetitions": "R1+R2", "n_reps": 2, "method": "qmt_hinge", "flag": ""}
    peers = pd.DataFrame([{**peer, **dict(zip(R_COLUMNS, R.ravel()))}])

    def voted(axis):
        recordings = pd.DataFrame(
            [
                {**key, "rep": rep, "kind": "motion", "flag": "", **dict(zip(PHASE_COLUMNS, axis))}
                for rep in (1, 2)
            ]
        )
        return direction_gates(peers, recordings, lambda s, i: "+x", {"T1": "-y"}.get).iloc[0]

    agrees = voted([-1.0, 0.0, 0.0])
    assert agrees["flag"] == "" and agrees["first_phase_agreement"] == 1.0
    assert bool(agrees[SIGN_VERIFIED])
    backward = voted([1.0, 0.0, 0.0])
    assert backward["flag"] == "backward" and backward["first_phase_agreement"] == 0.0


def test_a_peers_full_calibration_is_unstable_when_most_of_its_retest_subsets_are_not_half():
    import pandas as pd
    from scipy.spatial.transform import Rotation

    from aceval.data.contract import R_COLUMNS
    from aceval.evaluation.peer_gates import unstable_gates

    key = {"subject": "S1", "sensor_set": "s", "imu": "A", "test": "T5", "method": "qmt_hinge"}

    def row(repetitions, deg):
        R = Rotation.from_euler("z", deg, degrees=True).as_matrix()
        n = repetitions.count("+") + 1
        return {
            **key,
            "repetitions": repetitions,
            "n_reps": n,
            "flag": "",
            **dict(zip(R_COLUMNS, R.ravel())),
        }

    def full_flag(*subsets):
        peers = pd.DataFrame([row("R1+R2+R3+R4", 0.0), *(row(r, d) for r, d in subsets)])
        return unstable_gates(peers, 2)["flag"].tolist()

    # one of two subsets of 2 repetitions 12 deg away: half, not most
    assert full_flag(("R1+R2", 12.0), ("R3+R4", 1.0)) == ["", "unstable", ""]
    assert full_flag(("R1+R2", 12.0), ("R3+R4", 14.0), ("R1+R3", 1.0))[0] == "unstable"
