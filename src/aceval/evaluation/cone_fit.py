"""The cone model's few constants, fitted across simulator variants and real truths (beyond the
papers; issue 39), and the criteria a cone is judged by.

The model (:class:`aceval.methods.uncertainty.ConeModel`) adds what the recording shows: the
spread of its repetitions, the other estimates' disagreement (other signals, other tests), Kong's
conditioning, and two a-priori terms. Three scales (``signals``, ``tests``, ``conditioning``) and a
factor ``q`` per method are fitted here (:func:`fit_cone_model`), on a grid of the scales:

* for each grid point, ``q`` of a method is the 95th percentile of its simulated errors over
  their modelled RMS, every simulator variant weighing alike;
* the grid point chosen is the one whose cones break the criteria (:data:`POOLED`, :data:`CELL`,
  :data:`MAX_CONE_OVER_ERROR`, :func:`penalty`) least on the training rows: per simulator
  variant and method, and on each real dataset's truths (pooled over methods, allowing for the
  truth's own uncertainty: the error minus ``truth_uncertainty_deg``), weighing as much as all
  the variants together.

Rows (:func:`usable`): the calibrations from all repetitions with a spread and an error to the
truth, unflagged but for ``heading_undetermined`` (which the cone itself decides: a row whose
cone is beyond 90 deg is dropped from the coverage as the flag drops it, never counted covered).
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from aceval.calibrate.table import flag_text
from aceval.methods.uncertainty import ConeModel, model_cones, undetermined

#: a 95 % cone covers within this range pooled (per method and dataset) ...
POOLED = (0.90, 0.99)
#: ... at least this much in every test x segment cell of at least :data:`MIN_CELL` calibrations
CELL, MIN_CELL = 0.80, 5
#: ... and its median is at most this many times the median error
MAX_CONE_OVER_ERROR = 3.0
#: the grid of the three scales
GRID = {
    "signals": (0.0, 0.25, 0.5, 0.75, 1.0),
    "tests": (0.0, 0.25, 0.5, 0.75),
    "conditioning": (0.0, 0.1, 0.2, 0.3, 0.4, 0.5),
}
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
    flags = flag_text(rows["flag"]).str.split(";")
    only = flags.map(lambda names: set(names) - {""} <= {"heading_undetermined"})
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


def factors(rows: pd.DataFrame, scales: dict, level: float = 0.95) -> dict[str, float]:
    """``q`` per method at these ``scales``: the weighted 95th percentile of the simulated rows'
    errors over their RMS (each dataset weighing alike).
    """
    sim = rows[rows["kind"] == "simulated"]
    rms = cones_of(sim, ConeModel(**scales, q={}, q_other=1.0))
    ratio = excess_error(sim) / rms
    weight = 1.0 / sim.groupby("dataset")["dataset"].transform("size").to_numpy(float)
    return {
        method: _weighted_quantile(ratio[at], weight[at], level)
        for method, at in sim.groupby("method").indices.items()
    }


def judged(rows: pd.DataFrame, cone: np.ndarray) -> pd.DataFrame:
    """``rows`` with ``cone_deg``, ``undetermined`` (beyond 90 deg: left out, never covered)
    and ``hit`` (the excess error inside the cone).
    """
    lost = undetermined(cone, rows["spread95_deg"])
    return rows.assign(cone_deg=cone, undetermined=lost, hit=~lost & (excess_error(rows) <= cone))


def penalty(table: pd.DataFrame) -> float:
    """How far a set of (dataset, method) rows of :func:`criteria` breaks the criteria: the
    pooled coverage outside :data:`POOLED`, the worst cell below :data:`CELL`, and a tenth of the
    median cone's excess over :data:`MAX_CONE_OVER_ERROR` times the median error, summed.
    """
    pooled = np.clip(POOLED[0] - table["coverage"], 0, None) + np.clip(
        table["coverage"] - POOLED[1], 0, None
    )
    cell = np.clip(CELL - table["worst_cell_coverage"].fillna(1.0), 0, None)
    ratio = 0.1 * np.clip(table["cone_over_error"] - MAX_CONE_OVER_ERROR, 0, None)
    return float((pooled + cell + ratio).sum())


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


def fit_cone_model(rows: pd.DataFrame, grid: dict = GRID) -> ConeModel:
    """The constants (module docstring) from ``rows`` (:func:`usable`, with ``dataset`` and
    ``kind`` 'simulated' or 'real').
    """
    best = None
    n_variants = rows.loc[rows["kind"] == "simulated", "dataset"].nunique()
    for values in itertools.product(*grid.values()):
        scales = dict(zip(grid, values))
        q = factors(rows, scales)
        model = ConeModel(**scales, q=q, q_other=max(q.values()))
        data = judged(rows, cones_of(rows, model))
        sim = data[data["kind"] == "simulated"]
        score = penalty(criteria(sim, ["dataset", "method"]))
        real = data[data["kind"] == "real"]
        if len(real):
            pooled = criteria(real, ["dataset"]).assign(
                worst_cell_coverage=np.nan, cone_over_error=0.0
            )
            score += n_variants * penalty(pooled)
        if best is None or score < best[0] - 1e-12:
            best = (score, model)
    return best[1]
