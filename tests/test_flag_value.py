"""What each flag is worth (aceval.evaluation.flag_value): its numbers recomputed by hand."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aceval.data.contract import R_COLUMNS
from aceval.evaluation.flag_value import consensus_distance_deg, flag_value_table

R_TRUE = Rotation.from_euler("zyx", [30, 10, -20], degrees=True).as_matrix()


def _turned(deg):
    return Rotation.from_euler("z", deg, degrees=True).as_matrix() @ R_TRUE


def _row(subject, method, heading_deg, flag="", error=np.nan):
    R = _turned(heading_deg)
    return {
        "subject": subject,
        "sensor_set": "main",
        "imu": "IMU1",
        "segment": "foot",
        "test": "T6",
        "repetitions": "R1+R2+R3",
        "n_reps": 3,
        "method": method,
        **dict(zip(R_COLUMNS, R.ravel())),
        "flag": flag,
        "error_deg": error,
    }


def test_the_consensus_is_the_other_methods_unflagged_mean():
    rows = pd.DataFrame(
        [
            _row("S1", "kong", 10.0),
            _row("S1", "ricci_lm", 2.0),
            _row("S1", "triad", -2.0),
            _row("S1", "combined", 40.0, "not_planar"),  # flagged: in no one's consensus
        ]
    )
    distance = consensus_distance_deg(rows)
    assert distance[0] == pytest.approx(10.0, abs=1e-6)  # the mean of +2 and -2 is 0
    assert distance[1] == pytest.approx(2.0, abs=0.05)  # 2 against the mean of 10 and -2
    assert distance[3] == pytest.approx(40.0 - 10.0 / 3, abs=0.01)  # mean of 10, 2, -2


def test_a_flag_that_removes_worse_calibrations_earns_its_keep_against_the_truth():
    rows = []
    for k in range(6):
        rows.append(_row(f"S{k}", "kong", 0.0, "", error=1.0 + 0.1 * k))
        rows.append(_row(f"S{k}", "kong", 0.0, "", error=1.5))
    for k in range(4):  # flagged and 20 deg off
        rows.append(_row(f"F{k}", "kong", 0.0, "not_planar", error=20.0 + k))
    rows.append(_row("G0", "kong", 0.0, "not_planar;backward", error=90.0))
    rows.append(_row("G1", "qmt_hinge", np.nan, "not_applicable"))
    table = flag_value_table(pd.DataFrame(rows)).set_index("flag")
    assert "not_applicable" not in table.index  # no calibration: not judged
    row = table.loc["not_planar"]
    assert row["reference"] == "truth" and row["n_calibrations"] == 17
    assert row["n_flagged"] == 5 and row["n_only_this_flag"] == 4
    assert row["median_flagged_deg"] == pytest.approx(22.0)  # 20, 21, 22, 23, 90
    assert row["median_only_this_flag_deg"] == pytest.approx(21.5)
    assert row["median_unflagged_deg"] == pytest.approx(1.5)
    assert row["verdict"] == "earns its keep" and row["p_value"] < 0.05
    assert table.loc["backward", "verdict"] == "too few"  # one flagged distance


def test_a_flag_on_calibrations_as_good_as_the_others_is_not_measurably_worse():
    rows = []
    for k in range(8):  # without a truth: against the other methods' consensus
        flag = "not_planar" if k % 2 else ""
        rows += [
            _row(f"S{k}", "kong", 3.0 if k % 4 < 2 else -3.0, flag),
            _row(f"S{k}", "ricci_lm", 0.0),
            _row(f"S{k}", "triad", 0.0),
        ]
    table = flag_value_table(pd.DataFrame(rows)).set_index("flag")
    row = table.loc["not_planar"]
    assert row["reference"] == "consensus of the other methods"
    assert row["method"] == "kong" and row["n_calibrations"] == 8 and row["n_flagged"] == 4
    assert row["median_flagged_deg"] == pytest.approx(3.0, abs=1e-6)
    assert row["median_unflagged_deg"] == pytest.approx(3.0, abs=1e-6)
    assert row["verdict"] == "not measurably worse"


def test_the_unflagged_carry_no_other_flag_and_all_is_over_the_methods_that_carry_it():
    """Another flag's rows (backward, 40-43 deg) are not 'unflagged' for not_planar; a comparison
    flag (methods_disagree) is, except when it is the flag judged; 'all' pools the methods that
    carry the flag (kong, ricci_lm), not triad."""
    rows = [_row(f"K{k}", "kong", 0.0, "", error=1.0 + 0.1 * k) for k in range(6)]
    rows += [_row(f"P{k}", "kong", 0.0, "not_planar", error=20.0 + k) for k in range(4)]
    rows += [_row(f"B{k}", "kong", 0.0, "backward", error=40.0 + k) for k in range(4)]
    rows += [
        _row("M0", "kong", 0.0, "not_planar;methods_disagree", error=24.0),
        _row("M1", "kong", 0.0, "methods_disagree", error=1.6),
        _row("R0", "ricci_lm", 0.0, "not_planar", error=30.0),
        _row("R1", "ricci_lm", 0.0, "", error=2.0),
    ]
    rows += [_row(f"T{k}", "triad", 0.0, "", error=50.0 + k) for k in range(3)]
    table = flag_value_table(pd.DataFrame(rows)).set_index(["flag", "method"])
    kong = table.loc[("not_planar", "kong")]
    assert kong["n_flagged"] == 5 and kong["n_only_this_flag"] == 5  # with methods_disagree too
    assert kong["median_unflagged_deg"] == pytest.approx(1.3)  # 1.0-1.6: not backward's 40-43
    both = table.loc[("not_planar", "all")]
    assert both["n_calibrations"] == 18 and both["n_flagged"] == 6
    assert both["median_unflagged_deg"] == pytest.approx(1.35)  # 1.0-1.6 and 2.0
    judged = table.loc[("methods_disagree", "kong")]
    assert judged["n_flagged"] == 2 and judged["median_unflagged_deg"] == pytest.approx(1.25)
    assert ("methods_disagree", "all") not in table.index  # one method carries it


def test_earning_its_keep_is_a_one_sided_p_below_0_05_from_three_distances_each():
    """Exact Mann-Whitney: 3 flagged above 3 unflagged, p = 1 / C(6, 3) = 0.05, not below;
    4 above 3, p = 1 / C(7, 3) = 0.029 one-sided (0.057 two-sided)."""

    def judged(n_flagged):
        rows = [_row(f"S{k}", "kong", 0.0, "", error=1.0 + k) for k in range(3)]
        rows += [_row(f"F{k}", "kong", 0.0, "not_planar", error=10.0 + k) for k in range(n_flagged)]
        return flag_value_table(pd.DataFrame(rows)).set_index("flag").loc["not_planar"]

    three = judged(3)
    assert three["p_value"] == pytest.approx(0.05) and three["verdict"] == "not measurably worse"
    four = judged(4)
    assert four["p_value"] == pytest.approx(1 / 35) and four["verdict"] == "earns its keep"
    assert judged(2)["verdict"] == "too few"
