"""For every sensor: which calibration to use and how far off it may be (issue 39), beyond both
papers.

* :func:`flag_disagreements`: the methods agree, or say so. Per calibration unit (one IMU in one
  test), every method's unflagged calibration from all its repetitions (the peers' too) against
  every other's: two calibrations further apart than their uncertainties allow (``sqrt(cone_a^2 +
  cone_b^2)``: each cone bounds its own error, and two methods' errors on the same recordings
  share their z0 and their samples, so they are not negatively correlated and their difference is
  at most as wide as the two in quadrature; a peer has no uncertainty of its own and is allowed
  the widest of aceval's on that unit) disagree, and a calibration that disagrees with more than
  half of the others is flagged ``methods_disagree`` (two methods that disagree are both flagged;
  of many, the outliers). ``methods_spread_deg``: its largest angle to another method's
  calibration.
* :func:`decision_table`: per IMU, the calibration to use: of its unflagged calibrations from all
  repetitions (every method, every test that calibrates it) with an uncertainty measured on the
  recording (a peer has none: it is a cross-check, chosen only where nothing else is unflagged,
  and then 'use with care'), the one whose method and test were
  most accurate on this dataset's segment (median error to the ground truth over its units) or,
  with no ground truth, most repeatable (median test-retest angle: repeatability, not accuracy;
  the table says which); its uncertainty, the spread between the methods, how many calibrations
  the choice rests on and a plain verdict.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import (
    CALIBRATION_KEY,
    combine_flags,
    flag_text,
    full_set_rows,
    matrices,
    unflagged,
)
from aceval.data.rotations import error_angle_deg
from aceval.methods import registry
from aceval.methods.uncertainty import UNDETERMINED_CONE_DEG

#: the uncertainty of a calibration (deg): the cone column of :mod:`aceval.methods.uncertainty`
CONE = "cone_deg"
#: beyond this uncertainty (deg) a calibration's heading is not determined: it is not used
MAX_CONE_DEG = UNDETERMINED_CONE_DEG
#: the IMU of a decision
IMU_KEY = ["subject", "sensor_set", "imu"]
DECISION_COLUMNS = [
    *IMU_KEY,
    "segment",
    "side",
    "method",
    "test",
    "repetitions",
    CONE,
    "methods_spread_deg",
    "n_unflagged",
    "n_calibrations",
    "flags_elsewhere",
    "disagreeing",
    "basis",
    "evidence_median_deg",
    "evidence_n",
    "note",
    "verdict",
]


def flag_disagreements(calibrations: pd.DataFrame) -> pd.DataFrame:
    """The calibrations with ``methods_disagree`` added to the calibrations from all repetitions
    that disagree with more than half of the other methods' on their unit, and
    ``methods_spread_deg`` on every compared one (module docstring).
    """
    if calibrations is None or calibrations.empty or "method" not in calibrations:
        return calibrations
    calibrations = calibrations.reset_index(drop=True)
    full = full_set_rows(calibrations)
    full = full[unflagged(full) & np.isfinite(matrices(full)).all(axis=(1, 2))]
    spread = np.full(len(calibrations), np.nan)
    disagree = np.zeros(len(calibrations), dtype=bool)
    cone = full[CONE] if CONE in full else pd.Series(np.nan, index=full.index)
    for _, unit in full.groupby(CALIBRATION_KEY, sort=False):
        if len(unit) < 2:
            continue
        R = matrices(unit)
        angles = error_angle_deg(R[:, None], R[None])
        own = cone.loc[unit.index].to_numpy(float)
        peer = unit["method"].map(lambda m: registry.method(m).peer is not None).to_numpy()
        widest = np.nanmax(own[~peer]) if np.isfinite(own[~peer]).any() else np.nan
        own = np.where(peer & ~np.isfinite(own), widest, own)
        apart = angles > np.hypot(own[:, None], own[None, :])  # NaN allowance: not judged
        np.fill_diagonal(angles, np.nan)
        spread[unit.index] = np.nanmax(angles, axis=1)
        disagree[unit.index] = apart.sum(axis=1) > (len(unit) - 1) / 2
    flags = [
        combine_flags(f, "methods_disagree" if d else "")
        for f, d in zip(flag_text(calibrations["flag"]), disagree)
    ]
    return calibrations.assign(methods_spread_deg=spread, flag=flags)


def _evidence(calibrations: pd.DataFrame, test_retest_k: int, retest_units) -> tuple:
    """``(cells, basis)``: per (segment, test, sensor_set, method), the median error to the
    ground truth and its n (basis 'accuracy') or, without a truth, the median test-retest angle
    and its n ('repeatability').
    """
    from aceval.evaluation.methods_comparison import methods_table, retest_table

    keys = ["segment", "test", "sensor_set", "method"]
    has_truth = "error_deg" in calibrations and np.isfinite(calibrations["error_deg"]).any()
    if has_truth:
        table, basis = methods_table(calibrations), "accuracy"
    else:
        table, basis = retest_table(calibrations, test_retest_k, retest_units), "repeatability"
    if table.empty or "median" not in table:
        return pd.DataFrame(columns=[*keys, "median", "n"]), basis
    return table.dropna(subset=["median"])[[*keys, "median", "n"]], basis


def decision_table(
    calibrations: pd.DataFrame, test_retest_k: int = 3, retest_units=None
) -> pd.DataFrame:
    """One row per IMU (subject, set, IMU): the calibration to use and why (module docstring).

    ``method``, ``test``, ``repetitions`` and its uncertainty (:data:`CONE`, deg); the largest
    angle between it and another method's unflagged calibration of the same test
    (``methods_spread_deg``) and the methods flagged ``methods_disagree`` there (``disagreeing``);
    ``n_unflagged`` of ``n_calibrations`` (the IMU's calibrations from
    all repetitions it could choose among, flagged ones included; a peer that does not apply is
    not counted) and the flags of the others (``flags_elsewhere``, with their counts); ``basis``
    ('accuracy': the method and test had the smallest median error to the ground truth on this
    segment, ``evidence_median_deg`` over ``evidence_n`` units; 'repeatability': the smallest
    median test-retest angle, no ground truth); ``note`` (a peer outside its authors' design);
    ``verdict``: 'use', 'use with care: ...' (the methods disagree beyond their uncertainties) or
    'no trustworthy calibration: ...' (why).
    """
    if calibrations is None or calibrations.empty:
        return pd.DataFrame(columns=DECISION_COLUMNS)
    evidence, basis = _evidence(calibrations, test_retest_k, retest_units)
    full = full_set_rows(calibrations)
    applicable = full[~flag_text(full["flag"]).str.contains("not_applicable")]
    rows = [_decide(imu, evidence, basis) for _, imu in applicable.groupby(IMU_KEY, sort=True)]
    return pd.DataFrame(rows, columns=DECISION_COLUMNS)


def _flag_counts(rows: pd.DataFrame, cone: pd.Series | None = None) -> str:
    """'not_planar x3; backward x1': the flags of ``rows`` by how often they occur (a peer's
    ``not_applicable`` left out: it made no calibration to count), and the unflagged ones left out
    for an uncertainty beyond :data:`MAX_CONE_DEG` (``cone``).
    """
    names = [
        n for f in flag_text(rows["flag"]) for n in f.split(";") if n and n != "not_applicable"
    ]
    if cone is not None:
        wide = unflagged(rows) & (cone > MAX_CONE_DEG)
        names += [f"uncertainty above {MAX_CONE_DEG:g} deg"] * int(wide.sum())
    counts = pd.Series(names, dtype=object).value_counts()
    return "; ".join(f"{name} x{count}" for name, count in counts.items())


def _decide(imu: pd.DataFrame, evidence: pd.DataFrame, basis: str) -> dict:
    """The decision row of one IMU's calibrations from all repetitions (:func:`decision_table`)."""
    first = imu.iloc[0]
    row = {k: first[k] for k in [*IMU_KEY, "segment", "side"]}
    cone = imu[CONE] if CONE in imu else pd.Series(np.nan, index=imu.index)
    usable = imu[unflagged(imu) & ~(cone > MAX_CONE_DEG)]
    row |= {"n_unflagged": len(usable), "n_calibrations": len(imu), "basis": basis}
    if usable.empty:
        why = _flag_counts(imu, cone) or "no calibration was made"
        return row | {"flags_elsewhere": why, "verdict": f"no trustworthy calibration: {why}"}
    measured = usable[np.isfinite(usable.get(CONE, pd.Series(np.nan, index=usable.index)))]
    keys = ["segment", "test", "sensor_set", "method"]
    ranked = (
        (measured if len(measured) else usable)
        .merge(evidence, on=keys, how="left")
        .assign(rank=lambda t: t["method"].map(registry.rank), cone=lambda t: t.get(CONE, np.nan))
    )
    ranked = ranked.sort_values(["median", "cone", "rank"], na_position="last", kind="stable")
    chosen = ranked.iloc[0]
    spread = chosen.get("methods_spread_deg", np.nan)
    row |= {
        "method": chosen["method"],
        "test": chosen["test"],
        "repetitions": chosen["repetitions"],
        CONE: chosen.get(CONE, np.nan),
        "methods_spread_deg": spread,
        "flags_elsewhere": _flag_counts(imu, cone),
        "evidence_median_deg": chosen["median"],
        "evidence_n": chosen["n"],
        "note": _design_note(chosen["method"], chosen["segment"]),
    }
    if not np.isfinite(chosen["median"]):
        row["basis"] = f"{basis}: none for this method and test (chosen by its uncertainty)"
    same_test = imu[imu["test"] == chosen["test"]]
    disagree = same_test[flag_text(same_test["flag"]).str.contains("methods_disagree")]
    row["verdict"] = "use"
    if not len(measured):
        row["verdict"] = (
            "use with care: none of its unflagged calibrations has an uncertainty measured on "
            "the recording"
        )
    if len(disagree):
        names = ", ".join(registry.ordered(disagree["method"]))
        row["disagreeing"] = names
        row["verdict"] = (
            f"use with care: methods disagree by up to {spread:.1f} deg from this one on "
            f"{chosen['test']} ({names} beyond their uncertainties)"
        )
    return row


def _design_note(method: str, segment: str) -> str:
    """A peer chosen outside what its authors meant it for (the registry's design domain)."""
    peer = registry.method(method).peer if method in registry.names() else None
    if peer is None or not peer.design_note:
        return ""
    if peer.design_segments is not None and segment in peer.design_segments:
        return ""
    return peer.design_note.format(others=segment)
