"""The sufficient statistics every method of Kong's protocol fits from: each repetition's, held per
calibration unit (one IMU in one motion test), and their weighted sums over any subset or bootstrap
resample of the repetitions.

A :class:`Statistic` is declared once, by the method that reads it (its ``statistics``,
:mod:`aceval.methods.interface`), as named :class:`Part` arrays: the columns it adds to the one
pass's summary row of a recording (:mod:`aceval.signals.reduction` runs its ``reduce``), their shape
per repetition, and whether a union of repetitions sums them. The plan pads each part over a job's
units (:class:`Units`, ``values[name]`` (U, R, ...)); :func:`pool` sums the summed parts of any
weighted union of repetitions and lets each statistic ``derive`` what its methods read
(:class:`Pooled`, ``pooled.<name>``). A calibration from any subset thus costs a few 3x3 sums and
one ``eigh``, never another pass over the samples.

Declared here, the statistics of both papers: :data:`ACC_SCATTER` (Kong's scatter ``sum a a^T``,
Eq. 3) and :data:`GYRO_MOMENTS` (the moments of the unit gyroscope samples and each repetition's
own first-phase axis, Ricci Eq. 1-2). The step-band scatter is step_harmonic's
(:data:`aceval.methods.step_harmonic.STEP_SCATTER`), the angular velocity's third moments the
direction checks' (:data:`aceval.signals.checks.GYRO_THIRD`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aceval.data.rotations import vector_angle_deg
from aceval.methods.moments import (
    ACC_SCATTER_COLUMNS,
    PHASE_COLUMNS,
    SUM_COLUMNS,
    UNIT_SCATTER_COLUMNS,
    recording_moments,
    scatter,
)


@dataclass(frozen=True)
class Part:
    """One named array of a statistic, per repetition: its summary ``columns`` (one per element,
    row-major), ``shape``, the value of a repetition a unit lacks (``absent``) and of a recording
    whose summary has no such columns (``missing``; None: the part is left out when no summary
    has them), and whether a union of repetitions sums it (``summed``; otherwise each repetition's
    value is kept for its statistic's ``derive``).
    """

    columns: tuple[str, ...]
    shape: tuple[int, ...] = ()
    absent: float = 0.0
    missing: float | None = 0.0
    summed: bool = True


@dataclass(frozen=True)
class Statistic:
    """A per-repetition sufficient statistic of a motion test.

    ``parts``: name -> :class:`Part`. ``reduce(acc, gyr, kept, fs_hz) -> {column: value}``: one
    motion recording's columns from its samples (m/s^2, rad/s) and the mask of the samples the
    trimmer keeps (None: computed per test instead, ``reduce_test``). ``reduce_test(recordings,
    fs_hz, summaries)``: once every recording of one subject's test with first phase
    ``test_phase`` is read, their columns (:func:`aceval.methods.step_harmonic.reduce_walking`).
    ``derive(units, unit, weights, sums, subsets) -> {name: (B, ...)}``: what the methods read of
    a pooled union beyond the summed parts (:func:`pool`).
    """

    name: str
    parts: Mapping[str, Part]
    reduce: Callable[..., dict] | None = None
    reduce_test: Callable[..., None] | None = None
    test_phase: str = ""
    derive: Callable[..., dict] | None = None

    @property
    def columns(self) -> list[str]:
        """Every summary column of the statistic, in its parts' order."""
        return [c for part in self.parts.values() for c in part.columns]


@dataclass(frozen=True)
class Units:
    """Every calibration unit (IMU x motion test) of a job: ``U`` units, at most ``R`` repetitions.

    Per unit: ``z0`` (U, 3) the downward vertical from quiet standing (Kong Eq. 2), ``right``
    (U, 3) the declared right axis, ``rho_static`` (U,) the static axis's reliability,
    ``first_phase`` and ``segment`` (U,) str. Per repetition (padded): ``rep`` (U, R) its number
    (0 where absent), ``present`` (U, R), ``n_samples`` (U, R) the samples the trimmer kept, and
    ``values``: each declared statistic's parts (name -> (U, R, ...)), of the ``statistics`` given.
    ``z0_rep`` (U, R, 3), optional: each repetition's own vertical (verticals.tsv), NaN for the
    units whose repetitions share ``z0``; a calibration from several repetitions takes the
    normalised mean of theirs.
    """

    z0: np.ndarray
    right: np.ndarray
    rho_static: np.ndarray
    first_phase: np.ndarray
    segment: np.ndarray
    rep: np.ndarray
    present: np.ndarray
    n_samples: np.ndarray
    statistics: tuple[Statistic, ...]
    values: dict[str, np.ndarray] = field(default_factory=dict)
    z0_rep: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.z0)

    def pooled_z0(self, unit: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """(B, 3) the vertical of each row's weighted repetitions: the unit's ``z0``, or where
        its repetitions have their own (``z0_rep``), their weighted mean, normalised.
        """
        z0 = self.z0[unit]
        if self.z0_rep is None:
            return z0
        own = self.z0_rep[unit]
        mean = np.einsum("br,brk->bk", weights, np.nan_to_num(own))
        norm = np.linalg.norm(mean, axis=1, keepdims=True)
        per_rep = np.isfinite(own).all(axis=(1, 2)) & (norm[:, 0] > 0)
        return np.where(per_rep[:, None], mean / np.where(norm > 0, norm, 1.0), z0)

    def get(self, name: str) -> np.ndarray | None:
        """A part's values (U, R, ...), None where the summaries had none."""
        return self.values.get(name)

    @classmethod
    def of_repetitions(
        cls,
        z0,
        right,
        scatters,
        n_samples,
        unit_scatters,
        rho_static: float = 1.0,
        first_phase: str = "",
        segment: str = "",
    ) -> Units:
        """One unit from its repetitions' arrays (a caller with samples of its own, and the
        tests): z0 and the declared right axis (3,), Kong's scatters (n, 3, 3) and counts (n,),
        the unit gyroscope scatters (n, 3, 3) (each unit sample adds 1 to the trace, which is the
        count); every other part of the two statistics as a recording without it has it
        (:attr:`Part.missing`: the sums 0, the repetitions' own axes NaN; movement axes are then
        signed by ``right``).
        """
        scatters = np.asarray(scatters, float)
        unit_scatters = np.asarray(unit_scatters, float)
        statistics = (ACC_SCATTER, GYRO_MOMENTS)
        given = {
            "scatter": scatters,
            "unit_scatter": unit_scatters,
            "n_unit": np.trace(unit_scatters, axis1=1, axis2=2),
        }
        return cls._one_unit(
            z0, right, n_samples, statistics, given, rho_static, first_phase, segment
        )

    @classmethod
    def of_samples(
        cls,
        z0,
        right,
        repetitions,
        fs_hz: float,
        statistics,
        rho_static: float = 1.0,
        first_phase: str = "",
        segment: str = "",
    ) -> Units:
        """One unit from its repetitions' samples, every sample kept (the tests: a statistic
        declared anywhere reaches them with nothing listed by hand): z0 and the declared right
        axis (3,), ``repetitions`` a list of (acc (n, 3) m/s^2, gyr (n, 3) rad/s) in the sensor
        frame, each reduced by every one of ``statistics`` as the one pass reduces a recording
        (its ``reduce``, or ``reduce_test`` over the unit's repetitions where the test's first
        phase is the statistic's ``test_phase``).
        """
        summaries = {
            rep: {"kept": f"0:{len(acc)}", "n_samples": len(acc)}
            for rep, (acc, _) in enumerate(repetitions)
        }
        for statistic in statistics:
            for rep, (acc, gyr) in enumerate(repetitions):
                if statistic.reduce is not None:
                    kept = np.ones(len(acc), dtype=bool)
                    summaries[rep].update(statistic.reduce(acc, gyr, kept, fs_hz))
            if statistic.reduce_test is not None and statistic.test_phase == first_phase:
                recordings = [
                    (rep, acc, np.ones(len(acc), dtype=bool), segment, rep + 1)
                    for rep, (acc, _) in enumerate(repetitions)
                ]
                statistic.reduce_test(recordings, fs_hz, summaries)
        rows = [summaries[rep] for rep in range(len(repetitions))]
        given = {
            name: np.array([[row.get(c, np.nan) for c in part.columns] for row in rows])
            for statistic in statistics
            for name, part in statistic.parts.items()
            if all(part.columns[0] in row for row in rows)
        }
        n_samples = [row["n_samples"] for row in rows]
        return cls._one_unit(
            z0, right, n_samples, tuple(statistics), given, rho_static, first_phase, segment
        )

    @classmethod
    def _one_unit(
        cls, z0, right, n_samples, statistics, given, rho_static, first_phase, segment
    ) -> Units:
        """One unit of ``len(n_samples)`` repetitions: each part of ``statistics`` from
        ``given`` (name -> (n, ...) values; each part's ``missing`` value where not given).
        """
        n = len(n_samples)
        values = {}
        for statistic in statistics:
            for name, part in statistic.parts.items():
                if name in given:
                    values[name] = np.asarray(given[name], float).reshape(1, n, *part.shape)
                elif part.missing is not None:
                    values[name] = np.full((1, n, *part.shape), part.missing)
        return cls(
            z0=np.asarray(z0, float)[None],
            right=np.asarray(right, float)[None],
            rho_static=np.array([rho_static], float),
            first_phase=np.array([first_phase], dtype=object),
            segment=np.array([segment], dtype=object),
            rep=np.arange(1, n + 1)[None],
            present=np.ones((1, n), dtype=bool),
            n_samples=np.asarray(n_samples, float)[None],
            statistics=tuple(statistics),
            values=values,
        )

    @property
    def phases(self) -> np.ndarray:
        """(U, R, 3) each repetition's own gyroscope axis, signed by its first phase (NaN: none)."""
        return self.values["phase"]


@dataclass(frozen=True)
class Pooled:
    """One row per calibration: the repetitions of unit ``unit`` weighted by ``weights`` (0/1 for a
    subset, counts for a bootstrap resample), summed.

    ``z0``, ``right``, ``rho_static`` and ``first_phase`` repeat the unit's; ``all_repetitions``
    (B,): the row uses every repetition once (the calibration "from all repetitions");
    ``n_samples`` (B,) the trimmed samples. ``values``: every summed part and every statistic's
    derived array (name -> (B, ...)), read as attributes: ``pooled.scatter`` (B, 3, 3) Kong's,
    ``pooled.gyro_axis`` (B, 3) the principal axis of the unit gyroscope samples (Ricci Eq. 1)
    signed along the declared right axis, ``pooled.gyro_rho`` (B,) its reliability (Ricci Eq.
    2), ``pooled.spread_deg`` (B,) the median angle between each chosen repetition's own axis and
    the pooled one (NaN for a resample), ``pooled.steps`` the step-band scatter, and so on.
    """

    unit: np.ndarray
    weights: np.ndarray
    z0: np.ndarray
    right: np.ndarray
    rho_static: np.ndarray
    first_phase: np.ndarray
    all_repetitions: np.ndarray
    n_samples: np.ndarray
    values: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.unit)

    def __getattr__(self, name: str) -> np.ndarray:
        values = self.__dict__.get("values", {})
        if name in values:
            return values[name]
        raise AttributeError(
            f"pooled statistics have no {name!r} (known: {', '.join(sorted(values))}): the method "
            "reading it must declare the statistic that gives it (aceval.methods.sufficient)"
        )

    @classmethod
    def concat(cls, rows: list[Pooled]) -> Pooled:
        """The rows of several pooled batches, in order (their values must match)."""
        fields = [f for f in cls.__dataclass_fields__ if f != "values"]
        values = {k: np.concatenate([r.values[k] for r in rows]) for k in rows[0].values}
        return cls(
            **{f: np.concatenate([getattr(r, f) for r in rows]) for f in fields}, values=values
        )

    @classmethod
    def of_axes(
        cls,
        z0,
        rho_static,
        gyro_axis,
        gyro_rho,
        spread_deg=np.nan,
        all_repetitions=True,
        right=None,
        statistics=None,
    ) -> Pooled:
        """One row given by its axes alone (the axis methods read no more): z0 (3,), the
        gyroscope axis (3,) already signed to the right, their rho, the repetitions' spread; every
        other part of ``statistics`` (default: every statistic the registry's methods declare)
        and what they derive, as of one repetition whose recording has none of them
        (:attr:`Part.missing`).
        """
        if statistics is None:
            from aceval.methods.registry import statistics as declared

            statistics = declared()
        axis = np.asarray(gyro_axis, float)
        units = Units._one_unit(
            z0, axis if right is None else right, [np.nan], statistics, {}, rho_static, "", ""
        )
        pooled = pool(units, np.zeros(1, int), np.ones((1, 1)))
        given = {
            "gyro_axis": axis[None],
            "gyro_rho": np.array([gyro_rho], float),
            "spread_deg": np.array([spread_deg], float),
        }
        return cls(
            **pooled.__dict__
            | {
                "all_repetitions": np.array([bool(all_repetitions)]),
                "values": pooled.values | given,
            }
        )


def pool(units: Units, unit: np.ndarray, weights: np.ndarray, subsets: bool = True) -> Pooled:
    """The statistics of each row's weighted union of its unit's repetitions (class docstring).

    ``unit`` (B,) indices into ``units``; ``weights`` (B, R). ``subsets``: the weights are 0/1
    (a statistic may derive what only a subset has, e.g. the repetitions' spread; a bootstrap
    resample has none).
    """
    unit = np.asarray(unit, int)
    weights = np.asarray(weights, float)
    values: dict[str, np.ndarray] = {}
    for statistic in units.statistics:
        for name, part in statistic.parts.items():
            if part.summed and name in units.values:
                values[name] = _weighted_sum(weights, units.values[name][unit])
    for statistic in units.statistics:
        if statistic.derive is not None:
            values |= statistic.derive(units, unit, weights, values, subsets)
    return Pooled(
        unit=unit,
        weights=weights,
        z0=units.pooled_z0(unit, weights),
        right=units.right[unit],
        rho_static=units.rho_static[unit],
        first_phase=units.first_phase[unit],
        all_repetitions=(weights == units.present[unit]).all(axis=1),
        n_samples=np.einsum("br,br->b", weights, units.n_samples[unit]),
        values=values,
    )


def _weighted_sum(weights: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``sum_r weights[b, r] * values[b, r, ...]`` (B, ...), NaN values counted as 0."""
    values = np.nan_to_num(values)
    if values.ndim == 4:
        return np.einsum("br,brij->bij", weights, values)
    if values.ndim == 3:
        return np.einsum("br,brk->bk", weights, values)
    return np.einsum("br,br->b", weights, values)


# --- the statistics of both papers ------------------------------------------------------------


def _acc_scatter(acc: np.ndarray, gyr: np.ndarray, kept: np.ndarray, fs_hz: float) -> dict:
    """Kong Eq. 3: the scatter ``sum a a^T`` (m^2/s^4) of the kept accelerations."""
    return dict(zip(ACC_SCATTER_COLUMNS, scatter(acc[kept]).ravel()))


#: Kong's scatter of the trimmed accelerations (Eq. 3): the plane of any union of repetitions is
#: the eigen-decomposition of their summed scatters
ACC_SCATTER = Statistic(
    "acc_scatter", {"scatter": Part(tuple(ACC_SCATTER_COLUMNS), (3, 3))}, reduce=_acc_scatter
)


def _gyro_moments(acc: np.ndarray, gyr: np.ndarray, kept: np.ndarray, fs_hz: float) -> dict:
    """Ricci Eq. 1-2: the moments of the kept unit gyroscope samples, with the recording's own
    axis signed by its first phase.
    """
    return recording_moments(gyr[kept], fs_hz, motion=True)


def _gyro_axis_of(units, unit, weights, sums, subsets) -> dict:
    """The pooled gyroscope axis, its rho and (for subsets) the repetitions' spread about it."""
    axis, rho = gyroscope_axis(
        sums["unit_sum"], sums["unit_scatter"], sums["n_unit"], units.right[unit]
    )
    chosen = weights > 0
    spread = (
        axis_spread_deg(units.phases[unit], axis, chosen) if subsets else np.full(len(unit), np.nan)
    )
    return {"gyro_axis": axis, "gyro_rho": rho, "spread_deg": spread}


#: the moments of the unit gyroscope samples (Ricci Eq. 1-2): their sum, scatter and count, and
#: each repetition's own axis signed by its first phase (kept per repetition)
GYRO_MOMENTS = Statistic(
    "gyro_moments",
    {
        "unit_sum": Part(tuple(SUM_COLUMNS), (3,)),
        "unit_scatter": Part(tuple(UNIT_SCATTER_COLUMNS), (3, 3)),
        "n_unit": Part(("n_unit",)),
        "phase": Part(tuple(PHASE_COLUMNS), (3,), absent=np.nan, missing=np.nan, summed=False),
    },
    reduce=_gyro_moments,
    derive=_gyro_axis_of,
)


def gyroscope_axis(
    unit_sum: np.ndarray, unit_scatter: np.ndarray, count: np.ndarray, right: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Axis (B, 3) and rho (B,) of summed unit-sample moments (sums (B, 3), scatters (B, 3, 3),
    counts (B,); Ricci Eq. 1-2, as :func:`aceval.methods.moments.axis_from_moments`: the first
    right singular vector, ``rho = s1 / (s1 + s2 + s3)``), the axis signed along ``right`` (B,
    3); NaN where fewer than 3 samples.
    """
    eigenvalues, vectors = np.linalg.eigh(unit_scatter)
    singular = np.sqrt(np.clip(eigenvalues[:, ::-1], 0.0, None))
    axis = vectors[:, :, -1]
    with np.errstate(invalid="ignore", divide="ignore"):
        projection = np.einsum("bi,bi->b", unit_sum, axis) / count
        rho = singular[:, 0] / singular.sum(axis=1)
    largest = np.take_along_axis(axis, np.argmax(np.abs(axis), axis=1)[:, None], axis=1)[:, 0]
    sign = np.where(np.abs(projection) > 1e-12, np.sign(projection), np.where(largest < 0, -1, 1))
    axis = axis * sign[:, None]
    axis = axis * np.where(np.einsum("bi,bi->b", axis, right) < 0, -1.0, 1.0)[:, None]
    few = ~(count >= 3)
    axis[few], rho[few] = np.nan, np.nan
    return axis, rho


def axis_spread_deg(phases: np.ndarray, pooled: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Median angle (deg, sign ignored) between each chosen repetition's own axis (``phases``
    (B, R, 3), NaN rows skipped) and the pooled axis (B, 3); NaN with none.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        phases = phases / np.linalg.norm(phases, axis=2)[..., None]
    return median_where(vector_angle_deg(phases, pooled[:, None], sign_free=True), chosen)


def median_where(values: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Each row's median of ``values`` (B, R) where ``chosen`` and finite; NaN where none."""
    masked = np.where(chosen, values, np.nan)
    out = np.full(len(values), np.nan)
    some = np.isfinite(masked).any(axis=1)
    out[some] = np.nanmedian(masked[some], axis=1)
    return out
