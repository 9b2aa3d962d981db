"""SUMMARY.md's first section: for each sensor, the calibration to use, how far off it may be, what
it rests on, and a plain verdict (table ``decision``, :func:`aceval.evaluation.decision.
decision_table`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.evaluation.decision import CONE

#: up to this many IMUs the section lists every one; beyond, one line per sensor place
MAX_LISTED = 40


def _deg(value) -> str:
    return f"{value:.1f}" if isinstance(value, (int, float)) and np.isfinite(value) else "-"


def _verdicts(table: pd.DataFrame) -> str:
    kinds = table["verdict"].fillna("").str.split(":").str[0]
    counts = kinds.value_counts()
    order = ["use", "use with care", "no trustworthy calibration"]
    return ", ".join(f"{counts.get(kind, 0)} {kind}" for kind in order)


def decision_section(tables: dict) -> list[str]:
    """The decision per IMU (every IMU of every subject up to :data:`MAX_LISTED`, else per sensor
    place over the subjects), with what it rests on and the price of the flags ("n unflagged of
    N"); empty without the table.
    """
    table = tables.get("decision")
    if table is None or table.empty:
        return []
    accuracy = table["basis"].fillna("").str.startswith("accuracy").any()
    lines = [
        "## Which calibration to use, for each sensor",
        "",
        f"{len(table)} IMUs: {_verdicts(table)}. Each IMU's calibration is chosen among its "
        "unflagged calibrations from all repetitions (every method, the peers too, every test that "
        "calibrates it) by "
        + (
            "the method and test with the smallest median error to the ground truth on its "
            "segment in this dataset (accuracy)"
            if accuracy
            else "the method and test with the smallest median test-retest angle on its segment "
            "(repeatability only: there is no ground truth here, and a repeatable calibration "
            "can still be wrong)"
        )
        + f". Uncertainty: `{CONE}`; spread: the largest angle to another method's calibration "
        "of the same test; n: unflagged of all its calibrations (table `decision`, every column).",
        "",
    ]
    if len(table) <= MAX_LISTED:
        return lines + _listed(table) + [""]
    return lines + _by_place(table) + [""]


def _listed(table: pd.DataFrame) -> list[str]:
    rows = [
        "| subject | set | IMU | segment | use | uncertainty (deg) | spread (deg) | n | verdict |",
        "|:--|:--|:--|:--|:--|--:|--:|:--|:--|",
    ]
    for _, r in table.iterrows():
        use = f"{r['method']} {r['test']}" if isinstance(r["method"], str) else "-"
        note = f" ({r['note']})" if isinstance(r.get("note"), str) and r["note"] else ""
        rows.append(
            f"| {r['subject']} | {r['sensor_set']} | {r['imu']} | {r['segment']} | {use}{note} | "
            f"{_deg(r[CONE])} | {_deg(r['methods_spread_deg'])} | "
            f"{int(r['n_unflagged'])} of {int(r['n_calibrations'])} | {r['verdict']} |"
        )
    return rows


def _by_place(table: pd.DataFrame) -> list[str]:
    rows = [
        "| set | IMU | segment | use (most often) | uncertainty, median (deg) | spread, median "
        "(deg) | n unflagged of N | verdicts |",
        "|:--|:--|:--|:--|--:|--:|:--|:--|",
    ]
    for (sensor_set, imu, segment), group in table.groupby(
        ["sensor_set", "imu", "segment"], sort=True
    ):
        chosen = (group["method"].fillna("-") + " " + group["test"].fillna("")).str.strip()
        top = chosen.value_counts()
        use = f"{top.index[0]} ({top.iloc[0]} of {len(group)} subjects)"
        notes = group["note"].dropna().astype(str)
        use += " (a peer outside its authors' design)" if (notes != "").any() else ""
        rows.append(
            f"| {sensor_set} | {imu} | {segment} | {use} | {_deg(group[CONE].median())} | "
            f"{_deg(group['methods_spread_deg'].median())} | "
            f"{int(group['n_unflagged'].sum())} of {int(group['n_calibrations'].sum())} | "
            f"{_verdicts(group)} |"
        )
    return rows
