"""SUMMARY.md: each claim of Kong et al. 2016 and Ricci et al. 2014 (reference/*/headline_findings.md)
with its verdict (:mod:`aceval.report.claims`) and the numbers behind it, after the decision
(:mod:`aceval.report.decisions`: SUMMARY.md's one answer per sensor), then the evidence behind it.

Each check states its rule and the source of every number it compares with.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import rows_of_method, unflagged
from aceval.evaluation.cone_fit import CELL, MAX_CONE_OVER_ERROR, MIN_CELL, POOLED
from aceval.evaluation.methods_comparison import (
    MAX_MARKER_FRAME_LONG_AXIS_DEG,
    MAX_MARKER_FRAME_VERTICAL_DEG,
    marker_frame_verdict,
)
from aceval.methods.kong import KongLimits
from aceval.report.claims import (
    CODE,
    FAILS,
    GROUND_TRUTH,
    HOLDS,
    INCONCLUSIVE,
    NEGLIGIBLE,
    PAPER,
    UNTESTABLE,
    VERDICTS,
    Claim,
    rule_sentences,
    verdict_text,
)
from aceval.report.kong_claims import blind_spots, kong_claims
from aceval.report.ricci_claims import ricci_claims, ricci_untestable


def claims(tables: dict, data: dict) -> list[Claim]:
    """Kong's claims when the dataset has any of Kong's tables (by number), Ricci's when it has the
    ricci_* tables (else, beside Kong's, Ricci's as not testable: no functional axes); both read
    ``data``'s tidy tables (correlations, angles, calibrations).
    """
    found = []
    kong = any(isinstance(key, int) for key in tables)
    if kong:
        found += kong_claims(tables, data)
    if any(str(key).startswith("ricci_") for key in tables):
        found += ricci_claims(tables, data)
    elif kong:
        found += ricci_untestable()
    return found


def _claims_table(found: list[Claim]) -> list[str]:
    table = pd.DataFrame(
        [
            {
                "objective": c.objective,
                "claim": c.claim,
                "verdict": verdict_text(c),
                "numbers (this run)": c.numbers,
                "rule": c.rule,
            }
            for c in found
        ]
    )
    return [table.to_markdown(index=False), ""]


def retest_section(tables: dict) -> list[str]:
    """Every method's test-retest, per segment (table ``methods_retest``): repeatability, which
    needs no truth, so datasets without one compare the methods here.
    """
    retest = tables.get("methods_retest")
    if retest is None or retest.empty or "median" not in retest:
        return []
    data = retest.dropna(subset=["median"])
    if data.empty:
        return []
    lines = [
        "## Every method's test-retest (Kong Obj 4 beyond Kong's method; no truth needed)",
        "",
        "Median over subject x IMU units of the angle between calibrations from two distinct "
        "subsets of repetitions of one test (table `methods_retest`), per segment: each method's "
        "best test. Repeatability is not accuracy: a method that ignores the motion (OpenSense's "
        "static pose) repeats perfectly.",
        "",
    ]
    best = data.loc[data.groupby(["segment", "method"], sort=False)["median"].idxmin()]
    for segment, group in best.groupby("segment", sort=False):
        parts = [f"{r['method']} {r['test']} {r['median']:.2f} deg" for _, r in group.iterrows()]
        lines.append(f"- **{segment}**: " + ", ".join(parts) + ".")
    return lines + [""]


def uncertainty_section(tables: dict) -> list[str]:
    """Table ``uncertainty``: how often the truth lies inside each calibration's uncertainty cone,
    per method, with its interval, beside what the repetitions' spread alone covers.
    """
    table = tables.get("uncertainty")
    if table is None or table.empty:
        return []
    lines = [
        "## How far to trust one calibration: the uncertainty cone",
        "",
        "Each calibration from all repetitions carries `cone_deg`, an uncertainty cone: the "
        "spread between its resampled repetitions (`spread95_deg`), how far the recording's other "
        "estimates of its heading lie (the other signals' calibrations and its other tests'), how "
        "well the motion fixes the heading (Kong's eigenvalue ratio), the tilt of z0 from the "
        "accelerometer's datasheet bias and the foot's progression angle, combined with "
        "constants fitted across simulator variants and real truths (docs/uncertainty.md; "
        "results/coverage). A cone beyond 90 deg is none: that calibration is flagged "
        "`heading_undetermined`. Against the ground truth (table `uncertainty`):",
        "",
    ]
    pooled = table[table["segment"] == "all"]
    cells = table[(table["segment"] != "all") & (table["n"] >= MIN_CELL)]
    for _, r in pooled.iterrows():
        worst = cells[cells["method"] == r["method"]]["coverage"].min()
        lines.append(
            f"- **{r['method']}**: the truth inside the cone for {r['coverage']:.0%} "
            f"[{r['coverage_low']:.0%}, {r['coverage_high']:.0%}] of {int(r['n'])} calibrations "
            f"({r['interval']} interval), "
            + (f"its worst cell {worst:.0%}" if pd.notna(worst) else "no cell with 5 calibrations")
            + f"; median cone "
            f"{r['cone_median_deg']:.2f} deg against median error {r['error_median_deg']:.2f} "
            f"deg; the repetitions' spread alone covers {r['spread_coverage']:.0%}"
            + (
                f"; with the truth's own uncertainty {r['coverage_with_truth']:.0%}"
                if pd.notna(r["coverage_with_truth"])
                else ""
            )
            + f". {_cone_verdict(r, worst)}"
        )
    lines += [
        "",
        f"A method's cone is called a 95 % cone here where it covers {POOLED[0]:.0%}-"
        f"{POOLED[1]:.0%} pooled, at least {CELL:.0%} in every test x segment cell and is at "
        f"most {MAX_CONE_OVER_ERROR:g} times the error (median); elsewhere it is an uncertainty "
        "cone whose coverage this table measures.",
        "",
    ]
    return lines


def _cone_verdict(pooled: pd.Series, worst_cell: float) -> str:
    """Whether a method's cone is a 95 % cone on this dataset (the criteria of
    :mod:`aceval.evaluation.cone_fit`: pooled, in every cell, against the error), or what it
    misses.
    """
    ratio = pooled["cone_median_deg"] / pooled["error_median_deg"]
    misses = [
        f"pooled {pooled['coverage']:.0%} outside {POOLED[0]:.0%}-{POOLED[1]:.0%}"
        if not POOLED[0] <= pooled["coverage"] <= POOLED[1]
        else "",
        f"a cell at {worst_cell:.0%}" if worst_cell < CELL else "",
        "no test x segment cell with 5 calibrations to judge" if pd.isna(worst_cell) else "",
        f"cone {ratio:.1f} times the error" if ratio > MAX_CONE_OVER_ERROR else "",
    ]
    misses = [m for m in misses if m]
    if not misses:
        return "A 95 % cone here."
    return f"Not a validated 95 % cone here ({'; '.join(misses)}): an uncertainty cone."


def conditioning_section(tables: dict) -> list[str]:
    """Table ``conditioning``: per test and segment, how many IMUs' headings Kong's plane leaves
    undetermined (eigenvalue ratio above 0.5), beside the median ratio.
    """
    table = tables.get("conditioning")
    if table is None or table.empty:
        return []
    limits = KongLimits()
    counts = (
        table.assign(
            undetermined=table["normal_ratio"] > limits.max_normal_ratio,
            not_plane=table["planarity"] > limits.max_planarity,
        )
        .groupby(["test", "segment"], sort=True)
        .agg(
            n=("heading", "size"),
            heading_undetermined=("undetermined", "sum"),
            median_ratio=("normal_ratio", "median"),
            largest_ratio=("normal_ratio", "max"),
            not_a_plane=("not_plane", "sum"),
            largest_planarity=("planarity", "max"),
        )
        .reset_index()
    )
    return [
        "## How well each test determines the heading (conditioning of Kong's plane)",
        "",
        "Kong's medial-lateral axis is the normal of the plane of accelerations. When the smallest "
        f"and middle eigenvalues are close (ratio above {limits.max_normal_ratio}) the normal, so "
        "the heading, is undetermined; when the smallest is not small against the largest "
        f"(planarity above {limits.max_planarity}) the accelerations do not lie in a plane. Either "
        "flags the calibration `not_planar`. Per test and segment, from each IMU's calibration of "
        "all repetitions (table `conditioning` has every IMU):",
        "",
        counts.round({"median_ratio": 2, "largest_ratio": 2, "largest_planarity": 3}).to_markdown(
            index=False
        ),
        "",
    ]


def loose_reference_section(tables: dict) -> list[str]:
    """Table ``loose_reference``: each method's right axis against a hand-set reference, as orders
    of magnitude (the reference is not a measurement).
    """
    table = tables.get("loose_reference")
    if table is None or table.empty:
        return []
    check = table["reference_standing_up_angle_deg"]
    lines = [
        "## Orders of magnitude against a loose reference (NOT a ground truth)",
        "",
        "The publishers' hand-tuned segment axes (set by eye for a visualisation) beside each "
        "calibration of all repetitions: the angle between the two right axes. The reference's own "
        f"up is {check.min():.0f}-{check.max():.0f} deg from the accelerometer's vertical while "
        "standing, so differences of that size say nothing. Table `loose_reference` has every "
        "method and the verticals.",
        "",
    ]
    for method, group in table.groupby("method", sort=False):
        kept = group[group["flag"].fillna("") == ""]
        if not group["right_axis_angle_deg"].notna().any():
            lines.append(f"- {method}: not applicable here ({len(group)} rows, no calibration)")
            continue
        lines.append(
            f"- {method}: median {group['right_axis_angle_deg'].median():.1f} deg over "
            f"{len(group)} calibrations (range {group['right_axis_angle_deg'].min():.1f}-"
            f"{group['right_axis_angle_deg'].max():.1f}); unflagged only: median "
            f"{kept['right_axis_angle_deg'].median():.1f} deg over {len(kept)}"
        )
    return lines + [""]


def _long_axis(correction: float) -> str:
    """', long-axis check 0.5' (the heading correction the long axis asks), or nothing."""
    return f", long-axis check {correction:.1f}" if np.isfinite(correction) else ""


def _marker_frame(r) -> str:
    """The error against the marker-frame truth, or why that truth is not used for this sensor."""
    if np.isfinite(r["error_marker_frame_deg"]):
        return f"against the marker-frame truth {r['error_marker_frame_deg']:.1f} deg" + (
            f" (its long-axis check {r['marker_frame_long_axis_check_deg']:.1f})"
            if np.isfinite(r["marker_frame_long_axis_check_deg"])
            else ""
        )
    why = marker_frame_verdict(
        r["marker_frame_vertical_check_deg"], r["marker_frame_long_axis_check_deg"]
    )
    return f"the marker-frame truth not used ({why})"


def truth_section(tables: dict) -> list[str]:
    """Real recordings with a marker-based truth (table ``truth_errors``): Kong's error per sensor
    beside the truth's own uncertainty, the second truth, and the conditioning.
    """
    table = tables.get("truth_errors")
    if table is None or table.empty:
        return []
    kong = rows_of_method(table)
    lines = [
        "## What Kong's method measures on this person (against the marker-based ground truth)",
        "",
        "Each IMU's calibration from all repetitions, error to the truth (optical point acceleration: "
        "quiet standing's vertical plus the heading that matches the sensor's acceleration to a joint "
        "centre's) with that truth's own uncertainty (its strides, points and time offsets) and "
        "the heading correction an independent check asks of it (the angular velocity of the "
        "segment's long axis), then the error to the second, "
        "marker-frame truth (only where its own vertical and long-axis checks pass: within "
        f"{MAX_MARKER_FRAME_VERTICAL_DEG:g} and {MAX_MARKER_FRAME_LONG_AXIS_DEG:g} deg), the two "
        "truths' difference and the marker frame's "
        "mean twist about the segment's long axis while walking, where the sensor sits (from the "
        "segment's point), and the conditioning of Kong's plane (smallest/middle eigenvalue ratio; "
        "above 0.5 the heading is undetermined). Table `truth_errors` has every method.",
        "",
    ]
    for _, r in kong.iterrows():
        flag = f", flagged {r['flag']}" if isinstance(r["flag"], str) and r["flag"] else ""
        if isinstance(r["truth_flag"], str) and r["truth_flag"]:
            flag += f", truth flagged {r['truth_flag']}"
        lines.append(
            f"- {r['imu']} ({r['sensor_set']}, {r['test']}): {r['error_deg']:.1f} deg "
            f"(truth +- {r['truth_uncertainty_deg']:.1f}{_long_axis(r['long_axis_check_deg'])}); "
            f"{_marker_frame(r)}; "
            f"truths {r['methods_differ_deg']:.1f} deg apart, "
            f"twist {r['twist_mean_deg']:+.1f} deg; sensor {100 * r['lever_arm_m']:.0f} cm from the "
            f"segment's point; eigenvalue ratio {r['normal_ratio']:.2f} ({r['heading']}){flag}"
        )
    return lines + [""]


def to_markdown(
    found: list[Claim],
    dataset: str,
    description: str,
    simulated: bool,
    notes: list[str],
    first: list[str] | None = None,
    extra: list[str] | None = None,
    tables: dict | None = None,
) -> str:
    """SUMMARY.md: the ``first`` section (which calibration to use for each sensor), the counts
    and table of the papers' claims (the testable ones first) with how each family of claims is
    judged and what it cannot see (from ``tables``), the notes, then aceval's own checks against
    a ground truth, the checks of the code, and the ``extra`` sections.
    """
    claims = [c for c in found if c.section == PAPER]
    claims = [c for c in claims if c.verdict != UNTESTABLE] + [
        c for c in claims if c.verdict == UNTESTABLE
    ]
    counts = {v: sum(c.verdict == v for c in claims) for v in VERDICTS}
    lines = [f"# {dataset}: which calibration to use, and the papers' claims", ""]
    lines += [f"{description}", ""]
    if simulated:
        lines += [
            "**SIMULATED data.** The simulator is built from physiology and datasheets, never fitted to the "
            "paper; where a claim does not hold here, the simulated effects differ from the paper's "
            "subjects (see docs/simulation.md), which says nothing about the method on real data.",
            "",
        ]
    lines += first or []
    lines += [
        "## The papers' claims on this dataset",
        "",
        f"{counts[HOLDS]} hold, {counts[FAILS]} do not hold, {counts[NEGLIGIBLE]} no relevant "
        f"difference, {counts[INCONCLUSIVE]} inconclusive, {counts[UNTESTABLE]} not testable. "
        "Each claim is judged on the subjects as independent units (docs/objectives.md, 'How a "
        "claim is judged'), on the t-intervals of the subjects' mean in each of its cells:",
        "",
        *rule_sentences(found),
        "",
        "An inconclusive claim says which way its estimates lean and how many subjects would "
        "decide it with 80 % probability at these effects. The cells behind every verdict are in "
        "tables/claim_cells.csv, each cell's intervals in tables/claim_estimates.csv. The claims "
        "that cannot be tested here come last.",
        "",
        *blind_spots(found, tables or {}),
    ]
    lines += notes + ([""] if notes else [])
    lines += (
        _claims_table(claims)
        if claims
        else ["No claim of either paper applies to this dataset's analyses.", ""]
    )
    truth = [c for c in found if c.section == GROUND_TRUTH]
    if truth:
        lines += ["## Against the ground truth (aceval's own check, beyond the paper)", ""]
        lines += _claims_table(truth)
    code = [c for c in found if c.section == CODE]
    if code:
        lines += [
            "## Checks of the code (true by construction: not findings)",
            "",
            *_claims_table(code),
        ]
    lines += extra or []
    return "\n".join(lines)


def calibration_screen(
    calibrations: pd.DataFrame, n_left_out: int, path, ground_truth: pd.DataFrame | None = None
) -> str:
    """One screen for the end of ``aceval calibrate``: what was written, per method how many
    calibrations, how many flagged and (with ground truth) the median error, and the warnings
    about the truth (``ground_truth``: :func:`aceval.evaluation.truth_warnings.truth_warning`).
    """
    if calibrations.empty:
        return f"aceval calibrate: wrote {path}: no calibrations ({n_left_out} recordings left out)"
    flagged = ~unflagged(calibrations)
    per_method = (
        calibrations.assign(flagged=flagged)
        .groupby("method", sort=False)
        .agg(
            calibrations=("flag", "size"),
            flagged=("flagged", "sum"),
            median_error_deg=("error_deg", "median"),
        )
    )
    if per_method["median_error_deg"].isna().all():
        per_method = per_method.drop(columns="median_error_deg")
    from aceval.evaluation.truth_warnings import truth_warning

    lines = [
        f"aceval calibrate: wrote {path}",
        f"  {len(calibrations)} calibrations ({int(flagged.sum())} flagged) of "
        f"{calibrations['subject'].nunique()} subject(s), "
        f"{calibrations[['sensor_set', 'imu']].drop_duplicates().shape[0]} IMU(s), tests "
        f"{', '.join(sorted(calibrations['test'].unique()))}; {n_left_out} recording(s) left out",
        *("  " + line for line in per_method.round(2).to_string().splitlines()),
    ]
    warning = truth_warning(calibrations, ground_truth)
    return "\n".join(lines + ([warning] if warning else []))
