"""An uncertainty with a calibration: a bootstrap over its repetitions (beyond the papers), for
every calibration aceval makes from a motion test's repetitions, by every method of the registry
with a ``resample`` (:mod:`aceval.methods.registry`; not the peers', which run in their own
environments, nor Ricci's functional design, whose axes pool all trials of several tests).

Every repetition of a motion test is reduced to a few sums (:mod:`aceval.methods.sufficient`), so a
calibration from any resample of repetitions costs a few weighted 3x3 sums and one ``eigh``.
:func:`bootstrap_cones` draws ``n_boot`` resamples of each unit's repetitions with replacement
(Efron's bootstrap, the repetition as the unit), calibrates each by every method's ``resample``
(NaN where the method would flag it: counted as 180 deg away), and reports the 95th percentile
of the angle between a resample's calibration and the calibration from all repetitions (Kong
Eq. 11) as the half-angle of a 95 % cone, and the median share of those deviations about the
body vertical.

What it does not see: z0 from quiet standing is held (one static recording gives no resample),
so the cone is the heading's spread only; a bias shared by all repetitions (a sensor that does
not move in the segment's sagittal plane, soft tissue, a tilted stance) moves every resample
alike and is outside the cone. With 5 repetitions a bootstrap also underestimates the spread
(its variance is the plug-in one, (n - 1) / n of the unbiased). ``results/<dataset>/tables/
uncertainty`` measures the cone's coverage against the ground truth.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.rotations import relative_rotvec, rotvec_vertical_share
from aceval.methods.interface import CalibrationMethod
from aceval.methods.registry import classes, fit_order
from aceval.methods.sufficient import Units, pool

#: resamples per calibration (the 95th percentile of 200 angles: its 10th largest)
N_BOOT = 200
#: the cone's coverage level
LEVEL = 0.95
#: the accelerometer's zero-g offset, +-60 mg as 3 SD of a constant bias (InvenSense MPU-9250
#: datasheet, rev. 1.1; the simulator's, :class:`aceval.simulate.engine.ImuErrorModel`): what
#: tilts z0 from quiet standing
ACC_OFFSET_MG = 60.0
#: the RMS tilt (deg) of z0 that bias gives: two horizontal axes, each atan(bias / g)
TILT_SD_DEG = float(np.sqrt(2) * np.degrees(np.arctan(ACC_OFFSET_MG / 3 * 1e-3)))
#: a 1-D spread's 95th percentile over its SD (the bootstrap's spread is mostly heading)
Z95 = 1.959964
#: the model learned from simulations (:mod:`aceval.evaluation.coverage`): per method, test and
#: segment the heading bias ``tau_deg`` no resampling sees, and per method the factor ``q``
MODEL_PATH = Path(__file__).parent / "cone_model.csv"


def resample_weights(n_rep: int, n_boot: int = N_BOOT, seed: int = 0) -> np.ndarray:
    """(n_boot, n_rep): how often each repetition is drawn in each bootstrap resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_rep, np.full(n_rep, 1.0 / n_rep), size=n_boot).astype(float)


def cones(resampled: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cone95_deg, cone_vertical_share)`` (U,) of each unit's resampled calibrations (U, n_boot,
    3, 3) about its calibration ``R`` (U, 3, 3); NaN where ``R`` is. A resample the method would
    flag (not finite) counts as 180 deg away: the calibration is undetermined there, and
    leaving it out would narrow the cone (so a cone is 180 deg when more than 5 % are).
    """
    n_units, n_boot = resampled.shape[:2]
    ok = np.isfinite(resampled).all(axis=(2, 3)) & np.isfinite(R).all(axis=(1, 2))[:, None]
    rotvec = np.full((n_units, n_boot, 3), np.nan)
    rows, draws = np.nonzero(ok)
    rotvec[rows, draws] = relative_rotvec(resampled[rows, draws], R[rows])
    norm = np.linalg.norm(rotvec, axis=-1)
    share = rotvec_vertical_share(rotvec)
    judged = np.isfinite(R).all(axis=(1, 2))
    cone95, median_share = np.full(n_units, np.nan), np.full(n_units, np.nan)
    if judged.any():
        angles = np.where(ok[judged], np.degrees(norm[judged]), 180.0)
        cone95[judged] = np.percentile(angles, 100 * LEVEL, axis=1)
        some = judged & np.isfinite(share).any(axis=1)
        median_share[some] = np.nanmedian(share[some], axis=1)
    return cone95, median_share


def bootstrap_cones(
    units: Units,
    seeds: np.ndarray,
    R_full: dict[str, np.ndarray],
    n_boot: int = N_BOOT,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The 95 % cone of each method's calibration of each unit from all its repetitions:
    ``{method: (cone95_deg (U,), cone_vertical_share (U,))}`` for the methods of ``R_full``
    (method -> (U, 3, 3), NaN where none) that resample (:mod:`aceval.methods.registry`).

    Each unit draws ``n_boot`` resamples of its own repetitions from its own ``seeds`` (U,) (the
    same cones on every run and in any job); every method calibrates the same resamples, after
    the methods it needs.
    """
    present = units.present.sum(axis=1)
    weights = np.zeros((len(units) * n_boot, units.present.shape[1]))
    for u, (n_rep, seed) in enumerate(zip(present, seeds)):
        weights[u * n_boot : (u + 1) * n_boot, :n_rep] = resample_weights(int(n_rep), n_boot, seed)
    pooled = pool(units, np.repeat(np.arange(len(units)), n_boot), weights, subsets=False)
    methods = classes(R_full)
    fitted: dict[str, CalibrationMethod] = {}
    out = {}
    for name in fit_order(methods):
        if not methods[name].has_resample():
            continue
        fitted[name] = methods[name]().resample(pooled, fitted)
        if name in R_full:
            resampled = fitted[name].rotation_.reshape(len(units), n_boot, 3, 3)
            out[name] = cones(resampled, R_full[name])
    return out


# --- the cone: the repetitions' spread, the tilt and the shared heading bias -----------------


def fit_model(rows: pd.DataFrame) -> pd.DataFrame:
    """The model of a 95 % cone, ``q * sqrt((spread95 / Z95)^2 + TILT_SD^2 + tau^2)``, learned
    from calibrations with a truth (``rows``: method, test, segment, ``spread95_deg``,
    ``error_deg``): per (method, test, segment), ``tau_deg``, the RMS error the spread and the
    tilt leave unexplained, ``sqrt(max(mean(error^2) - mean(spread_sd^2) - TILT_SD^2, 0))``; per
    method, ``q``, the 95th percentile of the errors over their modelled RMS; and per method a
    row with test and segment '*' whose ``tau_deg`` is the largest of its cells (for a test or
    segment it never saw). ``n`` the calibrations behind each row.
    """
    data = rows.assign(spread_sd=rows["spread95_deg"] / Z95)
    cells = (
        data.groupby(["method", "test", "segment"], sort=True)
        .apply(
            lambda g: pd.Series(
                {
                    "tau_deg": np.sqrt(
                        max(
                            np.mean(g["error_deg"] ** 2)
                            - np.mean(g["spread_sd"] ** 2)
                            - TILT_SD_DEG**2,
                            0.0,
                        )
                    ),
                    "n": len(g),
                }
            ),
            include_groups=False,
        )
        .reset_index()
    )
    data = data.merge(cells[["method", "test", "segment", "tau_deg"]])
    rms = np.sqrt(data["spread_sd"] ** 2 + TILT_SD_DEG**2 + data["tau_deg"] ** 2)
    q = (data["error_deg"] / rms).groupby(data["method"]).quantile(LEVEL).rename("q")
    fallback = cells.groupby("method").agg(tau_deg=("tau_deg", "max"), n=("n", "sum")).reset_index()
    table = pd.concat([cells, fallback.assign(test="*", segment="*")], ignore_index=True)
    return table.merge(q.reset_index(), on="method")[
        ["method", "test", "segment", "tau_deg", "q", "n"]
    ]


@functools.lru_cache(maxsize=1)
def load_model(path=MODEL_PATH) -> pd.DataFrame | None:
    """The learned model (:func:`fit_model`), read once, or None where none has been learned."""
    return pd.read_csv(path) if Path(path).is_file() else None


def model_cones(spread95, method, test, segment, model: pd.DataFrame | None):
    """``(cone95_deg, source)`` of calibrations with bootstrap spreads ``spread95`` (deg) by
    ``method`` from ``test`` on ``segment`` (arrays): the model's cone, ``source`` 'cell' where
    the model learned that method, test and segment, 'method' where it falls back on the
    method's largest ``tau`` (a test or segment the simulations do not have), '' (and NaN) where
    it has no such method or the spread is NaN.
    """
    spread95 = np.asarray(spread95, float)
    n = len(spread95)
    cone, source = np.full(n, np.nan), np.full(n, "", dtype=object)
    if model is None or n == 0:
        return cone, source
    keys = pd.DataFrame({"method": method, "test": test, "segment": segment})
    learned = ["tau_deg", "q"]
    cell = keys.merge(model, on=["method", "test", "segment"], how="left")[learned]
    fallback = model[(model["test"] == "*") & (model["segment"] == "*")]
    fallback = keys[["method"]].merge(fallback, on="method", how="left")[learned]
    in_cell = cell["tau_deg"].notna().to_numpy()
    row = np.where(in_cell[:, None], cell.to_numpy(float), fallback.to_numpy(float))
    cone = row[:, 1] * np.sqrt((spread95 / Z95) ** 2 + TILT_SD_DEG**2 + row[:, 0] ** 2)
    source = np.where(in_cell, "cell", np.where(np.isfinite(row[:, 0]), "method", "")).astype(
        object
    )
    source[~np.isfinite(cone)] = ""
    return np.minimum(cone, 180.0), source
