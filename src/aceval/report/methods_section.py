"""SUMMARY.md's methods section: the methods side by side on the same data (table ``methods``),
where each peer is used outside its authors' design, the comparison on the cells every method
shares, and the ranking over the subjects (table ``methods_ranking``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.methods import registry
from aceval.report.claims import interval


def _design_notes(methods: pd.DataFrame) -> list[str]:
    """One line per peer shown outside what its authors meant it for (the registry's
    ``design_segments`` and ``design_note``).
    """
    notes = []
    for method, peer in registry.peers().items():
        if not peer.design_note:
            continue
        rows = methods[(methods["method"] == method) & methods["median"].notna()]
        others = sorted(set(rows["segment"]) - set(peer.design_segments or ()))
        if len(rows) and (peer.design_segments is None or others):
            notes.append("- " + peer.design_note.format(others=", ".join(others)) + ".")
    return ["", "Peers outside their authors' design here:", *notes] if notes else []


def static_pose_methods() -> set[str]:
    """Methods that calibrate from a static pose (the registry's ``static_pose``): their cells are
    the static test's, and their test-retest says nothing about the motion.
    """
    return {name for name, peer in registry.peers().items() if peer.static_pose}


def unflagged_of(row) -> str:
    """'2 unflagged of 3' (``n`` of ``n_calibrations``), or just n without the count."""
    total = row.get("n_calibrations", np.nan)
    return f"{int(row['n'])} unflagged of {int(total)}" if pd.notna(total) else f"{int(row['n'])}"


def _shared_cells_line(methods: pd.DataFrame, compared: list[str]) -> str:
    """The methods' median errors over the cells (segment x test x set) where every one of
    ``compared`` has an unflagged value: the comparison on the same cells.
    """
    key = ["segment", "test", "sensor_set"]
    wide = methods[methods["method"].isin(compared)].pivot_table(
        index=key, columns="method", values="median"
    )
    shared = wide.reindex(columns=compared).dropna()
    if shared.empty:
        return "No cell has an unflagged value of every method: no comparison on shared cells."
    medians = shared.median().sort_values()
    return (
        f"On the {len(shared)} cell(s) where every method calibrating from motion has an unflagged "
        "value (the fair comparison; a static-pose method has its own cells, under the static "
        "test): " + ", ".join(f"{m} {v:.2f} deg" for m, v in medians.items()) + "."
    )


def _fully_flagged(methods: pd.DataFrame) -> list[str]:
    """The cells whose every calibration is flagged (n = 0, the flags kept in table ``methods``)."""
    if "flags" not in methods:
        return []
    fully = methods[(methods["n"] == 0) & (methods["flags"].fillna("") != "")]
    if fully.empty:
        return []
    cells = "; ".join(
        f"{r['method']} {r['segment']} {r['test']} {r['sensor_set']} ({r['flags']})"
        for _, r in fully.iterrows()
    )
    return [
        f"Every calibration flagged (no number, the row kept in table `methods`): {cells}. Here "
        "any flag leaves a calibration out; the decision above keeps one whose flags are only "
        "advisory (shown beside it there)."
    ]


def _ranking_lines(ranking: pd.DataFrame | None) -> list[str]:
    """The methods ranked over the subjects (table ``methods_ranking``), with intervals."""
    if ranking is None or ranking.empty:
        return []
    parts = [f"{ranking['method'].iloc[0]} {interval(*ranking.iloc[0][['mean', 'low', 'high']])}"]
    for _, r in ranking.iloc[1:].iterrows():
        to_first = interval(*r[["difference_to_first", "difference_low", "difference_high"]])
        parts.append(f"{r['method']} {interval(*r[['mean', 'low', 'high']])} ({to_first})")
    return [
        "",
        f"Ranked on the same {int(ranking['cells'].iloc[0])} cell(s) over the "
        f"{int(ranking['n_subjects'].iloc[0])} subjects (each subject's mean error there, its sides "
        "and sets inside it; table `methods_ranking`): mean [95 % interval] deg, and in brackets "
        f"the difference to the first, simultaneous over the {len(ranking) - 1} comparison(s): "
        + "; ".join(parts)
        + ".",
    ]


def methods_section(tables: dict) -> list[str]:
    """Which method and which test, per segment, against the ground truth (tables methods*)."""
    best, methods = tables.get("methods_best"), tables.get("methods")
    if best is None or best.empty or methods is None:
        return []
    lines = [
        "## Methods against the ground truth (the evidence; the decision above is the answer "
        "per sensor)",
        "",
    ]
    overall = methods.groupby("method")["median"].median().dropna().sort_values()
    cells = methods.dropna(subset=["median"]).groupby("method").size()
    price = methods.groupby("method")[["n", "n_calibrations"]].sum() if "flags" in methods else None

    def counted(m):
        kept = "" if price is None else f", {unflagged_of(price.loc[m])}"
        return f"{cells[m]} cells{kept}"

    lines.append(
        "Median error to the true mounting (median over segment x test x set cells of the per-cell "
        "medians; table `methods`), each method over all its own cells, with how many of its "
        "calibrations the flags left: "
        + ", ".join(f"{m} {v:.2f} deg ({counted(m)})" for m, v in overall.items())
        + "."
    )
    lines += _fully_flagged(methods)
    static = static_pose_methods()  # a static pose: its own cells
    moving = [m for m in overall.index if m not in static]
    lines += [
        "",
        _shared_cells_line(methods, moving),
        *_ranking_lines(tables.get("methods_ranking")),
    ]
    lines += _design_notes(methods)
    if "note" in methods:
        never = methods[~methods["method"].isin(overall.index)].groupby("method")["note"].first()
        lines += (
            [
                "",
                "Not applicable on this dataset: "
                + "; ".join(f"{m} ({note})" for m, note in never.items())
                + ".",
            ]
            if len(never)
            else []
        )
    lines.append("")
    kong_method = registry.paper_method("kong2016")
    for segment, group in best.groupby("segment", sort=False):
        parts = [
            f"{r['method']} {r['best_test']} ({r['best_median_deg']:.2f} deg)"
            for _, r in group.iterrows()
        ]
        kong = group[
            (group["method"] == kong_method)
            & group["kong_recommends"].notna()
            & (group["kong_recommends"] != "")
        ]
        text = f"- **{segment}**: smallest median error with " + ", ".join(parts)
        if len(kong):
            row = kong.iloc[0]
            tests_here = methods.loc[
                (methods["segment"] == segment) & (methods["method"] == kong_method), "test"
            ].nunique()
            agree = (
                "is the only test here, so nothing is compared with"
                if tests_here < 2
                else "agrees with"
                if row["best_test"] == row["kong_recommends"]
                else "differs from"
            )
            text += (
                f". Kong recommends {row['kong_recommends']} "
                f"({row['recommended_median_deg']:.2f} deg with Kong's method here): this {agree} it"
            )
        lines.append(text + ".")
    return lines + [""]
