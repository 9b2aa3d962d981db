"""From a dataset's per-recording statistics to calibrations: rotations and flags, nothing else
(evaluation joins the truth afterwards, :func:`aceval.evaluation.methods_comparison.with_truth`).

Data flows one way (docs/architecture.md): :mod:`aceval.signals.reduction` reads each recording
once and reduces it to a summary; :func:`aceval.calibrate.plan.build_plan` resolves each IMU's
inputs once (z0, right axis, the sensor checks' verdicts, the statistics of each motion test's
repetitions, which subsets); every method of :mod:`aceval.methods.registry` fits its calibrations
from the pooled statistics, all units of the job at once; the checks of
:mod:`aceval.signals.checks` add their flags; :mod:`aceval.methods.uncertainty` gives each
calibration from all repetitions its cone; :mod:`aceval.calibrate.rows` writes the table.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.plan import EVERY_SUBSET, RETEST, Plan, Subsets, build_plan
from aceval.calibrate.ricci_design import calibrate_functional
from aceval.calibrate.rows import calibration_rows, motion_axes
from aceval.calibrate.table import (
    AXES_COLUMNS,
    CALIBRATION_COLUMNS,
    KEY,
    SIGN_VERIFIED,
    combine_flags,
    full_set_rows,
    has_flag,
    rows_of_method,
    unflagged,
)
from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import Dataset
from aceval.data.rotations import error_angle_deg
from aceval.methods import registry
from aceval.methods.interface import CalibrationMethod, Fit
from aceval.methods.kong import KongLimits
from aceval.methods.sufficient import Pooled, pool
from aceval.methods.uncertainty import calibration_cones, cone_model
from aceval.signals.checks import direction_checks
from aceval.signals.gait_sign import gait_right

#: a subset's calibration farther than this from its unit's calibration from all repetitions is
#: ``unstable`` (:func:`flag_unstable`): Kong's Obj 5 finds calibrations of one IMU from different
#: tests within "about 5 deg" (Table 11), so a subset of one test's repetitions farther from that
#: test's own calibration disagrees with it more than whole tests do in the paper
UNSTABLE_DEG = 5.0
#: the ``cone_fit`` of a method whose cone factor no coverage study fitted (it has the largest
#: fitted one, :class:`aceval.methods.uncertainty.ConeModel`): its cone's coverage is unknown
NOT_VALIDATED = "not validated: no fitted cone factor (the largest used); run the coverage study"


def calibrate(
    dataset: Dataset,
    summaries: pd.DataFrame,
    subsets: str = "all",
    retest_k: int | None = 3,
    sensors: dict | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every calibration of the IMUs in ``summaries``: ``(calibrations, axes)``.

    Datasets with ``functional_axes.tsv`` (Ricci's protocol) get the functional design
    (:func:`calibrate_functional`); the others Kong's sagittal design (:func:`calibrate_sagittal`).
    ``sensors``: :func:`aceval.calibrate.plan.imu_checks` when the caller has it already.
    """
    if dataset.functional_axes is not None:
        return calibrate_functional(dataset, summaries, sensors)
    return calibrate_sagittal(dataset, summaries, subsets, retest_k, sensors)


def calibrate_sagittal(
    dataset: Dataset,
    summaries: pd.DataFrame,
    subsets: str = "all",
    retest_k: int | None = 3,
    sensors: dict | None = None,
    methods: list[str] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every method's calibrations of every (subject, set, IMU, motion test) in ``summaries``
    (``methods``: these of the registry's, default all): a method fitted on every subset
    (``every_subset``: Kong's) on every subset of its usable repetitions (``subsets='all'``) or
    all of them together (``'full'``), the others on all of them and, with ``retest_k``, on
    every subset of that many (Obj 4's test-retest for every method).

    One row per calibration: key columns, ``repetitions`` ('R1+R3+R4'), ``n_reps``, ``method``,
    r11..r33, the method's diagnostics, the sensor checks' evidence, ``rho_static`` and
    ``rho_motion`` (the reliability of the static and gyroscope axes, Ricci Eq. 2), ``z0_tests``
    (the static test(s) z0 came from), the cone of the calibrations from all repetitions
    (``cone_deg`` and its terms: :func:`aceval.methods.uncertainty.calibration_cones`; ``cone_fit``:
    the fit of the cone model, :func:`aceval.methods.uncertainty.cone_model`), ``flag``
    ('' when valid; ``heading_undetermined`` where that cone is no cone) and ``error_deg``,
    ``error_vertical_share`` left empty (calibration knows no truth). ``axes``: one row per
    (subject, set, IMU, test) with the axis and rho of all its repetitions.
    """
    plan = build_plan(dataset, summaries, subsets, retest_k, sensors)
    if not len(plan.units):
        return pd.DataFrame(columns=CALIBRATION_COLUMNS), plan.static_axes
    names = methods or registry.own()
    classes = registry.classes(names)
    policy_of = {name: EVERY_SUBSET if classes[name].every_subset else RETEST for name in names}
    pooled = {policy: pool(plan.units, s.unit, s.weights) for policy, s in plan.subsets.items()}
    fitted = {
        policy: _fits([n for n in names if policy_of[n] == policy], pooled[policy])
        for policy in plan.subsets
    }
    tables, R_full = [], {}
    checked: dict[str, Fit] = {}
    for name in names:
        policy = policy_of[name]
        rows = pooled[policy]
        fit = _checked(plan, plan.subsets[policy], fitted[policy][name].result)
        checked[name] = flag_unstable(fit, rows, retest_k)
        R_full[name] = checked[name].R[_full_rows(rows)]
    cones = _cones(plan, checked, pooled, policy_of, R_full, dataset.name)
    for order, name in enumerate(checked):
        policy = policy_of[name]
        rows = pooled[policy]
        chosen = None if classes[name].every_subset else classes[name]().applies(rows)
        tables.append(
            calibration_rows(
                plan,
                plan.subsets[policy],
                rows,
                name,
                checked[name],
                order,
                cones,
                _full_rows(rows),
                chosen,
                block=policy == RETEST,
            )
        )
    calibrations = pd.concat([t for t in tables if len(t)], ignore_index=True)
    calibrations = calibrations.sort_values(
        ["_unit", "_block", "_subset", "_method"], kind="stable"
    ).drop(columns=["_unit", "_block", "_subset", "_method"])
    retest = pooled[RETEST]
    axes = pd.concat(
        [plan.static_axes, motion_axes(plan, retest, _full_rows(retest))], ignore_index=True
    )
    return propagate_backward(calibrations.reset_index(drop=True)), axes[AXES_COLUMNS]


def _cones(plan, checked: dict, pooled: dict, policy_of: dict, R_full: dict, dataset: str) -> dict:
    """Every resampling method's cone of each unit and its terms
    (:func:`aceval.methods.uncertainty.calibration_cones`, with Kong's plane's conditioning), and
    ``cone_fit``: the fit of the cone model the ``dataset`` gets (the one fitted without its truth
    where the cone was fitted on it: :func:`aceval.methods.uncertainty.cone_model`), 'not
    validated' for a method the model has no fitted factor of.
    """
    imu = plan.identity[["subject", "sensor_set", "imu"]].astype(str).agg("|".join, axis=1)
    kong = registry.paper_method("kong2016")  # Kong's plane: every heading's conditioning
    normal_ratio = np.full(len(plan.units), np.nan)
    if kong in checked:
        normal_ratio = checked[kong].columns["normal_ratio"][_full_rows(pooled[policy_of[kong]])]
    fit, model = cone_model(dataset)
    cones = calibration_cones(
        plan.units, plan.identity["seed"].to_numpy(), R_full, imu.to_numpy(), normal_ratio, model
    )
    for method, columns in cones.items():
        said = fit if model.validated(method) else NOT_VALIDATED
        columns["cone_fit"] = np.full(len(plan.units), said, dtype=object)
    return cones


def _fits(names: list[str], pooled: Pooled) -> dict[str, CalibrationMethod]:
    """The methods ``names`` fitted on the rows of ``pooled``, each after the methods it needs,
    fitted on the same rows (what it reads: the combined heading reads Kong's plane).
    """
    classes = registry.classes(names) if names else {}
    fitted: dict[str, CalibrationMethod] = {}
    for name in registry.fit_order(classes):
        fitted[name] = classes[name]().fit(pooled, fitted)
    return fitted


def _full_rows(pooled: Pooled) -> np.ndarray:
    """(U,) the row of each unit's calibration from all repetitions."""
    full = np.full(pooled.unit.max() + 1 if len(pooled) else 0, -1)
    at = np.flatnonzero(pooled.all_repetitions)
    full[pooled.unit[at]] = at
    return full


def _checked(plan: Plan, subsets: Subsets, fit: Fit) -> Fit:
    """A method's calibrations of ``subsets`` with the sensor checks' flags and the direction
    checks' (:func:`aceval.signals.checks.direction_checks`: the declared right axis on the
    calibration's own y, forward or backward on its own repetitions; nothing inherited from the
    calibration of all of them), and their evidence, on every row it calibrated. A method's own
    ``not_applicable`` stays alone. Where the method reports its plane normal's eigenvalue ratio
    (Kong's ``normal_ratio``) and it is undetermined, the right axis is ``right_axis_unchecked``,
    not a mismatch: the y axis then says nothing about the declaration.
    """
    sensor = plan.identity["sensor_flag"].to_numpy()[subsets.unit]
    flag = np.array(
        [f if f == "not_applicable" else combine_flags(s, f) for s, f in zip(sensor, fit.flag)],
        dtype=object,
    )
    columns = dict(fit.columns)
    columns["first_phase_agreement"] = np.full(len(fit), np.nan)
    columns["right_axis_angle_deg"] = np.full(len(fit), np.nan)
    columns[SIGN_VERIFIED] = np.zeros(len(fit), dtype=bool)
    checked = np.flatnonzero(np.isfinite(fit.R).all(axis=(1, 2)))
    units = plan.units
    unit = subsets.unit[checked]
    cues = [units.get(name) for name in ("foot_right", "trunk_right", "gait_strength")]
    direction = direction_checks(
        units.first_phase[unit],
        units.segment[unit],
        units.phases[unit],
        None if units.get("third") is None else units.get("third")[unit],
        subsets.weights[checked],
        fit.R[checked],
        units.right[unit],
        _undetermined(fit, checked),
        None if cues[0] is None else gait_right(units.segment[unit], *(c[unit] for c in cues)),
    )
    for key in ("first_phase_agreement", "right_axis_angle_deg"):
        columns[key][checked] = direction[key]
    columns[SIGN_VERIFIED][checked] = direction["sign_verified"]
    flag[checked] = [combine_flags(f, found) for f, found in zip(flag[checked], direction["flag"])]
    return Fit(fit.R, flag, columns)


def _undetermined(fit: Fit, rows: np.ndarray) -> np.ndarray | None:
    """Where the ``rows`` of a fit that reports its plane normal's ratio have it undetermined
    (above :attr:`aceval.methods.kong.KongLimits.max_normal_ratio`); None for other fits.
    """
    if "normal_ratio" not in fit.columns:
        return None
    return ~(np.asarray(fit.columns["normal_ratio"])[rows] <= KongLimits().max_normal_ratio)


def flag_unstable(fit: Fit, pooled: Pooled, retest_k: int | None) -> Fit:
    """Each calibration from a subset of a unit's repetitions more than :data:`UNSTABLE_DEG` from
    the same method's calibration from all of them is flagged ``unstable`` (column
    ``full_set_angle_deg``), and so is the calibration from all of them when most of its
    test-retest subsets (:data:`aceval.calibrate.plan` ``retest_k`` repetitions) are: which
    repetitions are included then decides the answer. Two unflagged calibrations of one unit
    are thus within twice that angle of each other. Kong's Obj 3-4 and the methods' test-retest,
    which measure this spread, keep calibrations whose only flag is ``unstable``
    (:func:`aceval.calibrate.table.spread_usable`).
    """
    full = _full_rows(pooled)
    at = full[pooled.unit]
    finite = np.isfinite(fit.R).all(axis=(1, 2))
    ok = (at >= 0) & finite & finite[np.maximum(at, 0)]
    angle = np.full(len(pooled), np.nan)
    angle[ok] = error_angle_deg(fit.R[ok], fit.R[at[ok]])
    unstable = angle > UNSTABLE_DEG
    n_reps = pooled.weights.sum(axis=1)
    retest = ~pooled.all_repetitions & (n_reps == (retest_k or 0))
    for unit in np.unique(pooled.unit[retest & ok]):
        rows = retest & ok & (pooled.unit == unit)
        if unstable[rows].mean() > 0.5:
            unstable[full[unit]] = True
    flag = np.array(
        [combine_flags(f, "unstable" if u else "") for f, u in zip(fit.flag, unstable)],
        dtype=object,
    )
    return Fit(fit.R, flag, fit.columns | {"full_set_angle_deg": angle})


def propagate_backward(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Tests whose direction cannot be checked (e.g. the thigh in walking) inherit the verdict of a
    checked test of the same IMU: every test's y axis takes its sign from the same ``right_axis``,
    so a calibration within 90 deg of one found backward is backward too. Judged on Kong's
    calibrations from all repetitions; the flag goes to every calibration (and method) of the test.
    The sign verified elsewhere carries over likewise (:func:`propagate_verified`).
    """
    if calibrations.empty or "first_phase_agreement" not in calibrations:
        return calibrations
    full = full_set_rows(rows_of_method(calibrations))
    flags = np.where(unflagged(calibrations), "", calibrations["flag"].astype(str)).astype(object)
    for _, imu in full.groupby(KEY, sort=False):
        backward = imu[has_flag(imu["flag"], "backward")]
        unchecked = imu[imu["first_phase_agreement"].isna() & unflagged(imu)]
        if backward.empty or unchecked.empty:
            continue
        R_unchecked = unchecked[R_COLUMNS].to_numpy(float).reshape(-1, 1, 3, 3)
        R_backward = backward[R_COLUMNS].to_numpy(float).reshape(1, -1, 3, 3)
        near = (error_angle_deg(R_unchecked, R_backward) < 90.0).any(axis=1)
        for test in unchecked["test"][near]:
            same = (
                (calibrations[KEY] == imu.iloc[0][KEY]).all(axis=1) & (calibrations["test"] == test)
            ).to_numpy()
            flags[same] = [combine_flags(f, "backward") for f in flags[same]]
    return propagate_verified(calibrations.assign(flag=flags))


def propagate_verified(calibrations: pd.DataFrame) -> pd.DataFrame:
    """A calibration whose direction its own recordings cannot judge (``first_phase_agreement``
    NaN) has its sign verified (:data:`SIGN_VERIFIED`) when it is within 90 deg of one of Kong's
    calibrations of the same IMU from all repetitions whose recordings verified it, and none of
    the IMU's such calibrations is ``backward``: every test's y axis takes its sign from the same
    ``right_axis``.
    """
    if SIGN_VERIFIED not in calibrations:
        return calibrations
    verified = calibrations[SIGN_VERIFIED].to_numpy(bool).copy()
    unjudged = calibrations["first_phase_agreement"].isna().to_numpy()
    matrices = calibrations[R_COLUMNS].to_numpy(float)
    finite = np.isfinite(matrices).all(axis=1)
    full = full_set_rows(rows_of_method(calibrations))
    rows_of = calibrations.groupby(KEY, sort=False).indices
    for key, imu in full.groupby(KEY, sort=False):
        sure = imu[imu[SIGN_VERIFIED].to_numpy(bool)]
        if sure.empty or has_flag(imu["flag"], "backward").any():
            continue
        at = rows_of[key][unjudged[rows_of[key]] & finite[rows_of[key]]]
        R = matrices[at].reshape(-1, 1, 3, 3)
        angle = error_angle_deg(R, sure[R_COLUMNS].to_numpy(float).reshape(1, -1, 3, 3))
        verified[at[(angle < 90.0).any(axis=1)]] = True
    return calibrations.assign(**{SIGN_VERIFIED: verified})
