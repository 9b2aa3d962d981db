"""What the decision chooses by (beyond both papers; :mod:`aceval.evaluation.decision`): for each
IMU, the evidence for every method and test it could use, taken from the other sensors of its
segment, and an order of its calibrations that does not flip on noise.

* **Evidence** (:func:`evidence_units`, :func:`cross_fitted`): per method, test, sensor set and
  segment (a cell), each IMU's error to the ground truth ('accuracy') or, without a truth, its
  test-retest angle ('repeatability', Kong Eq. 15: repeatability, not accuracy), of the
  calibrations the decision may choose. The evidence for one IMU is the median over the cell's
  *other* IMUs (the other subjects', the other side's): cross-fitted, never the IMU's own error,
  which the decision is then judged by. Its uncertainty is the median's standard error,
  ``sqrt(pi / 2) * 1.4826 * MAD / sqrt(n)`` (the normal approximation, the SD from the median
  absolute deviation), infinite with fewer than 2 other IMUs.
* **The order** (:func:`ranked`): of the calibrations with an uncertainty measured on the
  recording (a peer has none: it is a cross-check, ordered only where nothing else can be), the
  best evidence first; those whose evidence differs from the best by no more than the two
  uncertainties in quadrature (one standard error of the difference), or that have none, are a
  tie, ordered by: a cone within the tolerance T first, then one within 2T, then the others; in
  each, a calibration that agrees with the other methods before one flagged ``methods_disagree``
  (on kong_powered's truth those lie 4.6 deg from it, the others 2.7), then the registry's order
  of methods (:mod:`aceval.methods.registry`: Kong's first; beyond 2T the smaller cone first, the
  best available), then the test's name; the others follow by their evidence. The first is
  chosen; the second is the runner-up, and the margin is its evidence minus the chosen one's
  (negative where the tie chose the worse median).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import has_flag
from aceval.methods import registry

#: an IMU of a subject
IMU_KEY = ["subject", "sensor_set", "imu"]
#: what the evidence is pooled over: a method's calibrations of one segment in one test and set
CELL = ["segment", "test", "sensor_set", "method"]
#: a median's standard error over the SD, for normal data: sqrt(pi / 2)
MEDIAN_SE = float(np.sqrt(np.pi / 2))
#: the SD over the median absolute deviation, for normal data
MAD_SD = 1.4826
#: an IMU's cell: the key of its evidence
UNIT = [*IMU_KEY, *(c for c in CELL if c not in IMU_KEY)]
#: the evidence columns of a calibration (deg, deg, count)
EVIDENCE_COLUMNS = ["evidence_median_deg", "evidence_uncertainty_deg", "evidence_n"]


def evidence_units(
    full: pd.DataFrame, calibrations: pd.DataFrame, test_retest_k: int, retest_units=None
) -> tuple[pd.DataFrame, str]:
    """``(units, basis)``: one ``value`` (deg) per IMU and cell of the calibrations from all
    repetitions the decision may choose (``full``): their error to the ground truth (basis
    'accuracy') or, where no calibration has one, the IMU's test-retest angle of that method and
    test (basis 'repeatability'; :func:`aceval.evaluation.methods_comparison.every_retest_unit` of
    ``calibrations`` and the precomputed ``retest_units``).
    """
    from aceval.evaluation.methods_comparison import every_retest_unit

    columns = [*UNIT, "value"]
    error = full["error_deg"].astype(float) if "error_deg" in full else pd.Series(dtype=float)
    if np.isfinite(error).any():
        units = full[np.isfinite(error)].assign(value=error)
        return units[columns].reset_index(drop=True), "accuracy"
    units = every_retest_unit(calibrations, test_retest_k, retest_units)
    if units.empty:
        return pd.DataFrame(columns=columns), "repeatability"
    units = units.rename(columns={"error_angle_deg": "value"})
    chosen = full[[*IMU_KEY, "test", "method"]].drop_duplicates()
    units = units.merge(chosen, on=[*IMU_KEY, "test", "method"])
    return units[columns].reset_index(drop=True), "repeatability"


def cross_fitted(units: pd.DataFrame, wanted: pd.DataFrame) -> pd.DataFrame:
    """For each row of ``wanted`` (an IMU and a cell), :data:`EVIDENCE_COLUMNS` from the
    ``units`` of its cell that are not its IMU's (module docstring): NaN median and n 0 where
    there are none.
    """
    out = wanted[UNIT].drop_duplicates().reset_index(drop=True)
    median, spread, n = np.full(len(out), np.nan), np.full(len(out), np.nan), np.zeros(len(out))
    cells = units.groupby(CELL, sort=False).indices
    for cell, at in out.groupby(CELL, sort=False).indices.items():
        if cell not in cells:
            continue
        mine = units.iloc[cells[cell]]
        others = _imus(out.iloc[at])[:, None] != _imus(mine)[None, :]
        values = np.where(others, mine["value"].to_numpy(float)[None, :], np.nan)
        n[at] = np.isfinite(values).sum(axis=1)
        some = n[at] > 0
        rows = at[some]
        median[rows] = np.nanmedian(values[some], axis=1)
        spread[rows] = np.nanmedian(np.abs(values[some] - median[rows][:, None]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.where(n >= 2, MEDIAN_SE * MAD_SD * spread / np.sqrt(n), np.inf)
    return out.assign(
        evidence_median_deg=median, evidence_uncertainty_deg=se, evidence_n=n.astype(int)
    )


def _imus(table: pd.DataFrame) -> np.ndarray:
    """Each row's IMU as one label."""
    return table[IMU_KEY].astype(str).agg("|".join, axis=1).to_numpy()


def ranked(candidates: pd.DataFrame, tolerance: float) -> tuple[pd.DataFrame, int]:
    """``(order, n_tied)``: one IMU's calibrations (with ``cone_deg`` and
    :data:`EVIDENCE_COLUMNS`) in the decision's order (module docstring) and how many tie for the
    first place.
    """
    cone = candidates["cone_deg"].to_numpy(float)
    peer = candidates["method"].map(lambda m: m in registry.peers()).to_numpy()
    measured = np.isfinite(cone) & ~peer
    pool = candidates[measured] if measured.any() else candidates
    median = pool["evidence_median_deg"].to_numpy(float)
    se = np.where(np.isfinite(median), pool["evidence_uncertainty_deg"].to_numpy(float), np.inf)
    tied = np.ones(len(pool), dtype=bool)
    if np.isfinite(median).any():
        best = int(np.nanargmin(median))
        with np.errstate(invalid="ignore"):
            tied = ~(median - median[best] > np.hypot(se, se[best]))
    cone = pool["cone_deg"].to_numpy(float)
    within = np.where(cone <= tolerance, 0, np.where(cone <= 2 * tolerance, 1, 2))
    beyond = within == 2  # not within 2T (or unmeasured): the smaller cone, the best available
    disagrees = has_flag(pool["flag"], "methods_disagree").to_numpy()
    order = pool.assign(
        _after=~tied,
        _class=np.where(tied, within, 0),
        _disagrees=tied & disagrees,
        _cone=np.where(tied & beyond, np.nan_to_num(cone, nan=np.inf), 0.0),
        _evidence=np.where(tied, 0.0, median),
        _rank=pool["method"].map(registry.rank),
    )
    keys = ["_after", "_class", "_disagrees", "_cone", "_evidence", "_rank"]
    order = order.sort_values([*keys, "test"], kind="stable").drop(columns=keys)
    return order.reset_index(drop=True), int(tied.sum())
