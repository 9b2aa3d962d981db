"""The calibrations table: its columns, its flags and the selections every later stage makes of it
(one row per calibration: subject, set, IMU, test, the repetitions it used, the method, R and
``flag``); an IMU's identity columns; and the axes table's columns and rows (one per functional
axis).
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import Dataset
from aceval.methods import registry
from aceval.methods.interface import combine_flags as combine_flags  # the table's flags

CALIBRATION_KEY = ["subject", "sensor_set", "imu", "test"]
#: the calibrations column that says whether the recordings verified the declared right axis's
#: sign (:func:`aceval.signals.checks.direction_checks`; carried to the tests that cannot tell by
#: :func:`aceval.calibrate.pipeline.propagate_verified`)
SIGN_VERIFIED = "right_axis_sign_verified"
KEY = ["subject", "sensor_set", "imu"]
#: what a calibration is of: the sensor, the test, the repetitions and the method
IDENTITY_COLUMNS = [*KEY, "segment", "side", "test", "repetitions", "n_reps", "method"]
#: the columns every calibration table has (an empty table keeps them)
CALIBRATION_COLUMNS = [*IDENTITY_COLUMNS, *R_COLUMNS, "flag"]


def all_subsets(repetitions: list[int]) -> list[tuple[int, ...]]:
    """Every non-empty subset of the repetitions, by size then lexicographically (31 for 5)."""
    return [
        c for k in range(1, len(repetitions) + 1) for c in itertools.combinations(repetitions, k)
    ]


def subset_label(subset) -> str:
    """``(1, 3)`` -> ``'R1+R3'`` (the inverse of :func:`aceval.calibrate.table.parse_subset`)."""
    return "+".join(f"R{r}" for r in subset)


def flag_text(flags: pd.Series) -> pd.Series:
    """A ``flag`` column as strings, '' where empty (read back from a CSV, an empty flag is NaN and
    a column without any flag is float).
    """
    return flags.astype(object).fillna("").astype(str)


def flag_sets(flags: pd.Series) -> pd.Series:
    """The one reader of a ``flag`` column: each row's flags as a frozenset of names (';'-joined
    as :func:`combine_flags` writes them; empty where there is none).
    """
    return flag_text(flags).str.split(";").map(lambda names: frozenset(n for n in names if n))


def has_flag(flags: pd.Series, name: str) -> pd.Series:
    """True for the rows whose ``flag`` includes ``name`` (:func:`flag_sets`)."""
    return flag_sets(flags).map(lambda names: name in names).astype(bool)


def parse_subset(label: str) -> tuple[int, ...]:
    """``'R1+R3'`` -> ``(1, 3)`` (the inverse of :func:`aceval.calibrate.table.subset_label`)."""
    return tuple(int(part[1:]) for part in label.split("+"))


def matrices(table: pd.DataFrame) -> np.ndarray:
    """The rotations of a calibration table, shape (n, 3, 3)."""
    return table[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)


#: flags that judge a calibration against the other methods', not against its own recordings
#: (:func:`aceval.evaluation.decision.flag_disagreements`): every analysis of a method keeps these
#: rows (:func:`unflagged`), so that a method's numbers do not depend on which other methods ran;
#: the decision reads them
COMPARISON_FLAGS = ("methods_disagree",)


def only_flags(table: pd.DataFrame, names) -> pd.Series:
    """True for the rows whose flags (:func:`flag_sets`) are all among ``names`` (or none)."""
    allowed = frozenset(names)
    return flag_sets(table["flag"]).map(allowed.issuperset).astype(bool)


def unflagged(table: pd.DataFrame) -> pd.Series:
    """True for the rows no flag takes out: no flag, or only :data:`COMPARISON_FLAGS` (read back
    from a CSV, an empty flag is NaN; a column with no flag at all is read as numbers, and is not
    turned into a million strings).
    """
    flag = table["flag"]
    if pd.api.types.is_numeric_dtype(flag):
        return flag.isna()
    clean = flag.isna() | (flag.astype(str) == "")
    if not clean.all():
        clean[~clean] = only_flags(table[~clean], COMPARISON_FLAGS)
    return clean


def usable(calibrations: pd.DataFrame, method: str | None = None) -> pd.DataFrame:
    """A method's calibrations that no flag takes out (:func:`unflagged`; Objectives 1-5 are
    about Kong's method; the other methods are compared in
    :mod:`aceval.evaluation.methods_comparison`).
    """
    calibrations = rows_of_method(calibrations, method)
    return calibrations[unflagged(calibrations)]


#: flags that say how far a calibration is from the others of its unit, not that it is wrong in
#: itself: Kong's Obj 3-4 and the methods' test-retest, which measure that spread, keep them
SPREAD_FLAGS = ("unstable",)


def spread_usable(calibrations: pd.DataFrame, method: str | None = None) -> pd.DataFrame:
    """A method's calibrations that are unflagged or flagged only by :data:`SPREAD_FLAGS`: what
    the spread between subsets (Kong Obj 3-4, every method's test-retest) is measured on (leaving
    the unstable subsets out would hide the spread those objectives measure).
    """
    calibrations = rows_of_method(calibrations, method)
    return calibrations[only_flags(calibrations, SPREAD_FLAGS + COMPARISON_FLAGS)]


def rows_of_method(calibrations: pd.DataFrame, method: str | None = None) -> pd.DataFrame:
    """The rows of ``method``, by default Kong's (the registry's method of Kong et al. 2016; all
    rows of a table without ``method``).
    """
    method = method or registry.paper_method("kong2016")
    return (
        calibrations[calibrations["method"] == method]
        if "method" in calibrations.columns
        else calibrations
    )


def full_set_rows(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Every method's calibrations from the most repetitions of each (subject, set, IMU, test),
    flagged ones included: the one definition of "the calibration from all repetitions", and all
    that the tables and figures read besides the Obj 3-5 angles and the methods' test-retest units
    (:func:`all_angles`, :func:`aceval.evaluation.methods_comparison.retest_units`), which are computed per
    subject from the subsets (7 % of Kong's rows).
    """
    key = [*CALIBRATION_KEY, "method"] if "method" in calibrations else CALIBRATION_KEY
    most = calibrations.groupby(key)["n_reps"].transform("max")
    return calibrations[calibrations["n_reps"] == most]


def full_sets(calibrations: pd.DataFrame) -> pd.DataFrame:
    """The calibration from all usable repetitions of each (subject, set, IMU, test); left out when
    that calibration itself is flagged.
    """
    return usable(full_set_rows(rows_of_method(calibrations)))


def imu_identity(dataset: Dataset, subject: str, sensor_set: str, imu: str) -> dict:
    """The key and place columns of an IMU's rows: subject, set, IMU, segment and side."""
    segment, side = dataset.places[(sensor_set, imu)]
    return {
        "subject": subject,
        "sensor_set": sensor_set,
        "imu": imu,
        "segment": segment,
        "side": side,
    }


AXES_COLUMNS = [
    "subject",
    "sensor_set",
    "imu",
    "segment",
    "side",
    "test",
    "kind",
    "signal",
    "n_recordings",
    "n_samples",
    "axis_x",
    "axis_y",
    "axis_z",
    "rho",
    "reference",
    "residual_before_deg",
    "residual_after_deg",
]


def axis_row(
    identity: dict, test: str, kind: str, estimate, reference: str, n_recordings: int | None = None
) -> dict:
    """One row of the axes table (:data:`AXES_COLUMNS`) from a functional axis ``estimate``."""
    return {
        **identity,
        "test": test,
        "kind": kind,
        "signal": "acc" if kind == "static" else "gyr",
        "n_recordings": n_recordings,
        "n_samples": estimate.n_samples,
        "axis_x": estimate.axis[0],
        "axis_y": estimate.axis[1],
        "axis_z": estimate.axis[2],
        "rho": estimate.rho,
        "reference": reference,
        "residual_before_deg": np.nan,
        "residual_after_deg": np.nan,
    }
