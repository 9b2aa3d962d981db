"""The one small interface every calibration method of Kong's protocol exposes (the registry:
:mod:`aceval.methods.registry`).

A method is a pure function of pooled statistics (:class:`aceval.methods.statistics.Pooled`, one
row per calibration: a unit and the repetitions it uses) to a :class:`Fit`: a rotation per row
(sensor -> body, Kong Eq. 6: ``d_body = R @ d_sensor``), the method's own flag ('' when valid) and
its diagnostics, by the column names of the calibrations table. ``resample`` gives the rotations of
bootstrap resamples of the same statistics, NaN where the method would not calibrate, for its
uncertainty (:mod:`aceval.methods.uncertainty`). Nothing here reads a file or knows a dataset:
calibration (:mod:`aceval.calibrate.pipeline`) pools the statistics, calls each method in the
registry's order, adds the checks' flags and writes the rows.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aceval.methods.statistics import Pooled


@dataclass
class Fit:
    """A method's calibrations of a batch of rows: ``R`` (B, 3, 3), NaN where there is none;
    ``flag`` (B,) object, '' where valid, else the reason (error codes joined by ';');
    ``columns``: diagnostics, name -> (B,) values, for the calibrations table.
    """

    R: np.ndarray
    flag: np.ndarray
    columns: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.R)

    def select(self, rows) -> Fit:
        """The fit of some rows (an index array or boolean mask)."""
        return Fit(self.R[rows], self.flag[rows], {k: v[rows] for k, v in self.columns.items()})


#: ``fit(pooled, fitted) -> Fit``: ``fitted`` holds the fits of the methods listed before it, on
#: the same rows (a method may build on another: the combined heading on Kong's plane)
FitFunction = Callable[[Pooled, Mapping[str, Fit]], Fit]


def combine_flags(*flags: str) -> str:
    """Every flag of a row, each once, in the order given, joined by ';' ('' when none): a check
    adds its flag beside the others' and never replaces them.
    """
    names = [name for f in flags if isinstance(f, str) for name in f.split(";") if name]
    return ";".join(dict.fromkeys(names))


def all_rows(pooled: Pooled) -> np.ndarray:
    """Every row: a method that calibrates every unit."""
    return np.ones(len(pooled), dtype=bool)


@dataclass(frozen=True)
class Method:
    """One calibration method of Kong's protocol.

    ``name``: its ``method`` in the calibrations table. ``fit``: :data:`FitFunction`.
    ``resample``: the same from bootstrap resamples (``fitted`` their fits by the methods before
    it), R NaN where the method would flag a resample; None: no uncertainty. ``every_subset``:
    fitted on every subset of repetitions (Kong's method, Obj 3-5) rather than on all of them and
    the Obj 4 test-retest subsets. ``applies``: the rows (pooled) it calibrates at all; a row it
    applies to but cannot calibrate has R NaN and a flag (e.g. ``not_applicable``).
    ``summary``: one line on what it does, for the command line and the docs.
    """

    name: str
    fit: FitFunction
    resample: FitFunction | None = None
    every_subset: bool = False
    applies: Callable[[Pooled], np.ndarray] = all_rows
    summary: str = ""
