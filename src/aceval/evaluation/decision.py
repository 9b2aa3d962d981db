"""For every sensor: which calibration to use, how far off it may be, and whether that is within
the lab's tolerance (beyond both papers).

* :func:`flag_disagreements`: the methods agree, or say so. Per calibration unit (one IMU in one
  test), every method's calibration from all its repetitions that the decision may choose (no
  flag but :data:`aceval.evaluation.decision_rules.ADVISORY_FLAGS`; the peers' too) against
  every other's: two calibrations further apart than their repeatability allows (their
  bootstrap spreads ``spread95_deg`` in quadrature: the two come from the same repetitions, so
  their sampling errors are not negatively correlated and their difference is at most as wide; a
  peer, which has none, is allowed the widest of aceval's on that unit), or further apart than the
  tolerance T, disagree; a calibration that disagrees with more than half of the others is flagged
  ``methods_disagree`` (two methods that disagree are both flagged; of many, the outliers). It is a
  comparison flag: it takes no calibration out of any analysis, and the decision reads it (its tie
  order and ``disagreeing``). Being a vote among the methods compared, it is the one thing of
  another method a new method of the registry can change: that method's calibrations, cones and
  errors stay as they were (docs/architecture.md, "Add a method"), but which calibration of an IMU
  to use is a comparison of the methods there are. ``methods_spread_deg``: its largest angle to
  another method's calibration.
* :func:`decision_table`: per IMU, the calibration to use, chosen among its calibrations from all
  repetitions (every method, every test that calibrates it) that no flag takes out
  (:func:`aceval.evaluation.decision_rules.removes`) with a finite uncertainty within
  :data:`MAX_CONE_DEG`, by the evidence of the other sensors of its segment
  (:mod:`aceval.evaluation.decision_evidence`: accuracy where there is a ground truth,
  repeatability where not; ties broken by a stated order), with its uncertainty, the methods'
  spread, the runner-up and the margin, how many calibrations it rests on and a verdict against
  the tolerance (:mod:`aceval.evaluation.decision_rules`). The chosen rotation (sensor -> body)
  is in the row, so that ``aceval apply --decision`` needs nothing else.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import (
    CALIBRATION_KEY,
    combine_flags,
    flag_sets,
    flag_text,
    full_set_rows,
    has_flag,
    matrices,
)
from aceval.data.contract import FINGERPRINT, R_COLUMNS
from aceval.data.rotations import error_angle_deg
from aceval.evaluation.decision_evidence import (
    EVIDENCE_COLUMNS,
    IMU_KEY,
    UNIT,
    cross_fitted,
    evidence_units,
    ranked,
)
from aceval.evaluation.decision_rules import (
    DEFAULT_TOLERANCE_DEG,
    Evidence,
    advisory,
    none_verdict,
    removes,
    sign_verified,
    verdict,
)
from aceval.methods import registry
from aceval.methods.uncertainty import UNDETERMINED_CONE_DEG

#: the uncertainty of a calibration (deg): the cone column of :mod:`aceval.methods.uncertainty`
CONE = "cone_deg"
#: beyond this uncertainty (deg) a calibration's heading is not determined: it is not chosen
MAX_CONE_DEG = UNDETERMINED_CONE_DEG
DECISION_COLUMNS = [
    *IMU_KEY,
    "segment",
    "side",
    "method",
    "test",
    "repetitions",
    "verdict_kind",
    "tolerance_deg",
    CONE,
    "methods_spread_deg",
    "methods_range_deg",
    "n_behind",
    "n_unflagged",
    "n_calibrations",
    "advisory_flags",
    "flags_elsewhere",
    "disagreeing",
    "basis",
    *EVIDENCE_COLUMNS,
    "runner_up",
    "margin_deg",
    "n_tied",
    "cone_fit",
    "note",
    "verdict",
    *R_COLUMNS,
    FINGERPRINT,
]


def _candidates(full: pd.DataFrame) -> pd.Series:
    """True for the calibrations from all repetitions the decision may choose: a rotation, no
    flag that takes it out, and an uncertainty that is a cone (or none: a peer's).
    """
    cone = full[CONE] if CONE in full else pd.Series(np.nan, index=full.index)
    finite = pd.Series(np.isfinite(matrices(full)).all(axis=(1, 2)), index=full.index)
    return finite & ~removes(full["flag"]) & ~(cone.astype(float) > MAX_CONE_DEG)


def flag_disagreements(
    calibrations: pd.DataFrame, tolerance_deg: float = DEFAULT_TOLERANCE_DEG
) -> pd.DataFrame:
    """The calibrations with ``methods_disagree`` on those from all repetitions that disagree
    with more than half of the other methods' on their unit, and ``methods_spread_deg`` on every
    compared one (module docstring; any earlier ``methods_disagree`` replaced).
    """
    if calibrations is None or calibrations.empty or "method" not in calibrations:
        return calibrations
    flags = flag_text(calibrations["flag"]).map(  # in their order: a set's order is the hash's
        lambda text: combine_flags(*(n for n in text.split(";") if n != "methods_disagree"))
    )
    calibrations = calibrations.reset_index(drop=True).assign(flag=flags.values)
    full = full_set_rows(calibrations)
    full = full[_candidates(full)]
    spread = np.full(len(calibrations), np.nan)
    disagree = np.zeros(len(calibrations), dtype=bool)
    repeat = full["spread95_deg"] if "spread95_deg" in full else pd.Series(np.nan, full.index)
    for _, unit in full.groupby(CALIBRATION_KEY, sort=False):
        if len(unit) < 2:
            continue
        R = matrices(unit)
        angles = error_angle_deg(R[:, None], R[None])
        own = repeat.loc[unit.index].to_numpy(float)
        peer = unit["method"].map(lambda m: m in registry.peers()).to_numpy()
        widest = np.nanmax(own[~peer]) if np.isfinite(own[~peer]).any() else np.nan
        own = np.where(peer & ~np.isfinite(own), widest, own)
        allowed = np.fmin(np.hypot(own[:, None], own[None, :]), tolerance_deg)
        apart = angles > allowed
        np.fill_diagonal(apart, False)
        np.fill_diagonal(angles, np.nan)
        spread[unit.index] = np.nanmax(angles, axis=1)
        disagree[unit.index] = apart.sum(axis=1) > (len(unit) - 1) / 2
    flags = [
        combine_flags(f, "methods_disagree" if d else "")
        for f, d in zip(calibrations["flag"], disagree)
    ]
    return calibrations.assign(methods_spread_deg=spread, flag=flags)


def decision_table(
    calibrations: pd.DataFrame,
    test_retest_k: int = 3,
    retest_units=None,
    tolerance_deg: float | None = None,
) -> pd.DataFrame:
    """One row per IMU (subject, set, IMU): the calibration to use and why (module docstring).

    ``method``, ``test``, ``repetitions``, its rotation (r11..r33, sensor -> body; NaN where
    none is chosen) and uncertainty (:data:`CONE`, deg; ``cone_fit``: the cone model's fit that
    made it); the largest angle between it and another method's calibration of its test
    (``methods_spread_deg``), between any two methods' there (``methods_range_deg``) and the
    methods flagged ``methods_disagree`` there (``disagreeing``); ``n_behind``: its calibrations
    within the tolerance of it (its own included); ``n_unflagged`` of ``n_calibrations`` (the IMU's
    calibrations from all repetitions it could choose among, of all it has; a peer that does not
    apply is not counted), its own advisory flags (``advisory_flags``) and the flags of the others
    (``flags_elsewhere``, with their counts); ``basis`` ('accuracy' or 'repeatability') and the
    evidence (:mod:`aceval.evaluation.decision_evidence`), the next in the order
    (``runner_up``) and the margin to it (deg), how many tied for the first place; ``note`` (a
    peer outside its authors' design); ``verdict_kind`` (one of
    :data:`aceval.evaluation.decision_rules.VERDICT_KINDS`) and ``verdict`` ('kind: reasons'),
    at ``tolerance_deg`` (default :data:`aceval.evaluation.decision_rules.DEFAULT_TOLERANCE_DEG`).
    """
    tolerance = DEFAULT_TOLERANCE_DEG if tolerance_deg is None else float(tolerance_deg)
    if calibrations is None or calibrations.empty:
        return pd.DataFrame(columns=DECISION_COLUMNS)
    full = full_set_rows(calibrations)
    full = full[~has_flag(full["flag"], "not_applicable")].reset_index(drop=True)
    if CONE not in full:  # Ricci's functional design: no cone
        full = full.assign(**{CONE: np.nan})
    candidate = _candidates(full)
    units, basis = evidence_units(full[candidate], calibrations, test_retest_k, retest_units)
    evidence = cross_fitted(units, full[candidate])
    rows = [
        _decide(imu, candidate.loc[imu.index], evidence, basis, tolerance)
        for _, imu in full.groupby(IMU_KEY, sort=True)
    ]
    return pd.DataFrame(rows, columns=DECISION_COLUMNS)


def _flag_counts(rows: pd.DataFrame) -> str:
    """'not_planar x3; backward x1': the flags of ``rows`` by how often they occur (then by
    name).
    """
    names = [name for found in flag_sets(rows["flag"]) for name in found]
    counts = pd.Series(names, dtype=object).value_counts()
    ordered = sorted(counts.items(), key=lambda item: (-item[1], item[0]))
    return "; ".join(f"{name} x{count}" for name, count in ordered)


def _decide(imu: pd.DataFrame, candidate, evidence, basis: str, tolerance: float) -> dict:
    """The decision row of one IMU's calibrations from all repetitions (:func:`decision_table`)."""
    first = imu.iloc[0]
    row = {k: first[k] for k in [*IMU_KEY, "segment", "side"]}
    chosen_from = imu[candidate]
    elsewhere = imu[~candidate]
    row |= {
        "n_unflagged": len(chosen_from),
        "n_calibrations": len(imu),
        "basis": basis,
        "tolerance_deg": tolerance,
        "flags_elsewhere": _flag_counts(elsewhere),
        "cone_fit": _cone_fit(imu),
        FINGERPRINT: _fingerprint(imu),
    }
    if chosen_from.empty:
        why = row["flags_elsewhere"] or "no calibration was made"
        if not row["flags_elsewhere"] and len(imu):
            why = f"no uncertainty within {MAX_CONE_DEG:g} deg"
        return row | _verdict_columns(none_verdict(why))
    order, n_tied = ranked(chosen_from.merge(evidence, on=UNIT, how="left"), tolerance)
    chosen = order.iloc[0]
    agreement = _agreement(chosen, chosen_from, tolerance)
    row |= {k: chosen[k] for k in ["method", "test", "repetitions", *R_COLUMNS]}
    row |= {k: chosen[k] for k in EVIDENCE_COLUMNS}
    row |= agreement | {
        CONE: chosen.get(CONE, np.nan),
        "methods_spread_deg": chosen.get("methods_spread_deg", np.nan),
        "advisory_flags": advisory(pd.Series([chosen["flag"]])).iloc[0],
        "n_tied": n_tied,
        "note": _design_note(chosen["method"], chosen["segment"]),
    }
    if len(order) > 1:
        runner = order.iloc[1]
        row["runner_up"] = f"{runner['method']} {runner['test']}"
        row["margin_deg"] = runner["evidence_median_deg"] - chosen["evidence_median_deg"]
    judged = Evidence(
        cone=float(row[CONE]),
        methods_range=agreement["methods_range_deg"],
        disagreeing=agreement.pop("_farthest"),
        n_behind=agreement["n_behind"],
        sign_verified=sign_verified(imu),
        measured=bool(np.isfinite(row[CONE])) and chosen["method"] not in registry.peers(),
    )
    return row | _verdict_columns(verdict(judged, tolerance))


def _fingerprint(imu: pd.DataFrame):
    """The IMU's subject's recordings' fingerprint (:data:`FINGERPRINT`, what apply checks a
    decision against), from its calibrations that carry one (a peer's do not); NaN if none does.
    """
    given = imu[FINGERPRINT].dropna() if FINGERPRINT in imu else ()
    return given.iloc[0] if len(given) else np.nan


def _agreement(chosen: pd.Series, chosen_from: pd.DataFrame, tolerance: float) -> dict:
    """How the chosen calibration stands among the IMU's others: ``n_behind`` (within the
    tolerance of it, its own included), ``methods_range_deg`` (the largest angle between two
    methods' calibrations of its test), ``disagreeing`` (the methods flagged
    ``methods_disagree`` there) and ``_farthest`` (the two methods that far apart).
    """
    R = matrices(chosen_from)
    to_chosen = error_angle_deg(R, matrices(chosen.to_frame().T)[0])
    same = chosen_from[chosen_from["test"] == chosen["test"]]
    methods_range, farthest = np.nan, ""
    if same["method"].nunique() > 1:
        R_same = matrices(same)
        angles = error_angle_deg(R_same[:, None], R_same[None])
        methods_range = float(np.max(angles))
        i, j = np.unravel_index(np.argmax(angles), angles.shape)
        farthest = " and ".join(registry.ordered(same["method"].iloc[[i, j]]))
    flagged = same[has_flag(same["flag"], "methods_disagree")]["method"]
    return {
        "n_behind": int((to_chosen <= tolerance).sum()),
        "methods_range_deg": methods_range,
        "disagreeing": ", ".join(registry.ordered(flagged)),
        "_farthest": farthest,
    }


def _cone_fit(imu: pd.DataFrame):
    """The fit of the cone model behind the IMU's cones (NaN without a cone)."""
    fits = imu["cone_fit"].dropna() if "cone_fit" in imu else pd.Series(dtype=object)
    return fits.iloc[0] if len(fits) else np.nan


def _verdict_columns(found) -> dict:
    """The table's columns of a :class:`aceval.evaluation.decision_rules.Verdict`."""
    return {"verdict_kind": found.kind, "verdict": found.text}


def _design_note(method: str, segment: str) -> str:
    """A peer chosen outside what its authors meant it for (the registry's design domain)."""
    peer = registry.method(method).peer if method in registry.names() else None
    if peer is None or not peer.design_note:
        return ""
    if peer.design_segments is not None and segment in peer.design_segments:
        return ""
    return peer.design_note.format(others=segment)
