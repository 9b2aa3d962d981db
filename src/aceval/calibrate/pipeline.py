"""From a dataset's per-recording statistics to calibrations and correlations.

Data flow one way (docs/design.md, section 2): :mod:`aceval.signals.reduction` reads each recording once and
reduces it to a summary (static: the median specific force; motion: the scatter matrix ``sum a
a^T`` and count of its trimmed samples) and each Obj 1-2 recording pair to its moments; every
subset of repetitions is then calibrated from the summaries alone, and every calibrated pair
correlated from the moments alone.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from aceval.calibrate.functional_design import calibrate_functional  # noqa: E402
from aceval.calibrate.rows import (  # noqa: E402
    AXES_COLUMNS,
    axis_row,
    error_placeholders,
    imu_identity,
    method_rows,
)
from aceval.calibrate.table import (
    CALIBRATION_COLUMNS,
    KEY,
    all_subsets,
    combine_flags,
    full_set_rows,
    has_flag,
    subset_label,
    unflagged,
)
from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import Dataset
from aceval.data.rotations import axis_vector, error_angle_deg
from aceval.methods.combined import combined_rotation, gyro_weight, horizontal_right, kong_weight
from aceval.methods.functional import (
    AXIS_METHODS,
    MOMENT_COLUMNS,
    PHASE_COLUMNS,
    AxisLimits,
    axis_spread_deg,
    pool,
    pool_summed,
    sagittal_fits,
    sagittal_fits_batch,
    stable_seed,
    subset_axes,
)
from aceval.methods.functional import (
    SCATTER_COLUMNS as UNIT_SCATTER_COLUMNS,
)
from aceval.methods.kong import KongLimits, kong_from_scatters
from aceval.methods.step_harmonic import MAX_STEP_RATIO, step_harmonic_rotation
from aceval.methods.step_harmonic import SCATTER_COLUMNS as STEP_COLUMNS
from aceval.methods.uncertainty import bootstrap_cone
from aceval.signals.checks import (
    AGREEMENT_COLUMNS,
    MAX_STATIC_ANGLE_DEG,
    STILL_COLUMNS,
    THIRD_MOMENT_COLUMNS,
    best_test_agreement,
    direction_checks,
    sensor_problem,
    static_posture,
)
from aceval.signals.reduction import SCATTER_COLUMNS, reduce_recordings
from aceval.signals.segmentation import TrimParams
from aceval.signals.signatures import SIGNATURE_COLUMNS, signature_verdicts


def summarise_recordings(
    dataset: Dataset,
    subject: str | None = None,
    trim: TrimParams = TrimParams(),
    tests: list[str] | None = None,
) -> pd.DataFrame:
    """One summary row per recording of ``subject`` (all subjects if None) that some analysis
    needs (:func:`aceval.signals.reduction.summarise`); ``tests``: only these motion tests. The recording
    pairs and file findings of the same pass are in :func:`aceval.signals.reduction.reduce_recordings`.
    """
    return reduce_recordings(dataset, subject, trim, tests).summaries


def calibrate(
    dataset: Dataset,
    summaries: pd.DataFrame,
    subsets: str = "all",
    limits: KongLimits = KongLimits(),
    retest_k: int | None = 3,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every calibration of the IMUs in ``summaries``: ``(calibrations, axes)``.

    Datasets with ``functional_axes.tsv`` (Ricci's protocol) get the functional design
    (:func:`calibrate_functional`); the others Kong's sagittal design (:func:`calibrate_sagittal`).
    """
    if dataset.functional_axes is not None:
        return calibrate_functional(dataset, summaries)
    return calibrate_sagittal(dataset, summaries, subsets, limits, retest_k)


def _static_axes(summaries: pd.DataFrame) -> tuple[pd.DataFrame, dict]:
    """z0 (Kong Eq. 2; several static recordings averaged) and the pooled static axis of each IMU."""
    static = summaries[(summaries["kind"] == "static") & (summaries["flag"] == "")]
    z0 = static.groupby(KEY)[["z0_x", "z0_y", "z0_z"]].mean()
    z0 = z0.div(np.linalg.norm(z0.to_numpy(), axis=1), axis=0)
    axes = {
        key: (pool(group), ",".join(sorted(group["test"].unique())), len(group))
        for key, group in static.groupby(KEY)
    }
    return z0, axes


def imu_checks(dataset: Dataset, summaries: pd.DataFrame) -> dict[tuple, dict]:
    """Per (subject, set, IMU), what its motion recordings say about the sensor itself
    (:func:`aceval.signals.checks.sensor_problem`; walking recordings are left out of the agreement),
    about its static trial (:func:`aceval.signals.checks.static_posture`) and about its place
    (:func:`aceval.signals.signatures.signature_verdicts`): ``flag`` (every flag of the IMU's
    calibrations, ';'-joined), ``message``, ``test_flags`` (test -> the flag of that test's
    calibrations only) and the checks' evidence columns.
    """
    motion = summaries[summaries["kind"] == "motion"]
    if motion.empty or AGREEMENT_COLUMNS[0] not in motion:
        return {}
    gait = motion["test"].map(dataset.first_phase) == "gait"
    z0, _ = _static_axes(summaries)
    places = summaries[summaries["kind"].isin(["motion", "extra"])]
    signatures = signature_verdicts(places) if SIGNATURE_COLUMNS[0] in places else {}
    out = {}
    for key, group in motion.groupby(KEY, sort=False):
        per_test = group.loc[~gait[group.index]].groupby("test")[AGREEMENT_COLUMNS].sum()
        summed = best_test_agreement(per_test.to_numpy(float))
        verdict = sensor_problem(
            summed, float(group["gyro_p90_deg_s"].max()), dataset.meta["units"]["gyr"]
        )
        messages = [verdict["message"]]
        if key in z0.index and STILL_COLUMNS[0] in group:
            still = {t: g[STILL_COLUMNS].to_numpy(float) for t, g in group.groupby("test")}
            posture = static_posture(z0.loc[key].to_numpy(float), still)
            verdict["static_vertical_angle_deg"] = posture["static_vertical_angle_deg"]
            verdict["static_check_tests"] = posture["static_check_tests"]
            verdict["flag"] = combine_flags(verdict["flag"], posture["flag"])
            if posture["flag"]:
                messages.append(
                    f"the static trial's vertical is {posture['static_vertical_angle_deg']:.0f} deg "
                    f"from that of the still portions of every one of its "
                    f"{posture['static_check_tests']} motion tests with still portions (more than "
                    f"{MAX_STATIC_ANGLE_DEG:.0f}): taken seated or leaning, not standing?"
                )
        place = signatures.get(key, {"flag": "", "message": "", "test_flags": {}})
        verdict["flag"] = combine_flags(verdict["flag"], place["flag"])
        verdict["test_flags"] = place["test_flags"]
        messages.append(place["message"])
        message = "; ".join(m for m in messages if m)
        verdict["message"] = f"{' '.join(key)}: {message}" if message else ""
        out[key] = verdict
    return out


@dataclass(frozen=True)
class _Repetitions:
    """The summaries of one IMU's repetitions of one motion test (sorted by ``rep``) as arrays: read
    from the table once, so that every subset of them is a row selection, not a pandas lookup.
    """

    rep: np.ndarray  # (n,) int
    scatters: np.ndarray  # (n, 3, 3) Kong's sum a a^T
    n_samples: np.ndarray  # (n,)
    unit_scatters: np.ndarray  # (n, 3, 3) Ricci's unit scatters
    moments: np.ndarray  # (n, 16) MOMENT_COLUMNS
    phases: np.ndarray  # (n, 3) PHASE_COLUMNS: each repetition's first-phase axis
    third: np.ndarray | None  # (n, 10) THIRD_MOMENT_COLUMNS
    steps: np.ndarray | None  # (n, 3, 3) step-harmonic scatters; None unless every rep has one
    step_hz: np.ndarray | None  # (n,)

    @classmethod
    def of(cls, group: pd.DataFrame) -> _Repetitions:
        group = group.sort_values("rep")
        steps = group[STEP_COLUMNS].to_numpy(float) if STEP_COLUMNS[0] in group else None
        walking = steps is not None and bool(np.isfinite(steps).all())
        return cls(
            rep=group["rep"].to_numpy(int),
            scatters=group[SCATTER_COLUMNS].to_numpy(float).reshape(-1, 3, 3),
            n_samples=group["n_samples"].to_numpy(float),
            unit_scatters=group[UNIT_SCATTER_COLUMNS].to_numpy(float).reshape(-1, 3, 3),
            moments=group[MOMENT_COLUMNS].to_numpy(float),
            phases=group[PHASE_COLUMNS].to_numpy(float),
            third=group[THIRD_MOMENT_COLUMNS].to_numpy(float)
            if THIRD_MOMENT_COLUMNS[0] in group
            else None,
            steps=steps.reshape(-1, 3, 3) if walking else None,
            step_hz=group["step_hz"].to_numpy(float) if walking else None,
        )

    def pooled_axis(self, rows, orient: np.ndarray):
        """:func:`aceval.methods.functional.pool` of the repetitions at ``rows`` (NaN phases skipped)."""
        return pool_summed(np.nansum(self.moments[rows], axis=0), orient)


def _direction(
    dataset: Dataset, test: str, segment: str, reps: _Repetitions, membership, R, right
) -> dict:
    return direction_checks(
        dataset.first_phase(test), segment, reps.phases, reps.third, membership, R, right
    )


def calibrate_sagittal(
    dataset: Dataset,
    summaries: pd.DataFrame,
    subsets: str = "all",
    limits: KongLimits = KongLimits(),
    retest_k: int | None = 3,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Kong calibrations for every (subject, set, IMU, motion test) in ``summaries`` and every
    subset of its usable repetitions (``subsets='all'``) or all of them together (``'full'``);
    for all the repetitions together, also the axis methods (:func:`aceval.methods.functional.sagittal_fits`),
    and, with ``retest_k``, the axis methods from every subset of that many repetitions (Obj 4's
    test-retest for every method).

    z0 comes from the IMU's static recording(s) (Kong Eq. 2; several are averaged). One row per
    calibration: key columns, ``repetitions`` ('R1+R3+R4'), ``n_reps``, ``method``, r11..r33,
    diagnostics (Kong: eigenvalues, planarity...; all: ``rho_static`` and ``rho_motion``, the
    reliability of the static and gyroscope axes, Ricci Eq. 2; ``z0_tests``, the static test(s)
    z0 came from), ``flag`` ('' when valid) and ``error_deg``, ``error_vertical_share`` left empty
    (calibration knows no truth: :func:`aceval.evaluation.methods_comparison.with_truth` fills
    them in). ``axes``: one row per
    (subject, set, IMU, test) with the axis and rho of all its repetitions.
    """
    z0, static_axes = _static_axes(summaries)
    sensors = imu_checks(dataset, summaries)
    motion = summaries[(summaries["kind"] == "motion") & (summaries["flag"] == "")]
    out, axes = [], []
    for key, (estimate, tests, n_recordings) in static_axes.items():
        axes.append(
            axis_row(imu_identity(dataset, *key), tests, "static", estimate, "-z", n_recordings)
        )
    for (subject, sensor_set, imu, test), group in motion.groupby(KEY + ["test"], sort=True):
        data = _Repetitions.of(group)
        reps = [int(r) for r in data.rep]
        if (subject, sensor_set, imu) not in z0.index:
            continue  # no static test: validation reports it; nothing to calibrate from
        chosen = all_subsets(reps) if subsets == "all" else [tuple(reps)]
        index = {rep: k for k, rep in enumerate(reps)}
        right = axis_vector(dataset.right_axis(sensor_set, imu))
        z0_imu = z0.loc[(subject, sensor_set, imu)].to_numpy(float)
        members = [[index[r] for r in subset] for subset in chosen]
        result = kong_from_scatters(
            data.scatters,
            data.n_samples,
            z0_imu,
            right,
            members,
            limits=limits,
            strict=False,
        )
        membership = np.zeros((len(chosen), len(reps)))
        for row, subset in enumerate(members):
            membership[row, subset] = 1.0
        rho_motion, gyro_axes = subset_axes(data.unit_scatters, membership)
        gyro_angle = np.degrees(
            np.arccos(np.clip(np.abs(np.einsum("ki,ki->k", result.R[:, 1], gyro_axes)), 0.0, 1.0))
        )
        static_axis, z0_tests, _ = static_axes[(subject, sensor_set, imu)]
        rho_static = static_axis.rho
        errors = error_placeholders(result.R)
        identity = imu_identity(dataset, subject, sensor_set, imu)
        sensor = sensors.get((subject, sensor_set, imu), {"flag": ""})
        sensor_flag = combine_flags(sensor["flag"], sensor.get("test_flags", {}).get(test, ""))
        sensor_columns = {
            k: sensor.get(k, np.nan)
            for k in ("gyro_acc_agreement", "gyro_acc_evidence_deg", "static_vertical_angle_deg")
        }
        direction = _direction(
            dataset, test, identity["segment"], data, membership, result.R, right
        )
        # forward or backward is a property of the IMU's mounting: judged on all repetitions together
        # (the largest subset, last), it holds for every subset of them
        full = _direction(
            dataset, test, identity["segment"], data, np.ones((1, len(reps))), result.R[-1:], right
        )
        # the declared right axis is judged on each subset's own y0, whatever its own direction
        # vote was (a subset voting 'backward' never got its mismatch flag before)
        own_mismatch = np.where(direction["mismatch"], "right_axis_mismatch", "")
        backward = "backward" if "backward" in full["flag"][0].split(";") else ""
        direction["flag"] = np.array(
            [combine_flags(backward, m) for m in own_mismatch], dtype=object
        )
        for k, subset in enumerate(chosen):
            out.append(
                {
                    **identity,
                    "test": test,
                    "repetitions": subset_label(subset),
                    "n_reps": len(subset),
                    "method": "kong",
                    **dict(zip(R_COLUMNS, result.R[k].ravel())),
                    "n_samples": int(result.n_samples[k]),
                    "eig1": result.eigenvalues[k, 0],
                    "eig2": result.eigenvalues[k, 1],
                    "eig3": result.eigenvalues[k, 2],
                    "planarity": result.planarity[k],
                    "normal_ratio": result.normal_ratio[k],
                    "normal_vertical_angle_deg": result.normal_vertical_angle_deg[k],
                    "rho_static": rho_static,
                    "rho_motion": rho_motion[k],
                    "z0_tests": z0_tests,
                    "normal_gyro_angle_deg": gyro_angle[k],
                    "first_phase_agreement": direction["first_phase_agreement"][k],
                    "right_axis_angle_deg": direction["right_axis_angle_deg"][k],
                    **sensor_columns,
                    "flag": combine_flags(sensor_flag, result.flag[k], direction["flag"][k]),
                    **{name: values[k] for name, values in errors.items()},
                }
            )
        kong_full = out[-1]  # the calibration from all repetitions (the last subset)
        gyro_axis = data.pooled_axis(slice(None), right)
        axes.append(axis_row(identity, test, "motion", gyro_axis, "+y", len(reps)))
        spread = axis_spread_deg(data.phases, gyro_axis.axis)
        base = {
            **identity,
            "test": test,
            "repetitions": subset_label(reps),
            "n_reps": len(reps),
            "n_samples": int(data.n_samples.sum()),
            "rho_static": rho_static,
            "rho_motion": gyro_axis.rho,
            "z0_tests": z0_tests,
            "axis_spread_deg": spread,
            **sensor_columns,
        }
        fits = sagittal_fits(z0_imu, rho_static, gyro_axis.axis, gyro_axis.rho, spread)
        axis_flag = fits["triad"].get("flag", "")  # the gyroscope axis's own conditioning
        kong_at = {subset: k for k, subset in enumerate(chosen)}
        fits["combined"] = _combined_fit(
            result, kong_at[tuple(reps)], z0_imu, gyro_axis, axis_flag, right, limits
        )
        steps = data.steps
        if steps is not None:  # walking: the step-harmonic heading
            fits["step_harmonic"] = _step_fit(steps.sum(axis=0), z0_imu, right, data.step_hz)
        elif dataset.first_phase(test) == "gait":
            fits["step_harmonic"] = {"R": None, "flag": "not_applicable", "note": STEP_TOO_SHORT}
        all_reps = np.ones((1, len(reps)))
        for method in fits:  # the same direction checks as Kong's
            if fits[method].get("R") is not None and np.isfinite(fits[method]["R"]).all():
                checked = _direction(
                    dataset,
                    test,
                    identity["segment"],
                    data,
                    all_reps,
                    fits[method]["R"][None],
                    right,
                )
                fits[method]["flag"] = combine_flags(
                    sensor_flag, fits[method].get("flag", ""), checked["flag"][0]
                )
                fits[method]["first_phase_agreement"] = checked["first_phase_agreement"][0]
                fits[method]["right_axis_angle_deg"] = checked["right_axis_angle_deg"][0]
            elif fits[method].get("flag") != "not_applicable":
                fits[method]["flag"] = combine_flags(sensor_flag, fits[method].get("flag", ""))
        cones = bootstrap_cone(
            data.scatters,
            data.n_samples,
            data.unit_scatters,
            z0_imu,
            right,
            result.R[kong_at[tuple(reps)]],
            fits["combined"]["R"],
            AxisLimits().min_rho,
            limits,
            seed=stable_seed(subject, sensor_set, imu, test),
            step_scatters=steps,
            R_step=fits["step_harmonic"]["R"] if steps is not None else None,
            rho_static=rho_static,
            R_axis={m: fits[m].get("R") for m in AXIS_METHODS},
        )
        for method, (cone95_deg, cone_share) in cones.items():
            target = kong_full if method == "kong" else fits[method]
            target.update(cone95_deg=cone95_deg, cone_vertical_share=cone_share)
        out += method_rows(base, fits)
        if subsets == "all" and retest_k and len(reps) > retest_k:
            out += _retest_rows(data, base, fits, sensor_flag, z0_imu, rho_static, right,
                                retest_k, result, kong_at, limits)  # fmt: skip
    calibrations = pd.DataFrame(out, columns=None if out else CALIBRATION_COLUMNS)
    return propagate_backward(calibrations), pd.DataFrame(axes, columns=AXES_COLUMNS)


def _combined_fit(kong, index: int, z0, axis, axis_flag: str, right, limits: KongLimits) -> dict:
    """The combined heading (:mod:`aceval.methods.combined`) of Kong's calibration ``index``
    of ``kong`` (a :class:`KongResult`) and the pooled gyroscope ``axis`` of the same repetitions:
    each weighted by its conditioning, 0 when flagged; both 0: the heading is undetermined
    (R NaN, flagged as Kong's calibration).
    """
    w_kong = (
        float(kong_weight(kong.normal_ratio[index], kong.planarity[index],
                          limits.max_normal_ratio, limits.max_planarity))
        if kong.flag[index] == "" else 0.0
    )  # fmt: skip
    w_gyro = float(gyro_weight(axis.rho, AxisLimits().min_rho)) if axis_flag == "" else 0.0
    R = combined_rotation(
        z0, kong.R[index, 1], horizontal_right(axis.axis, z0, right), w_kong, w_gyro
    )
    flag = (
        "" if w_kong + w_gyro > 0 else (combine_flags(kong.flag[index], axis_flag) or "not_planar")
    )
    return {"R": R, "flag": flag, "weight_kong": w_kong, "weight_gyro": w_gyro}


#: why a walking test has no step-harmonic calibration (aceval.methods.step_harmonic)
STEP_TOO_SHORT = (
    "needs walking recordings of at least two cycles of the slowest step (3.3 s) to find the "
    "step frequency; this dataset's repetitions are shorter"
)


def _step_fit(H: np.ndarray, z0, right, step_hz: np.ndarray) -> dict:
    """The step-harmonic calibration from the summed scatter ``H`` of repetitions whose step
    frequencies are ``step_hz``, flagged ``no_step_heading`` when no horizontal direction dominates.
    """
    R, ratio = step_harmonic_rotation(H, z0, right)
    ok = bool(ratio <= MAX_STEP_RATIO)
    return {
        "R": R,
        "flag": "" if ok else "no_step_heading",
        "step_ratio": float(ratio),
        "step_hz": float(np.median(step_hz)),
    }


def _retest_rows(
    data: _Repetitions, base, fits, sensor_flag, z0, rho_static, right, k, kong, kong_at, limits
) -> list[dict]:
    """The axis methods, the combined and (walking) the step-harmonic heading from every subset of
    ``k`` repetitions (Obj 4's
    test-retest for every method, not only Kong's): each subset's pooled gyroscope axis (and
    Kong's calibration ``kong_at[subset]`` of ``kong``); flagged as the subset's own fit and, for
    direction, as the calibration from all repetitions (a property of the mounting).
    """
    rows = []
    subsets = [list(chosen) for chosen in itertools.combinations(range(len(data.rep)), k)]
    axes = [data.pooled_axis(rows_at, right) for rows_at in subsets]
    spreads = [axis_spread_deg(data.phases[at], axis.axis) for at, axis in zip(subsets, axes)]
    fitted = sagittal_fits_batch(
        z0, rho_static, np.array([a.axis for a in axes]), np.array([a.rho for a in axes]),
        np.array(spreads),
    )  # fmt: skip
    for rows_at, axis, spread, sub in zip(subsets, axes, spreads, fitted):
        reps = [int(r) for r in data.rep[rows_at]]
        sub["combined"] = _combined_fit(
            kong, kong_at[tuple(reps)], z0, axis, sub["triad"].get("flag", ""), right, limits
        )
        if data.steps is not None and "step_harmonic" in fits:
            sub["step_harmonic"] = _step_fit(
                data.steps[rows_at].sum(axis=0), z0, right, data.step_hz[rows_at]
            )
        for method in sub:
            sub[method]["flag"] = combine_flags(
                sensor_flag, sub[method].get("flag", ""), fits[method].get("flag", "")
            )
        rows += method_rows(
            {
                **base,
                "repetitions": subset_label(reps),
                "n_reps": k,
                "rho_motion": axis.rho,
                "n_samples": int(data.n_samples[rows_at].sum()),
                "axis_spread_deg": spread,
            },  # fmt: skip
            sub,
        )
    return rows


def propagate_backward(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Tests whose direction cannot be checked (e.g. the thigh in walking) inherit the verdict of a
    checked test of the same IMU: every test's y axis takes its sign from the same ``right_axis``,
    so a calibration within 90 deg of one found backward is backward too. Judged on Kong's
    calibrations from all repetitions; the flag goes to every calibration (and method) of the test.
    """
    if calibrations.empty or "first_phase_agreement" not in calibrations:
        return calibrations
    kong = calibrations[calibrations["method"] == "kong"]
    full = full_set_rows(kong)
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
    return calibrations.assign(flag=flags)
