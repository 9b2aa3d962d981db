"""The decision's rules against what is committed: the default tolerance is the configuration's,
the flags that leave a calibration in the choice are those the truths found no worse, every
committed decision table holds to its verdicts, and SUMMARY.md's decision section reads back as
the table it is made from (aceval.evaluation.decision_rules, aceval.report.decisions)."""

import re

import numpy as np
import pandas as pd
import pytest
import yaml

from aceval.calibrate.table import COMPARISON_FLAGS
from aceval.data.contract import R_COLUMNS
from aceval.evaluation.decision import DECISION_COLUMNS
from aceval.evaluation.decision_rules import (
    ADVISORY_FLAGS,
    CARE,
    DEFAULT_TOLERANCE_DEG,
    DEFECT_FLAGS,
    NONE,
    NOT_WITHIN,
    USE,
    VERDICT_KINDS,
)
from aceval.report.decisions import MAX_LISTED, decision_section

from .runner import REPO

#: the committed datasets whose flag_value table is measured against a ground truth
TRUTH_DATASETS = ("kong_sim", "kong_powered", "box_sim", "neura", "gaitmap_feet")


def _committed_datasets() -> list[str]:
    return [
        name
        for config in ("config.yaml", "real.yaml")
        for name in yaml.safe_load((REPO / "config" / config).read_text())["run"]
    ]


def test_the_default_tolerance_is_the_workflows():
    schema = yaml.safe_load((REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())
    assert schema["properties"]["tolerance_deg"]["default"] == DEFAULT_TOLERANCE_DEG
    # a flexion of 60 deg (the knee in swing) about an axis turned by T about the vertical, in
    # flexion-ab/adduction-rotation angles: 4.3 deg of ab/adduction, under McGinley's 5 deg
    from scipy.spatial.transform import Rotation

    turned = Rotation.from_euler("z", DEFAULT_TOLERANCE_DEG, degrees=True)
    knee = turned * Rotation.from_euler("y", 60.0, degrees=True) * turned.inv()
    flexion, abduction, _ = knee.as_euler("YXZ", degrees=True)
    assert abs(abduction) == pytest.approx(4.33, abs=0.01) and abs(abduction) < 5.0
    assert flexion == pytest.approx(59.9, abs=0.1)


def _measured_flags() -> pd.DataFrame:
    """Every flag measured against a truth (not 'too few'), per dataset: its row over all the
    methods that carry it, or its one method's."""
    rows = []
    for dataset in TRUTH_DATASETS:
        table = pd.read_csv(REPO / "results" / dataset / "tables" / "flag_value.csv")
        table = table[(table["reference"] == "truth") & (table["verdict"] != "too few")]
        pooled = table[(table["method"] == "all") | ~table["flag"].duplicated(keep=False)]
        rows.append(pooled.assign(dataset=dataset))
    return pd.concat(rows, ignore_index=True)


def test_the_flags_left_in_the_choice_are_those_no_truth_found_worse():
    measured = _measured_flags()
    worse = (measured["verdict"] == "earns its keep") | (
        measured["median_flagged_deg"] > measured["median_unflagged_deg"]
    )
    judged = set(measured["flag"]) - set(DEFECT_FLAGS) - set(COMPARISON_FLAGS)
    never_worse = judged - set(measured.loc[worse, "flag"])
    assert set(ADVISORY_FLAGS) - set(COMPARISON_FLAGS) == never_worse, measured[
        ["dataset", "flag", "median_flagged_deg", "median_unflagged_deg", "verdict"]
    ]
    assert not set(ADVISORY_FLAGS) & set(DEFECT_FLAGS)


@pytest.mark.parametrize("dataset", _committed_datasets())
def test_every_committed_decision_holds_to_its_verdicts(dataset):
    """No 'use' with a cone beyond T or methods more than T apart, every sensor whose methods
    are more than T apart says so, a chosen rotation exactly where a calibration is chosen."""
    table = pd.read_csv(REPO / "results" / dataset / "tables" / "decision.csv")
    assert list(table.columns) == DECISION_COLUMNS and len(table)
    assert table["verdict_kind"].isin(VERDICT_KINDS).all()
    assert all(v.startswith(k) for v, k in zip(table["verdict"], table["verdict_kind"]))
    t = table["tolerance_deg"]
    use = table["verdict_kind"] == USE
    assert (table.loc[use, "cone_deg"] <= t[use]).all()
    assert (table.loc[use, "n_behind"] >= 2).all()
    assert not (table.loc[use, "methods_range_deg"] > t[use]).any()
    apart = table["methods_range_deg"] > t
    assert table.loc[apart, "verdict"].str.contains("methods disagree").all()
    assert (table.loc[table["cone_deg"] > 2 * t, "verdict_kind"] == NOT_WITHIN).all()
    care = table["verdict_kind"] == CARE
    assert (table.loc[care, "cone_deg"] <= 2 * t[care]).all()
    chosen = table["method"].notna()
    assert (chosen == (table["verdict_kind"] != NONE)).all()
    R = table[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    assert np.isfinite(R[chosen.to_numpy()]).all() and np.isnan(R[~chosen.to_numpy()]).all()
    for rotation in R[chosen.to_numpy()]:
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-9)


def _table(n: int) -> pd.DataFrame:
    """A decision table of n IMUs whose columns all differ (a swapped column reads wrong)."""
    rows = []
    for k in range(n):
        kind = VERDICT_KINDS[k % 4]
        rows.append(
            {
                "subject": f"S{k // 9}",
                "sensor_set": "s",
                "imu": f"IMU{k % 9}",
                "segment": f"seg{k % 9}",
                "method": "kong" if kind != NONE else np.nan,
                "test": "T6" if kind != NONE else np.nan,
                "verdict_kind": kind,
                "tolerance_deg": 5.0,
                "cone_deg": 3.0 + k,
                "methods_spread_deg": 0.5 + k / 10,
                "n_behind": 2 + k % 3,
                "n_unflagged": 1 + k % 2,
                "n_calibrations": 7 + k % 5,
                "basis": "accuracy",
                "runner_up": "triad T6",
                "n_tied": 1 + k % 2,
                "evidence_n": k % 3,
                "evidence_uncertainty_deg": np.inf if k % 3 < 2 else 0.1 * k,
                "margin_deg": 0.25 * k,
                "note": "",
                "verdict": kind + (": reason" if kind != USE else ""),
            }
        )
    return pd.DataFrame(rows)


def test_the_summary_lists_each_sensor_as_the_table_says():
    table = _table(9)
    lines = decision_section({"decision": table})
    assert lines[2].startswith("**Tolerance T = 5 deg**")
    assert "**3 of 9 sensors meet it**" in lines[2]
    assert (
        "3 use, 2 use with care, 2 not within tolerance, 2 no trustworthy calibration" in lines[2]
    )
    rows = [line for line in lines if line.startswith("| S")]
    assert len(rows) == 9
    for line, (_, r) in zip(rows, table.iterrows()):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[:4] == [r["subject"], r["sensor_set"], r["imu"], r["segment"]]
        assert float(cells[5]) == pytest.approx(r["cone_deg"], abs=0.05)
        assert float(cells[6]) == pytest.approx(r["methods_spread_deg"], abs=0.05)
        assert int(cells[7]) == r["n_behind"]
        assert cells[8] == f"{r['n_unflagged']} of {r['n_calibrations']}"
        assert cells[9] == f"triad T6 ({r['margin_deg']:+.1f})" and cells[10] == r["verdict"]


def test_the_summary_counts_the_ties_and_those_without_a_standard_error():
    """'N of M sensors chosen by the tie rule, K of them with evidence from fewer than 2 other
    sensors': K counts the ties whose evidence has no standard error (infinite), not those
    with no evidence at all (the count said 0 beside infinite uncertainties)."""
    table = _table(12)
    text = " ".join(decision_section({"decision": table}))
    chosen = table[table["method"].notna()]
    tied = chosen["n_tied"] > 1
    unmeasured = tied & ~np.isfinite(chosen["evidence_uncertainty_deg"])
    assert 0 < unmeasured.sum() < tied.sum()
    assert (
        f"{tied.sum()} of {len(chosen)} sensors chosen by the tie rule, {unmeasured.sum()} of them "
        "with evidence from fewer than 2 other sensors"
    ) in text


def test_the_summary_by_place_counts_every_subject():
    table = _table(MAX_LISTED + 5)
    lines = decision_section({"decision": table})
    rows = [line for line in lines if line.startswith("| s |")]
    assert len(rows) == 9
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        group = table[table["imu"] == cells[1]]
        assert float(cells[4]) == pytest.approx(group["cone_deg"].median(), abs=0.05)
        assert float(cells[5]) == pytest.approx(group["methods_spread_deg"].median(), abs=0.05)
        n, of = (int(x) for x in re.fullmatch(r"(\d+) of (\d+)", cells[6]).groups())
        assert (n, of) == (group["n_unflagged"].sum(), group["n_calibrations"].sum())
        counts = group["verdict_kind"].value_counts()
        assert cells[7] == ", ".join(f"{counts.get(k, 0)} {k}" for k in VERDICT_KINDS)


def test_the_summary_by_place_names_the_choice_made_most_often_of_its_subjects():
    """Beyond MAX_LISTED IMUs, one row per place: the calibration chosen most often and for how
    many of that place's subjects (not of all IMUs), the median cone (skewed: not the mean); up to
    MAX_LISTED, every IMU; the tie rule's count says how many had no evidence."""
    table = _table(MAX_LISTED + 5)  # 5 subjects of each IMU, one of them without a choice
    triad = ((table.index % 4 == 1) | (table.index % 9 == 0)) & table["method"].notna()
    table.loc[triad, "method"] = "triad"
    table["cone_deg"] = (table.index % 9 + 1.0) ** (1 + table.index // 9)  # 1, 1, 1, 1, 1 ... 9**5
    rows = {
        cells[1]: cells
        for line in decision_section({"decision": table})
        if line.startswith("| s |")
        for cells in [[c.strip() for c in line.strip("|").split("|")]]
    }
    assert rows["IMU0"][3] == "triad T6 (4 of 5 subjects)"  # one of the 5 has no calibration
    assert rows["IMU8"][3] == "kong T6 (3 of 5 subjects)"  # triad 1, none 1
    assert float(rows["IMU2"][4]) == pytest.approx(27.0)  # 3, 9, 27, 81, 243: the mean is 72.6
    assert (
        len(
            [
                line
                for line in decision_section({"decision": _table(MAX_LISTED)})
                if line.startswith("| S")
            ]
        )
        == MAX_LISTED
    )
    # 9 IMUs: 7 chosen, 2 of them tied (k 1 and 5), k 1's evidence without a standard error
    assert (
        "(2 of 7 sensors chosen by the tie rule, 1 of them with evidence from fewer than 2 other "
        "sensors" in "\n".join(decision_section({"decision": _table(9)}))
    )


def test_the_summary_names_the_advisory_flags_and_the_note_beside_the_choice():
    table = _table(2).assign(advisory_flags=["weight_switch;step_frequency_disagrees", ""])
    table["note"] = ["outside its authors' design", ""]
    rows = [line for line in decision_section({"decision": table}) if line.startswith("| S")]
    use = [[c.strip() for c in line.strip("|").split("|")][4] for line in rows]
    assert use == [
        "kong T6 [weight_switch, step_frequency_disagrees] (outside its authors' design)",
        "kong T6",
    ]


def _committed_with_decisions() -> list[str]:
    return sorted(p.parent.parent.name for p in (REPO / "results").glob("*/tables/decision.csv"))


def _section_rows(section: str) -> list[dict]:
    """The decision section's table rows as {header: cell}."""
    lines = [line for line in section.splitlines() if line.startswith("| ")]
    cells = [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines]
    assert all(len(c) == len(cells[0]) for c in cells), "a row's cells do not match its header"
    return [dict(zip(cells[0], row)) for row in cells[1:]]


def _deg_cell(cell: str, value) -> bool:
    """A '-' for NaN, else the number to its 1 decimal."""
    value = float(value)
    return cell == "-" if not np.isfinite(value) else float(cell) == pytest.approx(value, abs=0.051)


def _listed_row_says(shown: dict, r: pd.Series) -> None:
    assert [shown["subject"], shown["set"], shown["IMU"], shown["segment"]] == [
        str(r["subject"]),
        str(r["sensor_set"]),
        str(r["imu"]),
        str(r["segment"]),
    ]
    assert shown["verdict"] == r["verdict"]
    chosen = isinstance(r["method"], str)
    assert shown["use"].startswith(f"{r['method']} {r['test']}") if chosen else shown["use"] == "-"
    assert _deg_cell(shown["uncertainty (deg)"], r["cone_deg"])
    assert _deg_cell(shown["spread (deg)"], r["methods_spread_deg"])
    behind = r["n_behind"]
    assert shown["within T"] == ("-" if not np.isfinite(behind) else str(int(behind)))
    assert shown["kept of N"] == f"{int(r['n_unflagged'])} of {int(r['n_calibrations'])}"
    if isinstance(r["runner_up"], str):
        margin = f"({r['margin_deg']:+.1f})" if np.isfinite(r["margin_deg"]) else "(-)"
        assert shown["runner-up (margin, deg)"] == f"{r['runner_up']} {margin}"
    else:
        assert shown["runner-up (margin, deg)"] == "-"


def _place_row_says(shown: dict, group: pd.DataFrame) -> None:
    chosen = (group["method"].fillna("-") + " " + group["test"].fillna("")).str.strip()
    use = re.fullmatch(r"(.+?) \((\d+) of (\d+) subjects\)( \(.*\))?", shown["use (most often)"])
    assert use, shown["use (most often)"]
    name, count, of = use.group(1), int(use.group(2)), int(use.group(3))
    assert of == len(group) and count == (chosen == name).sum() == chosen.value_counts().max()
    assert _deg_cell(shown["uncertainty, median (deg)"], group["cone_deg"].median())
    assert _deg_cell(shown["spread, median (deg)"], group["methods_spread_deg"].median())
    total = f"{group['n_unflagged'].sum()} of {group['n_calibrations'].sum()}"
    assert shown["kept of N"] == total
    counts = group["verdict_kind"].value_counts()
    assert shown["verdicts"] == ", ".join(f"{counts.get(k, 0)} {k}" for k in VERDICT_KINDS)


@pytest.mark.parametrize("dataset", _committed_with_decisions())
def test_the_committed_summary_says_what_its_decision_table_says(dataset):
    """Every row of SUMMARY.md's decision section read back against decision.csv: per IMU up to
    MAX_LISTED, else per place (the choice made most often and of how many subjects, the
    medians, the sums, the verdicts' counts)."""
    table = pd.read_csv(REPO / "results" / dataset / "tables" / "decision.csv")
    text = (REPO / "results" / dataset / "SUMMARY.md").read_text()
    section = text.split("## Which calibration to use, for each sensor")[1].split("\n## ")[0]
    met = (table["verdict_kind"] == USE).sum()
    t = float(table["tolerance_deg"].iloc[0])
    assert f"**Tolerance T = {t:g} deg**" in section
    assert f"**{met} of {len(table)} sensors meet it**" in section
    rows = _section_rows(section)
    if len(table) <= MAX_LISTED:
        assert len(rows) == len(table)
        for shown, (_, r) in zip(rows, table.iterrows()):
            _listed_row_says(shown, r)
        return
    places = table.groupby(["sensor_set", "imu", "segment"], sort=True)
    assert len(rows) == places.ngroups
    for shown, ((sensor_set, imu, segment), group) in zip(rows, places):
        assert [shown["set"], shown["IMU"], shown["segment"]] == [sensor_set, imu, segment]
        _place_row_says(shown, group)
