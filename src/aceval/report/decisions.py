"""SUMMARY.md's first section: the tolerance and how many sensors meet it, then for each sensor the
calibration to use, how far off it may be, what it rests on and a verdict (table ``decision``,
:func:`aceval.evaluation.decision.decision_table`). It is SUMMARY.md's one answer per sensor.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.evaluation.decision import CONE
from aceval.evaluation.decision_rules import (
    ADVISORY_FLAGS,
    DEFAULT_TOLERANCE_DEG,
    USE,
    VERDICT_KINDS,
)

#: up to this many IMUs the section lists every one; beyond, one line per sensor place
MAX_LISTED = 40


def _deg(value) -> str:
    return f"{value:.1f}" if isinstance(value, (int, float)) and np.isfinite(value) else "-"


def verdict_counts(kinds: pd.Series) -> str:
    """'2 use, 1 use with care, 0 not within tolerance, 0 no trustworthy calibration' (a
    ``verdict_kind`` column).
    """
    counts = kinds.value_counts()
    return ", ".join(f"{counts.get(kind, 0)} {kind}" for kind in VERDICT_KINDS)


def _tolerance(table: pd.DataFrame) -> float:
    values = table["tolerance_deg"].dropna().unique() if "tolerance_deg" in table else []
    return float(values[0]) if len(values) else DEFAULT_TOLERANCE_DEG


def _first_lines(table: pd.DataFrame) -> list[str]:
    """The tolerance, how many sensors meet it, and what each verdict means."""
    t = _tolerance(table)
    met = int((table["verdict_kind"] == USE).sum())
    default = (
        "the default: 5 deg of heading error puts 4.3 deg of false varus-valgus into a knee "
        "flexed 60 deg, under the 5 deg of joint-angle error McGinley et al. 2009 say should "
        "raise concern"
        if t == DEFAULT_TOLERANCE_DEG
        else f"this run's; the default is {DEFAULT_TOLERANCE_DEG:g} deg"
    )
    return [
        f"**Tolerance T = {t:g} deg** (the heading accuracy asked for, config `tolerance_deg`; "
        f"{default}): **{met} of {len(table)} sensors meet it**. {verdict_counts(table['verdict_kind'])}.",
        "",
        "- **use**: its uncertainty cone within T, the methods of its test within T of each "
        "other, and another calibration of the sensor within T of it;",
        "- **use with care**: its cone within 2T, but the cone beyond T, the methods more than T "
        "apart, no other calibration within T, or the right axis's sign not verified by the data "
        "(the verdict says which, with the numbers);",
        "- **not within tolerance**: the best calibration available, with its numbers and why it "
        "is not within T;",
        "- **no trustworthy calibration**: every calibration taken out, and by what.",
        "",
    ]


def _ties(table: pd.DataFrame) -> str:
    """'3 of 9 sensors chosen by the tie rule, 2 of them with evidence from fewer than 2 other
    sensors' (no standard error: every method ties there).
    """
    chosen = table[table["method"].notna()]
    tied = chosen["n_tied"] > 1
    unmeasured = tied & ~np.isfinite(chosen["evidence_uncertainty_deg"].astype(float))
    return (
        f"{int(tied.sum())} of {len(chosen)} sensors chosen by the tie rule, "
        f"{int(unmeasured.sum())} of them with evidence from fewer than 2 other sensors (no "
        "standard error: every method ties there)"
    )


def _choice_lines(table: pd.DataFrame, with_peers: bool) -> list[str]:
    """How the calibration is chosen (``with_peers``: the peers' calibrations among them) and
    where its cones come from.
    """
    accuracy = table["basis"].fillna("").str.startswith("accuracy").any()
    evidence = (
        "the smallest median error to the ground truth of the other sensors of its segment "
        "(the other subjects', the other side's: never the sensor's own error, which the decision "
        "is judged by)"
        if accuracy
        else "the smallest median test-retest angle of the other sensors of its segment "
        "(repeatability only: there is no ground truth here, and a repeatable calibration can "
        "still be wrong)"
    )
    lines = [
        "Each sensor's calibration is chosen among its calibrations from all repetitions (every "
        f"method, {'the peers too' if with_peers else 'no peer: they were left out'}, every test "
        "that calibrates it) that no flag takes out ("
        + ", ".join(f"`{f}`" for f in ADVISORY_FLAGS)
        + " are shown beside it, not taken out: config/README.md) by "
        + evidence
        + "; methods whose evidence differs by less than its standard error, or has none, tie, "
        "and a tie goes to a cone within T, then within 2T; there to a calibration that agrees "
        "with the other methods (not `methods_disagree`), then to the registry's order of "
        "methods (Kong's first); beyond 2T to the smallest cone (the best available); then to "
        f"the test's name ({_ties(table)}). Uncertainty: `cone_deg`; spread: the largest angle to "
        "another method's calibration of the same test; within T: its calibrations within T of "
        "it (its own included); kept of N: its calibrations no flag takes out, of all it has; "
        "runner-up: the next in that order, and its evidence minus the chosen one's (negative: "
        "the runner-up's evidence was better, but within the tie) (table `decision`, every "
        "column, with the chosen rotation).",
    ]
    fits = table["cone_fit"].dropna().astype(str).unique() if "cone_fit" in table else []
    left_out = [f for f in fits if f.startswith("left out")]
    if left_out:
        lines += [
            "",
            "This dataset's ground truth is one the cone's constants are fitted on "
            "(docs/uncertainty.md): its cones are the ones fitted without it "
            f"(results/coverage/model.csv, fit '{left_out[0]}'), so here they are judged out of "
            "sample.",
        ]
    return lines + [""]


def decision_section(tables: dict, with_peers: bool = True) -> list[str]:
    """The decision per IMU (every IMU of every subject up to :data:`MAX_LISTED`, else per sensor
    place over the subjects), the tolerance and how many sensors meet it first; empty without
    the table. ``with_peers``: the peers' calibrations were among those it chose from.
    """
    table = tables.get("decision")
    if table is None or table.empty:
        return []
    lines = ["## Which calibration to use, for each sensor", ""]
    lines += _first_lines(table) + _choice_lines(table, with_peers)
    if len(table) <= MAX_LISTED:
        return lines + _listed(table) + [""]
    return lines + _by_place(table) + [""]


def _use(r) -> str:
    """'kong T6', its advisory flags and a design note beside it, or '-'."""
    if not isinstance(r["method"], str):
        return "-"
    text = f"{r['method']} {r['test']}"
    flags = r.get("advisory_flags")
    if isinstance(flags, str) and flags:
        text += f" [{flags.replace(';', ', ')}]"
    note = r.get("note")
    return text + (f" ({note})" if isinstance(note, str) and note else "")


def _runner_up(r) -> str:
    """'ricci_lm T6 (+0.4)': the runner-up and the margin, or '-'."""
    if not isinstance(r.get("runner_up"), str):
        return "-"
    margin = r.get("margin_deg", np.nan)
    return f"{r['runner_up']} ({margin:+.1f})" if np.isfinite(margin) else f"{r['runner_up']} (-)"


def _listed(table: pd.DataFrame) -> list[str]:
    rows = [
        "| subject | set | IMU | segment | use | uncertainty (deg) | spread (deg) | within T | "
        "kept of N | runner-up (margin, deg) | verdict |",
        "|:--|:--|:--|:--|:--|--:|--:|--:|:--|:--|:--|",
    ]
    for _, r in table.iterrows():
        behind = int(r["n_behind"]) if np.isfinite(r.get("n_behind", np.nan)) else "-"
        rows.append(
            f"| {r['subject']} | {r['sensor_set']} | {r['imu']} | {r['segment']} | {_use(r)} | "
            f"{_deg(r[CONE])} | {_deg(r['methods_spread_deg'])} | {behind} | "
            f"{int(r['n_unflagged'])} of {int(r['n_calibrations'])} | {_runner_up(r)} | "
            f"{r['verdict']} |"
        )
    return rows


def _by_place(table: pd.DataFrame) -> list[str]:
    rows = [
        "| set | IMU | segment | use (most often) | uncertainty, median (deg) | spread, median "
        "(deg) | kept of N | verdicts |",
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
            f"{verdict_counts(group['verdict_kind'])} |"
        )
    return rows
