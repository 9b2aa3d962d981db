"""Ricci et al. 2014 reproduced: Table 1 (reliability index rho per movement and segment), the
supported-vs-unsupported t-tests, the LM iterations and the residual angles.

Inputs are the tidy tables of ``aceval calibrate``: ``axes`` (one row per subject, set, IMU and
test: the pooled axis and its rho) and ``calibrations`` (one row per calibration and method).
Published values come from ``reference/ricci2014`` (see its SOURCE.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.evaluation.stats import TTEST_COLUMNS, holm, paired_ttest
from aceval.methods import registry
from aceval.methods.ricci import SAME_SOLUTION_DEG

REFERENCE = Path(__file__).parent / "reference" / "ricci2014"
#: Ricci's supported (with a bar) vs unsupported comparisons: (reading, frame, supported,
#: unsupported). The paper tests "the same physiological movement (flexion and extension) executed
#: with or without the support of a rigid bar": shoulder flexion-extension with (FEB) and without
#: (FE) the bar, at both the upper-arm and the forearm sensors (Table 1 gives both). The forearm's
#: own supported movement, elbow flexion-extension (FFEB), against shoulder FE mixes support with the
#: movement: a second, labelled reading.
SUPPORTED_PAIRS = [
    ("same movement (FEB vs FE)", "upper_arm", "FEB", "FE"),
    ("same movement (FEB vs FE)", "forearm", "FEB", "FE"),
    ("elbow vs shoulder movement (FFEB vs FE)", "forearm", "FFEB", "FE"),
]
PRIMARY_READING = SUPPORTED_PAIRS[0][0]
FRAMES = {"thorax": "thorax", "upper_arm": "upper_arm", "forearm": "forearm"}


def segment_label(segment: pd.Series, side: pd.Series) -> pd.Series:
    """'thorax', 'upper_arm_l', 'forearm_r' ... (Ricci Table 1 columns): side added when lateral."""
    side = side.astype(str).str[:1]
    return np.where(side.isin(["r", "l"]), segment.astype(str) + "_" + side, segment.astype(str))


def _published_table1() -> pd.DataFrame:
    wide = pd.read_csv(REFERENCE / "table1_reliability_index.csv", comment="#")
    rows = []
    for _, row in wide.iterrows():
        for column in wide.columns:
            if column.endswith("_mean") and np.isfinite(row[column]):
                segment = column[: -len("_mean")]
                rows.append(
                    {
                        "test": row["code"],
                        "segment": segment,
                        "published_mean": row[column],
                        "published_sd": row[f"{segment}_sd"],
                    }
                )
    return pd.DataFrame(rows)


def rho_table(axes: pd.DataFrame, paper_names: dict | None = None) -> pd.DataFrame:
    """Ricci Table 1: rho mean, SD and n (subjects) per test and segment (with side), the
    published value beside it (tests renamed with ``paper_names``, e.g. S -> 'TS/US/FS').
    """
    names = paper_names or {}
    data = axes.assign(
        segment=segment_label(axes["segment"], axes["side"]),
        test=axes["test"].map(lambda t: names.get(t, t)),
    )
    result = (
        data.groupby(["test", "segment"])["rho"].agg(mean="mean", sd="std", n="count").reset_index()
    )
    merged = result.merge(_published_table1(), on=["test", "segment"], how="outer")
    merged["difference"] = merged["mean"] - merged["published_mean"]
    return merged


def supported_ttest(axes: pd.DataFrame) -> pd.DataFrame:
    """Paired t-test of rho, supported (bar) vs unsupported movement, per reading, frame and side
    (:data:`SUPPORTED_PAIRS`: FEB vs FE at the upper-arm and forearm sensors, the paper's "same
    physiological movement"; FFEB vs FE at the forearm, a second reading).

    Pairing unit: the child (and side): each child's rho per movement is pooled over its 3 trials,
    as in Table 1, so every pair is one child's two movements; sides are tested separately because
    a child's left and right arm are not independent. ``p`` is the raw p (the paper quotes raw
    p < 0.05); ``p_holm`` corrects within each reading (its rows are one family).
    """
    rows = []
    data = axes.assign(label=segment_label(axes["segment"], axes["side"]))
    for reading, frame, supported, unsupported in SUPPORTED_PAIRS:
        for label, group in data[data["segment"] == frame].groupby("label", sort=True):
            wide = group.pivot_table(index=["subject", "sensor_set"], columns="test", values="rho")
            if not {supported, unsupported} <= set(wide.columns):
                continue
            wide = wide[[supported, unsupported]].dropna()
            rows.append(
                {
                    "reading": reading,
                    "segment": label,
                    "supported": supported,
                    "unsupported": unsupported,
                    **paired_ttest(wide[supported].to_numpy(), wide[unsupported].to_numpy()),
                }
            )
    columns = ["reading", "segment", "supported", "unsupported", *TTEST_COLUMNS]
    result = pd.DataFrame(rows, columns=columns)
    result["p_holm"] = np.nan
    for _, index in result.groupby("reading", sort=False).groups.items():
        result.loc[index, "p_holm"] = holm(result.loc[index, "p"])
    published = _published_table1().set_index(["test", "segment"])
    for side, column in (("a", "supported"), ("b", "unsupported")):
        keys = list(zip(result[column], result["segment"], strict=True))
        result[f"published_mean_{side}"] = [
            published["published_mean"].get(k, np.nan) for k in keys
        ]
    result["published_p"] = "< 0.05"
    return result


def published_lm() -> pd.DataFrame:
    """Ricci Sec. 3-4's LM iterations (mean, SD) per frame and residuals after the fit (deg)."""
    return pd.read_csv(REFERENCE / "lm_published.csv", comment="#", dtype={"test": str}).fillna(
        {"test": ""}
    )


def lm_table(calibrations: pd.DataFrame) -> pd.DataFrame:
    """LM iterations per frame with Ricci's adaptive damping (columns without a prefix: mean, SD,
    n IMUs; the published values beside) and with lambda fixed at 1e-3 (``fixed_*``), each with its
    final cost, its distance to the closed-form optimum (median and largest, deg; the share more
    than SAME_SOLUTION_DEG, 1 deg, away) and the share that converged (the gradient on the sphere reached
    :data:`aceval.methods.ricci.GRAD_TOL`); the random starts: the share that reach the closed-form
    optimum and their iterations.
    """
    lm = calibrations[calibrations["method"] == registry.paper_method("ricci2014")]
    lm = lm.assign(
        off_optimum=lm["optimum_distance_deg"] > SAME_SOLUTION_DEG,
        fixed_off_optimum=lm["fixed_optimum_distance_deg"] > SAME_SOLUTION_DEG,
    )
    result = (
        lm.groupby("segment")
        .agg(
            mean=("n_iterations", "mean"),
            sd=("n_iterations", "std"),
            n=("n_iterations", "count"),
            rejected_mean=("n_rejected", "mean"),
            cost_median=("cost", "median"),
            optimum_distance_deg_median=("optimum_distance_deg", "median"),
            optimum_distance_deg_max=("optimum_distance_deg", "max"),
            off_optimum_share=("off_optimum", "mean"),
            converged_share=("converged", "mean"),
            fixed_mean=("fixed_n_iterations", "mean"),
            fixed_sd=("fixed_n_iterations", "std"),
            fixed_cost_median=("fixed_cost", "median"),
            fixed_optimum_distance_deg_median=("fixed_optimum_distance_deg", "median"),
            fixed_optimum_distance_deg_max=("fixed_optimum_distance_deg", "max"),
            fixed_off_optimum_share=("fixed_off_optimum", "mean"),
            fixed_converged_share=("fixed_converged", "mean"),
            random_starts=("random_starts", "sum"),
            random_starts_optimum=("random_starts_optimum", "sum"),
            random_start_iterations_mean=("random_start_iterations_mean", "mean"),
            random_start_iterations_max=("random_start_iterations_max", "max"),
        )
        .reset_index()
    )
    result["random_starts_optimum_share"] = (
        result["random_starts_optimum"] / result["random_starts"]
    )
    result[["random_starts", "random_starts_optimum"]] = result[
        ["random_starts", "random_starts_optimum"]
    ].astype(int)
    published = (
        published_lm()
        .query("quantity == 'iterations'")
        .rename(columns={"frame": "segment", "mean": "published_mean", "sd": "published_sd"})
    )
    merged = result.merge(
        published[["segment", "published_mean", "published_sd"]], on="segment", how="outer"
    )
    merged["difference"] = merged["mean"] - merged["published_mean"]
    return merged


def residual_table(axes: pd.DataFrame, paper_names: dict | None = None) -> pd.DataFrame:
    """Ricci Fig. 5 / Eq. 13: residual angle (deg) between each reference axis and its estimate,
    before (identity) and after the LM fit, mean, SD and n children per segment (with side) and
    test, and over the tests (``all``: each child's mean over its tests, then over the children).
    """
    names = paper_names or {}
    used = axes.dropna(subset=["residual_after_deg"])
    data = used.assign(segment=segment_label(used["segment"], used["side"]))
    result = (
        data.groupby(["segment", "test"])
        .agg(
            before_mean=("residual_before_deg", "mean"),
            before_sd=("residual_before_deg", "std"),
            mean=("residual_after_deg", "mean"),
            sd=("residual_after_deg", "std"),
            n=("residual_after_deg", "count"),
        )
        .reset_index()
    )
    per_child = data.groupby(["segment", "subject"], as_index=False)[
        ["residual_before_deg", "residual_after_deg"]
    ].mean()  # a child's tests are not independent: one value per child in the overall row
    overall = (
        per_child.groupby("segment")
        .agg(
            before_mean=("residual_before_deg", "mean"),
            before_sd=("residual_before_deg", "std"),
            mean=("residual_after_deg", "mean"),
            sd=("residual_after_deg", "std"),
            n=("residual_after_deg", "count"),
        )
        .reset_index()
        .assign(test="all")
    )
    result = pd.concat([result, overall], ignore_index=True)
    published = (
        published_lm()
        .query("quantity == 'residual_after_deg'")
        .rename(columns={"frame": "segment", "mean": "published_mean"})[
            ["segment", "test", "published_mean"]
        ]
    )
    merged = result.merge(published, on=["segment", "test"], how="left")
    merged["difference"] = merged["mean"] - merged["published_mean"]
    merged["test"] = merged["test"].map(lambda t: names.get(t, t))
    return merged
