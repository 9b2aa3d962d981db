"""The statistics every method of Kong's protocol fits from: each repetition's, held per
calibration unit (one IMU in one motion test), and their sums over any subset or bootstrap
resample of the repetitions.

One pass over the samples (:mod:`aceval.signals.reduction`) reduces each repetition to a few sums:
Kong's acceleration scatter ``sum a a^T`` and count (Kong Eq. 3), the moments of the unit gyroscope
samples and the signed first-phase axis (Ricci Eq. 1-2), the third moments of the angular velocity
(the shank's swing in walking) and, in walking, the scatter of the step-band acceleration. A union
of repetitions is a weighted sum of these (:func:`pool`), so a calibration from any subset costs a
few 3x3 sums and one ``eigh``, never another pass.

:class:`Units` holds the repetitions of every unit of a job at once, padded to the most
repetitions of any unit (an absent repetition has weight 0 and zero sums), with what is constant
over a unit: the IMU's z0 and static rho, its declared right axis, the test's first phase and the
segment. :class:`Pooled` holds one row per calibration (a unit and the weight of each of its
repetitions): what every method's ``fit`` reads (:mod:`aceval.methods.registry`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aceval.data.rotations import vector_angle_deg

#: the per-repetition moments of the unit gyroscope samples (Ricci Eq. 1-2): their sum (3), their
#: scatter (9), their count and the repetition's own axis signed by its first phase (3)
SUM, SCATTER, COUNT, PHASE = slice(0, 3), slice(3, 12), 12, slice(13, 16)


@dataclass(frozen=True)
class Units:
    """Every calibration unit (IMU x motion test) of a job: ``U`` units, at most ``R`` repetitions.

    Per unit: ``z0`` (U, 3) the downward vertical from quiet standing (Kong Eq. 2), ``right``
    (U, 3) the declared right axis, ``rho_static`` (U,) the static axis's reliability,
    ``first_phase`` and ``segment`` (U,) str. Per repetition (padded): ``rep`` (U, R) its number
    (0 where absent), ``present`` (U, R), ``scatters`` (U, R, 3, 3) m^2/s^4, ``n_samples`` (U, R),
    ``moments`` (U, R, 16) (:data:`SUM` ... :data:`PHASE`; absent: 0, a missing phase: NaN),
    ``third`` (U, R, 10) or None, ``steps`` (U, R, 3, 3) the step-band scatter (NaN where a
    repetition has none: the unit has no step-harmonic calibration), ``step_hz`` (U, R) the
    step frequency of the subject's walking test and ``step_disagrees`` (U, R) 1 where that
    test's recordings disagree on it (:func:`aceval.methods.step_harmonic.pooled_steps`).
    """

    z0: np.ndarray
    right: np.ndarray
    rho_static: np.ndarray
    first_phase: np.ndarray
    segment: np.ndarray
    rep: np.ndarray
    present: np.ndarray
    scatters: np.ndarray
    n_samples: np.ndarray
    moments: np.ndarray
    third: np.ndarray | None
    steps: np.ndarray
    step_hz: np.ndarray
    step_disagrees: np.ndarray

    def __len__(self) -> int:
        return len(self.z0)

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
        steps=None,
    ) -> Units:
        """One unit from its repetitions' arrays (a caller with samples of its own, and the
        tests): z0 and the declared right axis (3,), Kong's scatters (n, 3, 3) and counts (n,),
        the unit gyroscope scatters (n, 3, 3) (each unit sample adds 1 to the trace, which is the
        count; the sums are taken as 0: movement axes are signed by ``right``), optionally the
        step-band scatters (n, 3, 3).
        """
        scatters = np.asarray(scatters, float)
        unit_scatters = np.asarray(unit_scatters, float)
        n = len(scatters)
        moments = np.zeros((1, n, 16))
        moments[0, :, SCATTER] = unit_scatters.reshape(n, 9)
        moments[0, :, COUNT] = np.trace(unit_scatters, axis1=1, axis2=2)
        moments[0, :, PHASE] = np.nan
        return cls(
            z0=np.asarray(z0, float)[None],
            right=np.asarray(right, float)[None],
            rho_static=np.array([rho_static], float),
            first_phase=np.array([first_phase], dtype=object),
            segment=np.array([segment], dtype=object),
            rep=np.arange(1, n + 1)[None],
            present=np.ones((1, n), dtype=bool),
            scatters=scatters[None],
            n_samples=np.asarray(n_samples, float)[None],
            moments=moments,
            third=None,
            steps=np.full((1, n, 3, 3), np.nan)
            if steps is None
            else np.asarray(steps, float)[None],
            step_hz=np.full((1, n), np.nan),
            step_disagrees=np.zeros((1, n)),
        )

    @property
    def phases(self) -> np.ndarray:
        """(U, R, 3) each repetition's own gyroscope axis, signed by its first phase (NaN: none)."""
        return self.moments[..., PHASE]

    @property
    def walking(self) -> np.ndarray:
        """(U,) every repetition of the unit has a step-band scatter (a walking test)."""
        return np.isfinite(self.steps).all(axis=(1, 2, 3))


@dataclass(frozen=True)
class Pooled:
    """One row per calibration: the repetitions of unit ``unit`` weighted by ``weights`` (0/1 for a
    subset, counts for a bootstrap resample), summed.

    ``scatter`` (B, 3, 3) and ``n_samples`` (B,): Kong's; ``gyro_axis`` (B, 3) the principal axis
    of the unit gyroscope samples (Ricci Eq. 1), signed along the declared right axis, and
    ``gyro_rho`` (B,) its reliability (Ricci Eq. 2); ``spread_deg`` (B,) the median angle between
    each chosen repetition's own axis and the pooled one (NaN for a resample); ``steps`` (B, 3, 3)
    the step-band scatter (NaN where the unit has none), ``step_disagrees`` (B,) whether the
    recordings disagree on the step frequency (:class:`Units`) and ``step_hz`` (B,) the chosen
    repetitions' median step frequency. ``z0``, ``right``, ``rho_static``, ``first_phase`` and
    ``walking`` repeat the unit's; ``all_repetitions`` (B,): the row uses every repetition once
    (the calibration "from all repetitions"); ``n_unit`` (B,) the unit gyroscope samples.
    """

    unit: np.ndarray
    weights: np.ndarray
    z0: np.ndarray
    right: np.ndarray
    rho_static: np.ndarray
    first_phase: np.ndarray
    walking: np.ndarray
    all_repetitions: np.ndarray
    scatter: np.ndarray
    n_samples: np.ndarray
    unit_scatter: np.ndarray
    n_unit: np.ndarray
    gyro_axis: np.ndarray
    gyro_rho: np.ndarray
    spread_deg: np.ndarray
    steps: np.ndarray
    step_hz: np.ndarray
    step_disagrees: np.ndarray

    def __len__(self) -> int:
        return len(self.unit)

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
    ) -> Pooled:
        """One row given by its axes alone (the axis methods read no more): z0 (3,), the
        gyroscope axis (3,) already signed to the right, their rho, the repetitions' spread; the
        other statistics NaN.
        """
        z0, axis = np.asarray(z0, float)[None], np.asarray(gyro_axis, float)[None]
        nan = np.full(1, np.nan)
        return cls(
            unit=np.zeros(1, int),
            weights=np.ones((1, 1)),
            z0=z0,
            right=axis if right is None else np.asarray(right, float)[None],
            rho_static=np.array([rho_static], float),
            first_phase=np.array([""], dtype=object),
            walking=np.zeros(1, bool),
            all_repetitions=np.array([bool(all_repetitions)]),
            scatter=np.full((1, 3, 3), np.nan),
            n_samples=nan,
            unit_scatter=np.full((1, 3, 3), np.nan),
            n_unit=nan,
            gyro_axis=axis,
            gyro_rho=np.array([gyro_rho], float),
            spread_deg=np.array([spread_deg], float),
            steps=np.full((1, 3, 3), np.nan),
            step_hz=nan,
            step_disagrees=np.zeros(1, dtype=bool),
        )


def pool(units: Units, unit: np.ndarray, weights: np.ndarray, subsets: bool = True) -> Pooled:
    """The statistics of each row's weighted union of its unit's repetitions (class docstring).

    ``unit`` (B,) indices into ``units``; ``weights`` (B, R). ``subsets``: the weights are 0/1
    (the spread and the step frequency are a subset's; a bootstrap resample has neither).
    """
    unit = np.asarray(unit, int)
    weights = np.asarray(weights, float)
    scatter = np.einsum("br,brij->bij", weights, units.scatters[unit])
    n_samples = np.einsum("br,br->b", weights, units.n_samples[unit])
    moments = np.einsum("br,brk->bk", weights, np.nan_to_num(units.moments[unit]))
    right = units.right[unit]
    axis, rho = gyroscope_axis(moments, right)
    nan = np.full(len(unit), np.nan)
    chosen = weights > 0
    spread = axis_spread_deg(units.phases[unit], axis, chosen) if subsets else nan
    with np.errstate(invalid="ignore"):
        steps = np.einsum(
            "br,brij->bij", weights, np.where(chosen[..., None, None], units.steps[unit], 0.0)
        )
    steps[~units.walking[unit]] = np.nan
    step_hz = _median_where(units.step_hz[unit], chosen) if subsets else nan
    return Pooled(
        unit=unit,
        weights=weights,
        z0=units.z0[unit],
        right=right,
        rho_static=units.rho_static[unit],
        first_phase=units.first_phase[unit],
        walking=units.walking[unit],
        all_repetitions=(weights == units.present[unit]).all(axis=1),
        scatter=scatter,
        n_samples=n_samples,
        unit_scatter=moments[:, SCATTER].reshape(-1, 3, 3),
        n_unit=moments[:, COUNT],
        gyro_axis=axis,
        gyro_rho=rho,
        spread_deg=spread,
        steps=steps,
        step_hz=step_hz,
        step_disagrees=(np.where(chosen, units.step_disagrees[unit], 0.0) > 0).any(axis=1),
    )


def gyroscope_axis(moments: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis (B, 3) and rho (B,) of summed unit-sample moments (B, 16) (Ricci Eq. 1-2, as
    :func:`aceval.methods.ricci.axis_from_moments`: the first right singular vector, ``rho =
    s1 / (s1 + s2 + s3)``), the axis signed along ``right`` (B, 3); NaN where fewer than 3
    samples.
    """
    eigenvalues, vectors = np.linalg.eigh(moments[:, SCATTER].reshape(-1, 3, 3))
    singular = np.sqrt(np.clip(eigenvalues[:, ::-1], 0.0, None))
    axis = vectors[:, :, -1]
    count = moments[:, COUNT]
    with np.errstate(invalid="ignore", divide="ignore"):
        projection = np.einsum("bi,bi->b", moments[:, SUM], axis) / count
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
    return _median_where(vector_angle_deg(phases, pooled[:, None], sign_free=True), chosen)


def _median_where(values: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Each row's median of ``values`` (B, R) where ``chosen`` and finite; NaN where none."""
    masked = np.where(chosen, values, np.nan)
    out = np.full(len(values), np.nan)
    some = np.isfinite(masked).any(axis=1)
    out[some] = np.nanmedian(masked[some], axis=1)
    return out
