"""An uncertainty with a calibration (beyond the papers): for every calibration aceval makes from
all repetitions of a motion test, by every method of the registry with a ``resample``
(:mod:`aceval.methods.registry`; not the peers', which run in their own environments, nor Ricci's
functional design, whose axes pool all trials of several tests), a cone about it whose every term
the recording itself shows (:func:`calibration_cones`; docs/uncertainty.md):

* the spread of its repetitions (the bootstrap below);
* how far the recording's other estimates of the same heading lie: the other signals' calibrations
  of the same IMU in the same test (the accelerations' plane, the gyroscope's axis, the step's
  direction) and the same method's calibrations of the IMU from its other tests
  (:func:`heading_terms`);
* how well the motion fixes the heading: Kong's smallest/middle eigenvalue ratio of the
  accelerations (a plane normal is decided only by how much the in-plane spread exceeds the
  out-of-plane one);
* two a-priori terms that no recording of one sensor shows: the tilt of z0 from the
  accelerometer's datasheet bias and, for the foot, how far its own plane of motion turns from
  the body's (the foot progression angle).

Their scales are constants in :data:`CONE_MODEL`, fitted across simulator variants and checked on
real truths by :mod:`aceval.evaluation.coverage` (``results/coverage``). A cone beyond
:data:`UNDETERMINED_CONE_DEG`, or one whose spread cannot be estimated, is no cone: the calibration
is flagged ``heading_undetermined`` (:func:`undetermined`).

The bootstrap:

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

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from aceval.data.rotations import error_angle_deg, relative_rotvec, rotvec_vertical_share
from aceval.methods.interface import CalibrationMethod
from aceval.methods.registry import classes, cone_references, fit_order, signals
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
#: a calibration whose cone is wider than this (deg) has no determined heading: flagged
#: ``heading_undetermined`` (a heading 90 deg off swaps forward and sideways)
UNDETERMINED_CONE_DEG = 90.0
#: a spread needs at least this many repetitions to resample (one gives a spread of 0)
MIN_REPETITIONS = 2


def resample_weights(n_rep: int, n_boot: int = N_BOOT, seed: int = 0) -> np.ndarray:
    """(n_boot, n_rep): how often each repetition is drawn in each bootstrap resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_rep, np.full(n_rep, 1.0 / n_rep), size=n_boot).astype(float)


def cones(resampled: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(spread95_deg, spread_vertical_share)`` (U,) of each unit's resampled calibrations (U,
    n_boot, 3, 3) about its calibration ``R`` (U, 3, 3); NaN where ``R`` is. A resample the method
    would flag (not finite) counts as 180 deg away: the calibration is undetermined there, and
    leaving it out would narrow the spread (so a spread is 180 deg when more than 5 % are).
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
    """The 95th percentile of the bootstrap's spread about each method's calibration of each unit
    from all its repetitions: ``{method: (spread95_deg (U,), spread_vertical_share (U,))}`` for the
    methods of ``R_full`` (method -> (U, 3, 3), NaN where none) that resample
    (:mod:`aceval.methods.registry`).

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


# --- the cone: what the recording shows, scaled by constants fitted across simulator variants ---

#: how far a segment's own plane of motion turns from the body's sagittal plane (deg, RMS), which
#: no recording of the segment alone shows: the foot's progression angle, 7 +- 3 deg toe-out
#: (Perry & Burnfield 2010, *Gait Analysis*, Ch. 4; the simulator's, docs/simulation.md)
SEGMENT_PLANE_DEG = {"foot": float(np.hypot(7.0, 3.0))}


@dataclass(frozen=True)
class ConeModel:
    """``cone = q[method] * sqrt((spread95 / Z95)^2 + TILT_SD^2 + plane^2 + (signals * d_signals)^2
    + (tests * d_tests)^2 + (conditioning * c)^2)`` (deg): ``d_signals`` and ``d_tests`` the
    disagreements of :func:`heading_terms`, ``c = atan(sqrt(normal_ratio))`` (deg) of Kong's plane,
    ``plane`` :data:`SEGMENT_PLANE_DEG`; ``signals``, ``tests`` and ``conditioning`` their weights.
    ``q`` per method: the factor that turns the combined RMS into a 95 % cone, split-conformally.
    A method without one (added since the fit) gets ``q_other``, the largest fitted, and its rows
    say so (``cone_fit`` 'not validated', :meth:`validated`) until the coverage study is run
    again. Fitted by :func:`aceval.evaluation.cone_fit.fit_cone_model`.
    """

    signals: float
    tests: float
    conditioning: float
    q: Mapping[str, float] = field(default_factory=dict)
    q_other: float = 2.0

    def factor(self, method) -> np.ndarray:
        """``q`` of each method in ``method`` (array of names)."""
        return np.array([self.q.get(m, self.q_other) for m in np.atleast_1d(method)], float)

    def validated(self, method: str) -> bool:
        """Whether the coverage study fitted this method's ``q`` (its cone's coverage measured)."""
        return method in self.q


#: fitted by ``python -m aceval.evaluation.coverage`` (results/coverage/model.csv, fit 'all';
#: docs/uncertainty.md): nine simulator variants and the real truths of NeuRA and gaitmap_feet;
#: tests/test_coverage.py checks that these are the committed study's constants
CONE_MODEL = ConeModel(
    signals=1.0,
    tests=1.0,
    conditioning=1.0,
    q={
        "kong": 0.8373,
        "ricci_lm": 0.7205,
        "align_vectors": 0.7205,
        "triad": 0.7318,
        "combined": 0.8854,
        "step_harmonic": 0.6330,
    },
    q_other=0.8854,
)
#: the models fitted without each real truth of the study (its fits 'left out: <name>'): the
#: cones of a dataset of that name (:func:`cone_model`), judged out of sample on its own truth
LEFT_OUT = {
    "neura": ConeModel(
        signals=1.0,
        tests=1.0,
        conditioning=1.0,
        q={
            "kong": 0.8589,
            "ricci_lm": 0.7303,
            "align_vectors": 0.7303,
            "triad": 0.7400,
            "combined": 0.9024,
            "step_harmonic": 0.7174,
        },
        q_other=0.9024,
    ),
    "gaitmap_feet": ConeModel(
        signals=1.0,
        tests=1.0,
        conditioning=1.0,
        q={
            "kong": 0.8723,
            "ricci_lm": 0.7313,
            "align_vectors": 0.7313,
            "triad": 0.7409,
            "combined": 0.9057,
            "step_harmonic": 0.6330,
        },
        q_other=0.9057,
    ),
}


def heading_terms(
    R_full: Mapping[str, np.ndarray], imu: np.ndarray, normal_ratio: np.ndarray
) -> dict[str, np.ndarray]:
    """What the recording shows of the heading's uncertainty, per unit (IMU x test; ``imu`` (U,)
    labels the units' IMUs) from every method's calibration from all repetitions (``R_full``:
    method -> (U, 3, 3), NaN where none), in deg:

    * ``{method}_signals``: the median angle to the other signals' reference calibrations of the
      same unit (each signal's method declaring ``cone_reference``,
      :func:`aceval.methods.registry.cone_references`: a method that is none changes no other
      method's cone); NaN where there is none;
    * ``{method}_tests``: the median angle to the same method's calibrations of the same IMU from
      its other tests; NaN where it has none;
    * ``conditioning``: ``atan(sqrt(normal_ratio))`` of Kong's plane of the unit (the tilt an
      out-of-plane spread that correlates with the in-plane one can give the normal); NaN where
      Kong has no plane.
    """
    imu = np.asarray(imu)
    n = len(imu)
    ok = {m: np.isfinite(R).all(axis=(1, 2)) for m, R in R_full.items()}
    out = {"conditioning": np.degrees(np.arctan(np.sqrt(np.clip(normal_ratio, 0.0, None))))}
    same_imu = imu[:, None] == imu[None, :]
    signal, reference = signals(), cone_references()
    for method, R in R_full.items():
        references = [m for s, m in reference.items() if m in R_full and s != signal.get(method)]
        angles = np.full((len(references), n), np.nan)
        for k, other in enumerate(references):
            both = ok[method] & ok[other]
            angles[k, both] = error_angle_deg(R[both], R_full[other][both])
        out[f"{method}_signals"] = _nanmedian(angles, axis=0)
        pairs = np.full((n, n), np.nan)
        both = ok[method][:, None] & ok[method][None, :]
        rows, cols = np.nonzero(same_imu & ~np.eye(n, dtype=bool) & both)
        pairs[rows, cols] = error_angle_deg(R[rows], R[cols])
        out[f"{method}_tests"] = _nanmedian(pairs, axis=1)
    return out


def _nanmedian(values: np.ndarray, axis: int) -> np.ndarray:
    """np.nanmedian without its warning on all-NaN slices (NaN there)."""
    some = np.isfinite(values).any(axis=axis)
    out = np.full(some.shape, np.nan)
    if some.any():
        out[some] = np.nanmedian(np.compress(some, values, axis=1 - axis), axis=axis)
    return out


def model_cones(spread95, signals, tests, conditioning, segment, method, model=CONE_MODEL):
    """The cone (deg) of calibrations with these terms (arrays; :class:`ConeModel`): a missing
    disagreement (no other estimate) or conditioning counts 0; NaN where the spread is NaN; at
    most 180 deg.
    """
    spread95 = np.asarray(spread95, float)
    plane = np.array([SEGMENT_PLANE_DEG.get(s, 0.0) for s in np.atleast_1d(segment)], float)
    rms = np.sqrt(
        (spread95 / Z95) ** 2
        + TILT_SD_DEG**2
        + plane**2
        + (model.signals * np.nan_to_num(np.asarray(signals, float))) ** 2
        + (model.tests * np.nan_to_num(np.asarray(tests, float))) ** 2
        + (model.conditioning * np.nan_to_num(np.asarray(conditioning, float))) ** 2
    )
    return np.minimum(model.factor(method) * rms, 180.0)


def undetermined(cone, spread95) -> np.ndarray:
    """True where a calibration's heading is undetermined: its cone, or the spread of its
    repetitions alone (whatever the cone's factor makes of it: 180 deg where more than 5 % of the
    resamples are flagged), beyond :data:`UNDETERMINED_CONE_DEG`, or not estimable (NaN: too few
    repetitions to resample).
    """
    cone, spread95 = np.asarray(cone, float), np.asarray(spread95, float)
    return ~(cone <= UNDETERMINED_CONE_DEG) | ~(spread95 <= UNDETERMINED_CONE_DEG)


def cone_model(dataset: str) -> tuple[str, ConeModel]:
    """``(fit, model)``: the cone model a dataset's calibrations get: the one fitted without its
    truth where the coverage study fitted on it (:data:`LEFT_OUT`, by the dataset's name: its cones
    are then judged out of sample), else :data:`CONE_MODEL` ('all').
    """
    if dataset in LEFT_OUT:
        return f"left out: {dataset}", LEFT_OUT[dataset]
    return "all", CONE_MODEL


def calibration_cones(
    units: Units,
    seeds: np.ndarray,
    R_full: dict[str, np.ndarray],
    imu: np.ndarray,
    normal_ratio: np.ndarray,
    model: ConeModel = CONE_MODEL,
) -> dict[str, dict[str, np.ndarray]]:
    """Every term and the cone of each method's calibration of each unit from all its
    repetitions: ``{method: {column: (U,)}}`` with ``spread95_deg``, ``spread_vertical_share``
    (:func:`bootstrap_cones`; NaN with fewer than :data:`MIN_REPETITIONS`),
    ``heading_signals_deg``, ``heading_tests_deg``, ``conditioning_deg`` (:func:`heading_terms`;
    ``imu`` (U,) labels each unit's IMU, ``normal_ratio`` (U,) is Kong's) and ``cone_deg``
    (:func:`model_cones` of ``model``), for the methods of ``R_full`` that resample.
    """
    spreads = bootstrap_cones(units, seeds, R_full)
    terms = heading_terms(R_full, imu, normal_ratio)
    few = units.present.sum(axis=1) < MIN_REPETITIONS
    out = {}
    for method, (spread, share) in spreads.items():
        spread = np.where(few, np.nan, spread)
        columns = {
            "spread95_deg": spread,
            "spread_vertical_share": share,
            "heading_signals_deg": terms[f"{method}_signals"],
            "heading_tests_deg": terms[f"{method}_tests"],
            "conditioning_deg": terms["conditioning"],
        }
        columns["cone_deg"] = model_cones(
            spread,
            columns["heading_signals_deg"],
            columns["heading_tests_deg"],
            columns["conditioning_deg"],
            units.segment,
            np.full(len(spread), method),
            model,
        )
        out[method] = columns
    return out
