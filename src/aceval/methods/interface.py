"""The one small interface every calibration method of Kong's protocol exposes (the registry:
:mod:`aceval.methods.registry`), in gaitmap's style: parameters in ``__init__``, one action
``fit(pooled, fitted) -> self``, results in attributes with a trailing underscore.

A method is a class that reads pooled statistics (:class:`aceval.methods.sufficient.Pooled`, one
row per calibration: a unit and the repetitions it uses) and sets ``rotation_`` (B, 3, 3; sensor
-> body, Kong Eq. 6: ``d_body = R @ d_sensor``; NaN where it has none), ``flag_`` (B,; '' when
valid, else the reason, error codes joined by ';') and ``diagnostics_`` (name -> (B,) values, by
the column names of the calibrations table). It declares what the rest of aceval needs to know:

* ``statistics``: the sufficient statistics it reads (:class:`aceval.methods.sufficient.Statistic`:
  the one pass computes what the registry's methods declare, and nothing imports a method to know
  it);
* ``needs``: the methods whose fits of the same rows it reads (``fitted[name]``, a fitted instance:
  the combined heading reads Kong's plane); calibration fits them first, whatever the registry's
  order;
* ``every_subset``: fitted on every subset of a unit's repetitions (Kong's Obj 3-5), rather than
  on all of them and the Obj 4 test-retest subsets;
* ``diagnostics``: the columns of the calibrations table its ``diagnostics_`` fills, in their
  order there (after the columns every calibration has: :mod:`aceval.calibrate.rows`);
* ``signal``: what its heading comes from ('acc' the accelerations' plane, 'gyr' the gyroscope's
  axis, 'step' the step's direction, 'acc+gyr' both): estimates from different signals of one
  unit check each other in its uncertainty (:mod:`aceval.methods.uncertainty`);
* ``cone_reference``: it is its signal's reference, the one estimate of that signal every other
  method's cone is compared with (one per signal; a method that is not one leaves the other
  methods' cones as they are);
* ``resample``: the same from bootstrap resamples, ``rotation_`` NaN where it would flag one (its
  uncertainty, :mod:`aceval.methods.uncertainty`); a method without it has no bootstrap cone;
* ``fit_functional``: its calibration from any set of axis pairs (Ricci's functional design,
  :func:`aceval.methods.functional.fit_axes`); a method without it is not fitted there.

Its name, order, paper and summary are its line in the registry. Nothing here reads a file or
knows a dataset: calibration (:mod:`aceval.calibrate.pipeline`) pools the statistics, fits every
method, adds the checks' flags and writes the rows.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from aceval.methods.sufficient import Pooled, Statistic


@dataclass(frozen=True)
class AxisProblem:
    """One calibration of Ricci's functional design: axis pairs ``v_ref ~ R v_est`` ((n, 3)
    each: the body references and the sensor's axes), weighted by ``rho`` (n,) (Ricci Eq. 7);
    ``triad_pair`` (primary, secondary) the rows a two-axis method keeps; ``random_starts`` and
    ``seed``: the LM's extra starts from random rotations; ``diagnostics``: the LM with lambda
    fixed too.
    """

    v_ref: np.ndarray
    v_est: np.ndarray
    rho: np.ndarray
    triad_pair: tuple[int, int]
    random_starts: int = 0
    seed: int = 0
    diagnostics: bool = True


@dataclass
class Fit:
    """A method's calibrations of a batch of rows, as calibration carries them on (its flags
    joined with the checks'): ``R`` (B, 3, 3), NaN where there is none; ``flag`` (B,) object, ''
    where valid; ``columns``: diagnostics, name -> (B,) values, for the calibrations table.
    """

    R: np.ndarray
    flag: np.ndarray
    columns: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.R)

    def select(self, rows) -> Fit:
        """The fit of some rows (an index array or boolean mask)."""
        return Fit(self.R[rows], self.flag[rows], {k: v[rows] for k, v in self.columns.items()})


def combine_flags(*flags: str) -> str:
    """Every flag of a row, each once, in the order given, joined by ';' ('' when none): a check
    adds its flag beside the others' and never replaces them.
    """
    names = [name for f in flags if isinstance(f, str) for name in f.split(";") if name]
    return ";".join(dict.fromkeys(names))


class CalibrationMethod:
    """One calibration method of Kong's protocol (module docstring).

    Subclasses set the class attributes ``statistics``, ``needs``, ``every_subset``,
    ``diagnostics``, ``signal`` and ``cone_reference``, take their parameters in ``__init__`` and
    implement :meth:`fit` (and :meth:`resample` for an uncertainty, :meth:`fit_functional` for
    Ricci's functional design); :meth:`applies` when they calibrate only some rows.

    Attributes
    ----------
    rotation_ : (B, 3, 3) array
        Sensor -> body rotations, NaN where there is none.
    flag_ : (B,) object array
        '' where valid, else the reason.
    diagnostics_ : dict
        Name -> (B,) values, columns of the calibrations table.
    """

    statistics: ClassVar[tuple[Statistic, ...]] = ()
    needs: ClassVar[tuple[str, ...]] = ()
    every_subset: ClassVar[bool] = False
    diagnostics: ClassVar[tuple[str, ...]] = ()
    signal: ClassVar[str] = ""
    cone_reference: ClassVar[bool] = False

    rotation_: np.ndarray
    flag_: np.ndarray
    diagnostics_: dict[str, np.ndarray]

    def fit(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod]) -> CalibrationMethod:
        """Calibrate every row of ``pooled``; ``fitted``: the fits of :attr:`needs`."""
        raise NotImplementedError

    def resample(
        self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod]
    ) -> CalibrationMethod:
        """Calibrate bootstrap resamples (``pooled`` from resampled weights), ``rotation_`` NaN
        where the method would flag one; ``fitted``: the resamples' fits of :attr:`needs`.
        """
        raise NotImplementedError

    @classmethod
    def fit_functional(cls, problem: AxisProblem) -> dict:
        """Its calibration of one IMU in Ricci's functional design from the axis pairs of
        ``problem``: ``{'R': (3, 3), 'flag': str, **diagnostics}`` (raises
        :class:`aceval.data.errors.CalibrationError` or ValueError where it cannot fit).
        """
        raise NotImplementedError

    @classmethod
    def serves_functional_design(cls) -> bool:
        """Whether Ricci's functional design fits it (it has :meth:`fit_functional`)."""
        return cls.fit_functional.__func__ is not CalibrationMethod.fit_functional.__func__

    def applies(self, pooled: Pooled) -> np.ndarray:
        """(B,) the rows it calibrates at all (a row it applies to but cannot calibrate has a NaN
        rotation and a flag, e.g. ``not_applicable``). Default: every row.
        """
        return np.ones(len(pooled), dtype=bool)

    @classmethod
    def has_resample(cls) -> bool:
        """Whether the method resamples (has a bootstrap uncertainty)."""
        return cls.resample is not CalibrationMethod.resample

    def _set(self, R, flag, diagnostics: dict | None = None) -> CalibrationMethod:
        self.rotation_ = np.asarray(R, float)
        self.flag_ = np.asarray(flag, dtype=object)
        self.diagnostics_ = dict(diagnostics or {})
        return self

    @property
    def result(self) -> Fit:
        """The fit as calibration carries it on (:class:`Fit`)."""
        return Fit(self.rotation_, self.flag_, dict(self.diagnostics_))
