"""The peers' calibrations through every gate aceval's own rows pass: a peer runs in its
own environment on aceval's own recordings, so what aceval measured about those recordings joins
its rows by key.

* its own axis (:func:`axis_gates`): the declared right axis against the calibration's body y
  (``right_axis_mismatch``), the peer's axis before its vertical part is removed against the
  vertical (``axis_near_vertical``), and how well the motion determines it (``axis_undetermined``:
  the peer's own eigenvalue ratio where it reports one, else the gyroscope axis's reliability rho
  of the same recordings, as the axis methods are judged);
* the sensor (:func:`sensor_gates`): the flags the checks put on the sensor itself in that test
  (aceval's rows' ``sensor_flag``: axes that do not follow the gyroscope, a static trial not
  standing, a sensor in another's place);
* the direction vote (:func:`direction_gates`): forward is forward, from the first phase of each
  repetition the calibration is made from (the recordings' summaries), as aceval's rows;
* ``unstable`` (:func:`unstable_gates`): a subset more than
  :data:`aceval.calibrate.pipeline.UNSTABLE_DEG` from the peer's own calibration from all
  repetitions, and that calibration when most test-retest subsets are.

Each flag joins the peer's own; flagged rows leave the medians and the test-retest, as aceval's do.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.pipeline import UNSTABLE_DEG, propagate_verified
from aceval.calibrate.table import (
    CALIBRATION_KEY,
    SIGN_VERIFIED,
    combine_flags,
    flag_text,
    matrices,
    parse_subset,
)
from aceval.data.rotations import axis_vector, error_angle_deg, vector_angle_deg
from aceval.methods.kong import KongLimits
from aceval.methods.moments import PHASE_COLUMNS
from aceval.methods.sagittal import AxisLimits
from aceval.signals.checks import (
    MAX_RIGHT_AXIS_ANGLE_DEG,
    THIRD_MOMENT_COLUMNS,
    direction_checks,
    right_axis_angle_deg,
)
from aceval.signals.gait_sign import FOOT_COLUMNS, STRENGTH_COLUMNS, TRUNK_COLUMNS, gait_right


def gate_peers(
    peers: pd.DataFrame,
    right_axis_of,
    own: pd.DataFrame | None = None,
    recordings: pd.DataFrame | None = None,
    first_phase_of=None,
    retest_k: int | None = 3,
) -> pd.DataFrame:
    """The peers' rows through every gate (module docstring). ``right_axis_of(sensor_set, imu)``
    -> '+y', ...; ``own``: aceval's calibrations (their ``sensor_flag`` and gyroscope rho, by
    unit); ``recordings``: the one pass's summaries (each repetition's first-phase axis and
    third moments); ``first_phase_of(test)``: the test's first phase ('-y', '+y', 'gait', '').
    Without ``own`` or ``recordings`` those gates are left out.
    """
    if peers.empty:
        return peers
    peers = axis_gates(peers.reset_index(drop=True), right_axis_of, own)
    if own is not None and "sensor_flag" in own:
        peers = sensor_gates(peers, own)
    if recordings is not None and first_phase_of is not None:
        peers = direction_gates(peers, recordings, right_axis_of, first_phase_of)
        if own is not None and SIGN_VERIFIED in own:  # a test it cannot judge, as aceval's rows
            both = propagate_verified(pd.concat([own, peers], ignore_index=True))
            peers[SIGN_VERIFIED] = both[SIGN_VERIFIED].to_numpy(bool)[len(own) :]
    return unstable_gates(peers, retest_k)


def _with_flags(rows: pd.DataFrame, hits: list[tuple[str, np.ndarray]]) -> list[str]:
    own = flag_text(rows["flag"])
    return [
        combine_flags(flag, *(name for name, hit in hits if hit[k])) for k, flag in enumerate(own)
    ]


def axis_gates(peers: pd.DataFrame, right_axis_of, own: pd.DataFrame | None = None) -> pd.DataFrame:
    """``right_axis_mismatch`` (the declared right axis more than
    :data:`aceval.signals.checks.MAX_RIGHT_AXIS_ANGLE_DEG` from the calibration's body y; column
    ``right_axis_angle_deg``), ``axis_near_vertical`` (the peer's axis ``axis_x..z`` closer to the
    vertical than :class:`aceval.methods.sagittal.AxisLimits` allows; ``axis_vertical_angle_deg``)
    and ``axis_undetermined`` (the peer's eigenvalue ratio ``axis_variance_ratio`` above Kong's
    :attr:`aceval.methods.kong.KongLimits.max_normal_ratio`, 0.5; where the peer reports none, the
    gyroscope axis's rho of the same recordings, from ``own``'s ``rho_motion``, below the axis
    methods' ``min_rho``; column ``axis_conditioning``).
    """
    R = matrices(peers)
    right = np.array(
        [axis_vector(right_axis_of(s, i)) for s, i in zip(peers["sensor_set"], peers["imu"])]
    ).reshape(-1, 3)
    angle = right_axis_angle_deg(R[:, 1, :], right)
    axis = peers.reindex(columns=["axis_x", "axis_y", "axis_z"]).to_numpy(float)
    with np.errstate(invalid="ignore"):
        axis = axis / np.linalg.norm(axis, axis=1)[:, None]
    vertical_angle = vector_angle_deg(axis, R[:, 2, :], sign_free=True)
    ratio = peers.reindex(columns=["axis_variance_ratio"]).to_numpy(float)[:, 0]
    rho = _own_rho(peers, own)
    undetermined = np.where(
        np.isfinite(ratio), ratio > KongLimits().max_normal_ratio, rho < AxisLimits().min_rho
    )
    hits = [
        ("right_axis_mismatch", angle > MAX_RIGHT_AXIS_ANGLE_DEG),
        ("axis_near_vertical", vertical_angle < AxisLimits().min_vertical_angle_deg),
        ("axis_undetermined", undetermined),
    ]
    return peers.assign(
        right_axis_angle_deg=angle,
        axis_vertical_angle_deg=vertical_angle,
        axis_conditioning=np.where(np.isfinite(ratio), "eigenvalue ratio", "gyroscope rho"),
        flag=_with_flags(peers, hits),
    )


def _own_rho(peers: pd.DataFrame, own: pd.DataFrame | None) -> np.ndarray:
    """The gyroscope axis's rho of each peer row's unit (aceval's calibration of the same IMU and
    test from all its repetitions: how well the test's rotation determines one axis), NaN where
    aceval has none.
    """
    if own is None or own.empty or "rho_motion" not in own:
        return np.full(len(peers), np.nan)
    full = own.dropna(subset=["rho_motion"]).sort_values("n_reps", ascending=False)
    rho = full.drop_duplicates(CALIBRATION_KEY)[[*CALIBRATION_KEY, "rho_motion"]]
    joined = (
        peers[CALIBRATION_KEY]
        .astype(str)
        .merge(rho.astype({k: str for k in CALIBRATION_KEY}), on=CALIBRATION_KEY, how="left")
    )
    return joined["rho_motion"].to_numpy(float)


def sensor_gates(peers: pd.DataFrame, own: pd.DataFrame) -> pd.DataFrame:
    """The checks' flags on the sensor itself in that test (aceval's rows' ``sensor_flag``, the
    same for every method and subset of a unit), added to the peer's rows of the unit.
    """
    found = own.dropna(subset=["sensor_flag"]).drop_duplicates(CALIBRATION_KEY)
    found = found[found["sensor_flag"].astype(str) != ""][[*CALIBRATION_KEY, "sensor_flag"]]
    if found.empty:
        return peers
    keys = peers[CALIBRATION_KEY].astype(str)
    joined = keys.merge(found.astype(str), on=CALIBRATION_KEY, how="left")["sensor_flag"]
    flags = [
        combine_flags(own_flag, sensor if isinstance(sensor, str) else "")
        for own_flag, sensor in zip(flag_text(peers["flag"]), joined)
    ]
    return peers.assign(flag=flags)


def direction_gates(
    peers: pd.DataFrame, recordings: pd.DataFrame, right_axis_of, first_phase_of
) -> pd.DataFrame:
    """``backward`` where the repetitions the peer's calibration is made from vote that its
    forward is backward (:func:`aceval.signals.checks.direction_checks`: each repetition's own
    first-phase axis within 45 deg of the calibration's body y votes; the shank in walking by its
    swing, the foot and the trunk by the physics of walking); columns ``first_phase_agreement``
    and ``right_axis_sign_verified``. Rows without a subset label ('R1+R3') or without the
    recordings' phases are left unchecked (NaN, False).
    """
    agreement = np.full(len(peers), np.nan)
    backward = np.zeros(len(peers), dtype=bool)
    verified = np.zeros(len(peers), dtype=bool)
    motion = recordings[(recordings["kind"] == "motion") & (recordings["flag"].fillna("") == "")]
    if motion.empty or PHASE_COLUMNS[0] not in motion:
        return peers.assign(first_phase_agreement=agreement, **{SIGN_VERIFIED: verified})
    has_third = THIRD_MOMENT_COLUMNS[0] in motion
    has_gait = FOOT_COLUMNS[0] in motion
    by_unit = {
        tuple(map(str, key)): group for key, group in motion.groupby(CALIBRATION_KEY, sort=False)
    }
    R = matrices(peers)
    labelled = peers["repetitions"].astype(str).str.fullmatch(r"R\d+(\+R\d+)*").to_numpy()
    checkable = labelled & np.isfinite(R).all(axis=(1, 2))
    keys = peers[CALIBRATION_KEY].astype(str)
    for key, rows in keys[checkable].groupby(CALIBRATION_KEY, sort=False).groups.items():
        group = by_unit.get(tuple(key))
        if group is None:
            continue
        at = peers.index.get_indexer(rows)
        reps = group["rep"].astype(int).to_numpy()
        membership = np.array(
            [np.isin(reps, parse_subset(label)) for label in peers["repetitions"].iloc[at]], float
        )
        n = len(at)
        found = direction_checks(
            np.full(n, first_phase_of(key[3]), dtype=object),
            peers["segment"].iloc[at].to_numpy(object),
            np.broadcast_to(group[PHASE_COLUMNS].to_numpy(float), (n, len(reps), 3)),
            np.broadcast_to(
                group[THIRD_MOMENT_COLUMNS].to_numpy(float),
                (n, len(reps), len(THIRD_MOMENT_COLUMNS)),
            )
            if has_third
            else None,
            membership,
            R[at],
            np.broadcast_to(axis_vector(right_axis_of(key[1], key[2])), (n, 3)),
            gait_axes=_gait_axes(group, peers["segment"].iloc[at].to_numpy(object))
            if has_gait
            else None,
        )
        agreement[at] = found["first_phase_agreement"]
        backward[at] = ["backward" in flag for flag in found["flag"]]
        verified[at] = found["sign_verified"]
    flags = _with_flags(peers, [("backward", backward)])
    return peers.assign(first_phase_agreement=agreement, flag=flags, **{SIGN_VERIFIED: verified})


def _gait_axes(group: pd.DataFrame, segment: np.ndarray) -> np.ndarray:
    """(n, n_rep, 3) the right direction each repetition of ``group`` (one unit's summaries) gives
    by the physics of walking, for each of ``n`` rows of that unit's ``segment``
    (:func:`aceval.signals.gait_sign.gait_right`).
    """
    n, reps = len(segment), len(group)
    foot, trunk, strength = (
        np.broadcast_to(group[columns].to_numpy(float), (n, reps, 3))
        for columns in (FOOT_COLUMNS, TRUNK_COLUMNS, STRENGTH_COLUMNS)
    )
    return gait_right(segment, foot, trunk, strength)


def unstable_gates(peers: pd.DataFrame, retest_k: int | None) -> pd.DataFrame:
    """``unstable`` as aceval's rows (:func:`aceval.calibrate.pipeline.flag_unstable`): a
    calibration from a subset of a unit's repetitions more than
    :data:`aceval.calibrate.pipeline.UNSTABLE_DEG` from the same peer's calibration from all of
    them (column ``full_set_angle_deg``), and that one when most of its subsets of ``retest_k``
    are.
    """
    angle = np.full(len(peers), np.nan)
    unstable = np.zeros(len(peers), dtype=bool)
    R = matrices(peers)
    finite = np.isfinite(R).all(axis=(1, 2))
    n_reps = peers["n_reps"].to_numpy(float)
    for _, group in peers.groupby([*CALIBRATION_KEY, "method"], sort=False):
        rows = group.index.to_numpy()
        positions = peers.index.get_indexer(rows)
        full = positions[np.argmax(n_reps[positions])]
        others = positions[(positions != full) & finite[positions]]
        if not finite[full] or not len(others):
            continue
        angle[others] = error_angle_deg(R[others], R[full])
        unstable[others] = angle[others] > UNSTABLE_DEG
        retest = others[n_reps[others] == (retest_k or 0)]
        if len(retest) and unstable[retest].mean() > 0.5:
            unstable[full] = True
    return peers.assign(full_set_angle_deg=angle, flag=_with_flags(peers, [("unstable", unstable)]))
