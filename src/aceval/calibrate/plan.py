"""What each IMU is calibrated from, resolved once per job: the calibration plan of Kong's protocol
(DESIGN.md: recordings -> statistics -> per-IMU plan -> calibrations).

From the one pass's summaries (:mod:`aceval.signals.reduction`): each IMU's z0 and static axis
(Kong Eq. 2, several static recordings averaged), what the checks say about the sensor itself
(:func:`imu_checks`), and for each calibration unit (one IMU in one motion test that calibrates
it) the statistics of its usable repetitions (:class:`aceval.methods.sufficient.Units`), its
place, its declared right axis, and the subsets of repetitions each method is fitted on: Kong's
method on every subset (Obj 3-5), the others on all repetitions and on every subset of ``k``
(Obj 4's test-retest for every method).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from aceval.calibrate.table import (
    AXES_COLUMNS,
    KEY,
    all_subsets,
    axis_row,
    combine_flags,
    imu_identity,
    subset_label,
)
from aceval.data.dataset import Dataset
from aceval.data.grouping import group_positions
from aceval.data.rotations import axis_vector
from aceval.methods import registry
from aceval.methods.functional import MOMENT_COLUMNS, axis_of_sums, stable_seed
from aceval.methods.sufficient import Units
from aceval.signals.checks import (
    AGREEMENT_COLUMNS,
    GYRO_THIRD,
    MAX_STATIC_ANGLE_DEG,
    REST_GYRO_COLUMNS,
    STILL_COLUMNS,
    acc_sign_agreement,
    acc_sign_problem,
    best_test_agreement,
    sensor_problem,
    signal_verdict,
    static_posture,
)
from aceval.signals.gait_sign import GAIT_SIGN
from aceval.signals.signatures import SIGNATURE_COLUMNS, signature_verdicts

#: the two subset policies of a method (its ``every_subset``): every subset of a unit's
#: repetitions (Kong's Obj 3-5), or all of them and the Obj 4 test-retest subsets of ``k``
EVERY_SUBSET, RETEST = "every_subset", "retest"
#: what the checks measured about each sensor, beside every calibration of it
SENSOR_COLUMNS = ["gyro_acc_agreement", "gyro_acc_evidence_deg", "static_vertical_angle_deg"]
SENSOR_COLUMNS += [
    "gyro_bias_deg_s",
    "static_spread_deg",
    "vendor_up_angle_deg",
    "acc_sign_agreement",
]
#: the end of ``z0_tests`` of a unit whose repetitions each have their own vertical (verticals.tsv)
PER_REPETITION = "(per repetition)"


@dataclass(frozen=True)
class Subsets:
    """Calibrations to make: one row each, the unit (index into the plan's units), the weight of
    each of its repetitions (0/1), the label ('R1+R3+R4') and how many repetitions.
    """

    unit: np.ndarray
    weights: np.ndarray
    label: np.ndarray
    n_reps: np.ndarray

    def __len__(self) -> int:
        return len(self.unit)


@dataclass(frozen=True)
class Plan:
    """A job's calibration plan: ``units`` (their statistics), ``identity`` (one row per unit:
    subject, set, IMU, segment, side, test, ``z0_tests``, the sensor's ``sensor_flag`` for this
    test, :data:`SENSOR_COLUMNS` and the unit's bootstrap ``seed``), ``subsets`` (the calibrations
    to make under each subset policy: :data:`EVERY_SUBSET`, every subset of each unit's
    repetitions, or all of them together; :data:`RETEST`, all repetitions, then every subset of
    ``k``), and ``static_axes`` (the axes table's rows of the static tests).
    """

    units: Units
    identity: pd.DataFrame
    subsets: dict[str, Subsets]
    static_axes: pd.DataFrame

    def policy_subsets(self, every_subset: bool) -> Subsets:
        """The calibrations a method with this subset policy is fitted on."""
        return self.subsets[EVERY_SUBSET if every_subset else RETEST]


def static_axes(summaries: pd.DataFrame) -> tuple[pd.DataFrame, dict]:
    """z0 (Kong Eq. 2; several static recordings averaged) and the pooled static axis, its
    tests and number of recordings, of each IMU.
    """
    static = summaries[(summaries["kind"] == "static") & (summaries["flag"] == "")]
    z0 = static.groupby(KEY)[["z0_x", "z0_y", "z0_z"]].mean()
    z0 = z0.div(np.linalg.norm(z0.to_numpy(), axis=1), axis=0)
    moments = static[MOMENT_COLUMNS].to_numpy(float).T  # as pandas sums them: NaN (phases) as 0
    moments = np.ascontiguousarray(np.where(np.isnan(moments), 0.0, moments))
    tests = static["test"].to_numpy(object)
    axes = {
        key: (
            axis_of_sums(moments[:, at].sum(axis=1)),
            ",".join(sorted(set(tests[at]))),
            len(at),
        )
        for key, at in sorted(group_positions(static, KEY), key=lambda group: group[0])
    }
    return z0, axes


def imu_checks(
    dataset: Dataset, summaries: pd.DataFrame, pairs=None, z0: pd.DataFrame | None = None
) -> dict[tuple, dict]:
    """Per (subject, set, IMU), what its motion recordings say about the sensor itself
    (:func:`aceval.signals.checks.sensor_problem`; walking recordings are left out of the
    agreement), about its static trial (:func:`aceval.signals.checks.static_posture`) and about
    its place (:func:`aceval.signals.signatures.signature_verdicts`): ``flag`` (every flag of the
    IMU's calibrations, ';'-joined), ``message``, ``test_flags`` (test -> the flag of that test's
    calibrations only) and the checks' evidence columns; also what its signals say
    (:func:`aceval.signals.checks.signal_verdict`) and, with the Obj 1 ``pairs``, whether the
    two sensors of its segment agree on the accelerometer's sign
    (:func:`aceval.signals.checks.acc_sign_agreement`). ``z0``: :func:`static_axes`' when the
    caller has it. The tables are grouped once; each IMU's checks read NumPy slices of them.
    """
    motion = summaries[summaries["kind"] == "motion"]
    if motion.empty or AGREEMENT_COLUMNS[0] not in motion:
        return {}
    z0 = static_axes(summaries)[0] if z0 is None else z0
    places = summaries[summaries["kind"].isin(["motion", "extra"])]
    signatures = signature_verdicts(places) if SIGNATURE_COLUMNS[0] in places else {}
    signs = acc_sign_agreement(pairs)
    agreements = _best_agreements(dataset, motion)
    fastest = motion.groupby(KEY, sort=False)["gyro_p90_deg_s"].max().to_dict()
    signals = _signal_verdicts(dataset, summaries, motion)
    tests = motion["test"].to_numpy(object)
    still = motion[STILL_COLUMNS].to_numpy(float) if STILL_COLUMNS[0] in motion else None
    verticals_of = dict(zip(z0.index, z0.to_numpy(float)))
    out = {}
    for key, at in group_positions(motion, KEY):
        verdict = sensor_problem(agreements[key], fastest[key], dataset.meta["units"]["gyr"])
        messages = [verdict["message"]]
        standing = dataset.functional_axes is None  # Ricci's static posture is the sheet's
        if standing and key in verticals_of and still is not None:
            verticals = {t: still[at[tests[at] == t]] for t in sorted(set(tests[at]))}
            posture = static_posture(verticals_of[key], verticals)
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
        signal = signals[key]
        sign = signs.get(key, np.nan)
        flags = [signal["flag"], "acc_sign_mismatch" if acc_sign_problem(sign) else ""]
        verdict["flag"] = combine_flags(verdict["flag"], *flags)
        messages += [*signal["messages"], acc_sign_problem(sign)]
        verdict |= {k: signal[k] for k in SENSOR_COLUMNS[3:6]} | {"acc_sign_agreement": sign}
        place = signatures.get(key, {"flag": "", "message": "", "test_flags": {}})
        verdict["flag"] = combine_flags(verdict["flag"], place["flag"])
        verdict["test_flags"] = place["test_flags"]
        messages.append(place["message"])
        message = "; ".join(m for m in messages if m)
        verdict["message"] = f"{' '.join(key)}: {message}" if message else ""
        out[key] = verdict
    return out


def _best_agreements(dataset: Dataset, motion: pd.DataFrame) -> dict[tuple, np.ndarray]:
    """Per IMU of ``motion``, the summed ``AGREEMENT_COLUMNS`` of its best test
    (:func:`aceval.signals.checks.best_test_agreement`; walking left out: zeros when only
    walking is left). Each test's sum runs over its recordings in table order, whatever else
    the table holds.
    """
    values = motion[AGREEMENT_COLUMNS].to_numpy(float)
    gait = (motion["test"].map(dataset.first_phase) == "gait").to_numpy()
    tests = motion["test"].to_numpy(object)
    out = {}
    for key, at in group_positions(motion, KEY):
        at = at[~gait[at]]
        per_test = [values[at[tests[at] == t]].sum(axis=0) for t in sorted(set(tests[at]))]
        out[key] = best_test_agreement(np.array(per_test).reshape(-1, len(AGREEMENT_COLUMNS)))
    return out


def _signal_verdicts(dataset, summaries: pd.DataFrame, motion: pd.DataFrame) -> dict[tuple, dict]:
    """:func:`aceval.signals.checks.signal_verdict` of each IMU of ``motion``, from the rest
    offsets of its static, then its motion recordings, and its usable static recordings; the
    static recordings verticals.tsv gives a repetition as its own (a re-placement) left out.
    """
    static = summaries[summaries["kind"] == "static"]
    static = static[~_linked(dataset, static)]

    def column_values(table, columns) -> np.ndarray:
        present = columns[0] in table
        return table[columns].to_numpy(float) if present else np.full((len(table), 3), np.nan)

    offsets = {
        kind: (table, column_values(table, REST_GYRO_COLUMNS))
        for kind, table in (("static", static), ("motion", motion))
    }
    usable = static[static["flag"] == ""] if "flag" in static else static
    z0 = column_values(usable, ["z0_x", "z0_y", "z0_z"])
    vendor = (
        usable["vendor_up_angle_deg"].to_numpy(float)
        if "vendor_up_angle_deg" in usable
        else np.full(len(usable), np.nan)
    )
    rows = {kind: dict(group_positions(t, KEY)) for kind, (t, _) in offsets.items()}
    of_usable = dict(group_positions(usable, KEY))
    none = np.zeros(0, dtype=int)
    out = {}
    for key in rows["motion"]:
        rest = [values[rows[kind].get(key, none)] for kind, (_, values) in offsets.items()]
        chosen = of_usable.get(key, none)
        out[key] = signal_verdict(np.concatenate(rest), z0[chosen], vendor[chosen])
    return out


def build_plan(
    dataset: Dataset,
    summaries: pd.DataFrame,
    subsets: str = "all",
    retest_k: int | None = 3,
    sensors: dict | None = None,
) -> Plan:
    """The plan of every unit in ``summaries`` (module docstring): Kong on every subset of its
    usable repetitions (``subsets='all'``) or all of them together (``'full'``); the other
    methods on all of them and, with ``subsets='all'`` and ``retest_k``, every subset of that
    many. A unit whose IMU has no static test is left out (the validation reports it).
    ``sensors``: :func:`imu_checks` when the caller has it already.
    """
    z0, statics = static_axes(summaries)
    sensors = imu_checks(dataset, summaries, z0=z0) if sensors is None else sensors
    motion = summaries[(summaries["kind"] == "motion") & (summaries["flag"] == "")]
    motion = motion[pd.MultiIndex.from_frame(motion[KEY]).isin(z0.index)]
    motion = motion.sort_values([*KEY, "test", "rep"], kind="stable")
    units, identity = _units(dataset, motion, z0, statics, sensors, summaries)
    n_present = units.present.sum(axis=1)
    every = [
        all_subsets(list(range(n))) if subsets == "all" else [tuple(range(n))] for n in n_present
    ]
    k = retest_k if subsets == "all" and retest_k else 0
    methods = [
        [tuple(range(n)), *(itertools.combinations(range(n), k) if 0 < k < n else [])]
        for n in n_present
    ]
    static_rows = [
        axis_row(imu_identity(dataset, *key), tests, "static", estimate, "-z", n_recordings)
        for key, (estimate, tests, n_recordings) in statics.items()
    ]
    return Plan(
        units=units,
        identity=identity,
        subsets={EVERY_SUBSET: _subsets(units, every), RETEST: _subsets(units, methods)},
        static_axes=pd.DataFrame(static_rows, columns=AXES_COLUMNS),
    )


def _units(dataset, motion, z0, statics, sensors, summaries) -> tuple[Units, pd.DataFrame]:
    """The :class:`Units` of the usable motion recordings (sorted by unit and repetition), with
    every statistic the registry's methods and the direction checks declare, each repetition's
    own vertical where verticals.tsv gives one, and their identity table.
    """
    unit_key = [*KEY, "test"]
    code = motion.groupby(unit_key, sort=False).ngroup().to_numpy()
    position = motion.groupby(unit_key, sort=False).cumcount().to_numpy()
    first = motion.drop_duplicates(unit_key)
    n_units, width = len(first), int(position.max()) + 1 if len(position) else 0
    present = np.zeros((n_units, width), dtype=bool)
    present[code, position] = True

    def padded(columns, shape=(), absent=0.0, missing=0.0):
        out = np.full((n_units, width, *shape), missing, dtype=float)
        if columns[0] in motion:
            out[code, position] = motion[list(columns)].to_numpy(float).reshape(-1, *shape)
        out[~present] = absent
        return out

    statistics = (*registry.statistics(), GYRO_THIRD, GAIT_SIGN)
    values = {
        name: padded(part.columns, part.shape, part.absent, part.missing)
        for statistic in statistics
        for name, part in statistic.parts.items()
        if part.missing is not None or part.columns[0] in motion
    }
    rep = np.zeros((n_units, width), dtype=int)
    rep[code, position] = motion["rep"].to_numpy(int)
    keys = list(first[KEY].itertuples(index=False, name=None))
    tests = first["test"].tolist()
    z0_rep = repetition_verticals(dataset, summaries, keys, tests, rep, z0)
    identity = _identity(dataset, keys, tests, statics, sensors)
    if z0_rep is not None:
        own = np.isfinite(z0_rep).all(axis=(1, 2))
        identity.loc[own, "z0_tests"] = identity.loc[own, "z0_tests"] + f" {PER_REPETITION}"
    units = Units(
        z0=z0.loc[keys].to_numpy(float) if keys else np.zeros((0, 3)),
        right=np.array([axis_vector(dataset.right_axis(s, i)) for _, s, i in keys]).reshape(-1, 3),
        rho_static=np.array([statics[key][0].rho for key in keys]),
        first_phase=np.array([dataset.first_phase(t) for t in tests], dtype=object),
        segment=identity["segment"].to_numpy(object),
        rep=rep,
        present=present,
        n_samples=padded(["n_samples"]),
        statistics=statistics,
        values=values,
        z0_rep=z0_rep,
    )
    return units, identity


def _linked(dataset, static: pd.DataFrame) -> np.ndarray:
    """(N,) which static recordings verticals.tsv gives to a motion repetition as its own."""
    if dataset.verticals is None:
        return np.zeros(len(static), dtype=bool)
    linked = set(zip(*(dataset.verticals[c] for c in ("subject", "static_test", "static_rep"))))
    return np.array([k in linked for k in zip(static["subject"], static["test"], static["rep"])])


def repetition_verticals(dataset, summaries, keys, tests, rep, z0) -> np.ndarray | None:
    """(U, R, 3) each motion repetition's own vertical (Kong Eq. 2 of the static recording that
    verticals.tsv gives it; its unit's ``z0`` for a repetition without one) for the units with
    any, NaN for the others; None when no unit has one.
    """
    if dataset.verticals is None or not keys:
        return None
    static = summaries[(summaries["kind"] == "static") & (summaries["flag"] == "")]
    own = static.set_index([*KEY, "test", "rep"])[["z0_x", "z0_y", "z0_z"]]
    link = dataset.verticals.set_index(["subject", "test", "rep"])
    out = np.full((*rep.shape, 3), np.nan)
    for u, ((subject, sensor_set, imu), test) in enumerate(zip(keys, tests)):
        for r, number in enumerate(rep[u]):
            if (subject, test, number) in link.index:
                source = link.loc[(subject, test, number)]
                key = (subject, sensor_set, imu, source["static_test"], source["static_rep"])
                if key in own.index:
                    vertical = own.loc[key].to_numpy(float)
                    out[u, r] = vertical / np.linalg.norm(vertical)
        if np.isfinite(out[u]).any():
            missing = ~np.isfinite(out[u]).all(axis=1)
            out[u, missing] = z0.loc[keys[u]].to_numpy(float)
    return out if np.isfinite(out).any() else None


def _identity(dataset, keys, tests, statics, sensors) -> pd.DataFrame:
    """One row per unit: its key, place, static tests, sensor flag and evidence, bootstrap seed."""
    rows = []
    for key, test in zip(keys, tests):
        sensor = sensors.get(key, {"flag": ""})
        test_flag = sensor.get("test_flags", {}).get(test, "")
        rows.append(
            {
                **imu_identity(dataset, *key),
                "test": test,
                "z0_tests": statics[key][1],
                "sensor_flag": combine_flags(sensor["flag"], test_flag),
                **{k: sensor.get(k, np.nan) for k in SENSOR_COLUMNS},
                "seed": stable_seed(*key, test),
            }
        )
    columns = [*KEY, "segment", "side", "test", "z0_tests", "sensor_flag", *SENSOR_COLUMNS, "seed"]
    return pd.DataFrame(rows, columns=columns)


def _subsets(units: Units, chosen: list[list[tuple[int, ...]]]) -> Subsets:
    """:class:`Subsets` of each unit's ``chosen`` subsets of repetition positions."""
    unit, weights, label = [], [], []
    for u, subsets in enumerate(chosen):
        for subset in subsets:
            row = np.zeros(units.present.shape[1])
            row[list(subset)] = 1.0
            unit.append(u)
            weights.append(row)
            label.append(subset_label(units.rep[u, list(subset)]))
    weights = np.array(weights) if weights else np.zeros((0, units.present.shape[1]))
    return Subsets(
        np.array(unit, dtype=int),
        weights,
        np.array(label, dtype=object),
        weights.sum(axis=1).astype(int),
    )
