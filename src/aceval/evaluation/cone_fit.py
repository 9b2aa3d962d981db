"""The cone model's constants, one per method, fitted split-conformally across simulator
variants and real truths (beyond the papers), and the criteria a cone is judged by.

The model (:class:`aceval.methods.uncertainty.ConeModel`) adds what the recording shows: the
spread of its repetitions, the other estimates' disagreement (other signals, other tests), Kong's
conditioning, and two a-priori terms. Every term counts at its own size (:data:`WEIGHTS`: 1, not
fitted: a disagreement of 10 deg between two estimates of one heading is 10 deg of uncertainty);
one factor ``q`` per method turns their root sum of squares into a 95 % cone
(:func:`fit_cone_model`): split-conformally, the 95th percentile of the error over that root sum
of squares on the datasets the fit sees, every dataset (each simulator variant, each real truth,
its error less the truth's own uncertainty) weighing alike (:func:`factors`). What the cones then
cover is measured on the datasets a fit did not see (:mod:`aceval.evaluation.coverage`, one left
out at a time), against :data:`GOAL` (:func:`goal`).

Rows (:func:`usable`): the calibrations from all repetitions with a spread and an error to the
truth, unflagged but for ``heading_undetermined`` (which the cone itself decides: a row whose
cone is beyond 90 deg is dropped from the coverage as the flag drops it, never counted covered).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import flag_sets
from aceval.methods.uncertainty import LEVEL, ConeModel, model_cones, undetermined

#: a 95 % cone covers within this range pooled (per method and dataset) ...
POOLED = (0.90, 0.99)
#: ... at least this much in every test x segment cell of at least :data:`MIN_CELL` calibrations
CELL, MIN_CELL = 0.80, 5
#: ... and its median is at most this many times the median error
MAX_CONE_OVER_ERROR = 3.0
#: what a cone should do on a dataset it was not fitted on: cover 90-99 % with a median cone at
#: most 3 times the median error (:func:`goal`)
GOAL = (POOLED, MAX_CONE_OVER_ERROR)
#: the weights of the disagreement and conditioning terms: each counts at its own size
WEIGHTS = {"signals": 1.0, "tests": 1.0, "conditioning": 1.0}
#: the columns a row of the study needs
TERMS = ["spread95_deg", "heading_signals_deg", "heading_tests_deg", "conditioning_deg"]
ROW_COLUMNS = [
    "dataset",
    "kind",
    "subject",
    "sensor_set",
    "imu",
    "segment",
    "test",
    "method",
    "flag",
    "error_deg",
    "truth_uncertainty_deg",
    *TERMS,
]


def usable(rows: pd.DataFrame) -> pd.DataFrame:
    """The rows the cone is fitted and judged on (module docstring)."""
    only = flag_sets(rows["flag"]).map(frozenset({"heading_undetermined"}).issuperset)
    finite = np.isfinite(rows["spread95_deg"].astype(float)) & np.isfinite(
        rows["error_deg"].astype(float)
    )
    return rows[only & finite].reset_index(drop=True)


def excess_error(rows: pd.DataFrame) -> np.ndarray:
    """The error a cone must hold: on real data the error minus the truth's own uncertainty
    (at least 0), on simulations (no truth uncertainty) the error.
    """
    truth = np.nan_to_num(rows["truth_uncertainty_deg"].to_numpy(float))
    return np.clip(rows["error_deg"].to_numpy(float) - truth, 0.0, None)


def cones_of(rows: pd.DataFrame, model: ConeModel) -> np.ndarray:
    """The model's cone of each row."""
    return model_cones(
        *(rows[t].to_numpy(float) for t in TERMS),
        rows["segment"].to_numpy(),
        rows["method"].to_numpy(),
        model,
    )


def _weighted_quantile(values, weights, level: float) -> float:
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order]) / weights.sum()
    return float(values[order][min(np.searchsorted(cumulative, level), len(values) - 1)])


def factors(rows: pd.DataFrame, level: float = LEVEL) -> dict[str, float]:
    """``q`` per method: the ``level`` quantile of its rows' errors (:func:`excess_error`) over
    their root sum of squares (:data:`WEIGHTS`, ``q`` 1), every dataset weighing alike (so two
    real truths of a few dozen calibrations count as much as two simulator variants of
    thousands): the split-conformal scale of each method's cone on ``rows``.
    """
    rms = cones_of(rows, ConeModel(**WEIGHTS, q={}, q_other=1.0))
    ratio = excess_error(rows) / rms
    weight = 1.0 / rows.groupby("dataset")["dataset"].transform("size").to_numpy(float)
    return {
        method: _weighted_quantile(ratio[at], weight[at], level)
        for method, at in rows.groupby("method").indices.items()
    }


def judged(rows: pd.DataFrame, cone: np.ndarray) -> pd.DataFrame:
    """``rows`` with ``cone_deg``, ``undetermined`` (beyond 90 deg: left out, never covered)
    and ``hit`` (the excess error inside the cone).
    """
    lost = undetermined(cone, rows["spread95_deg"])
    return rows.assign(cone_deg=cone, undetermined=lost, hit=~lost & (excess_error(rows) <= cone))


def criteria(data: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Per group ``by`` of judged rows (:func:`judged`): ``n`` (determined), ``n_undetermined``,
    ``coverage``, ``worst_cell``/``worst_cell_coverage`` (test x segment cells of at least
    :data:`MIN_CELL`), the medians of the cone and of the excess error, and their ratio.
    """
    kept = data[~data["undetermined"]].assign(excess=lambda d: excess_error(d))
    groups = kept.groupby(by, sort=False)
    cells = kept.groupby([*by, "test", "segment"], sort=False)["hit"].agg(["mean", "size"])
    cells = cells[cells["size"] >= MIN_CELL]["mean"].reset_index()
    worst = cells.loc[cells.groupby(by, sort=False)["mean"].idxmin()]
    worst = worst.assign(worst_cell=worst["test"] + " " + worst["segment"])
    table = pd.DataFrame(
        {
            "n": groups.size(),
            "n_undetermined": data.groupby(by, sort=False)["undetermined"].sum(),
            "coverage": groups["hit"].mean(),
            "cone_median_deg": groups["cone_deg"].median(),
            "error_median_deg": groups["excess"].median(),
        }
    ).reset_index()
    table["cone_over_error"] = table["cone_median_deg"] / table["error_median_deg"]
    worst = worst.rename(columns={"mean": "worst_cell_coverage"})[
        [*by, "worst_cell", "worst_cell_coverage"]
    ]
    return table.merge(worst, on=by, how="left")


def goal(coverage: float, cone_over_error: float) -> str:
    """'met', or 'not met: ...' naming what a cone misses of :data:`GOAL` on one dataset."""
    low, high = POOLED
    misses = [
        f"coverage {coverage:.0%} below {low:.0%}" if coverage < low else "",
        f"coverage {coverage:.0%} above {high:.0%}" if coverage > high else "",
        f"median cone {cone_over_error:.1f} times the median error, above {MAX_CONE_OVER_ERROR:g}"
        if cone_over_error > MAX_CONE_OVER_ERROR
        else "",
    ]
    misses = [m for m in misses if m]
    return "not met: " + "; ".join(misses) if misses else "met"


def fit_cone_model(rows: pd.DataFrame) -> ConeModel:
    """The cone model fitted on ``rows`` (:func:`usable`, with ``dataset``): :data:`WEIGHTS` and
    :func:`factors` (``q_other``, for a method without rows of its own: the largest).
    """
    q = factors(rows)
    return ConeModel(**WEIGHTS, q=q, q_other=max(q.values()))
