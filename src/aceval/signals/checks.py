"""Plausibility checks of a calibration from the motion itself (beyond both papers).

Each check turns a silent wrong result into a visible flag. All of them work from small
per-recording statistics computed in the one pass over the samples (:func:`recording_checks`),
so that any subset of repetitions is checked without reading the samples again.

* **Gyroscope and accelerometer agree** (:func:`gyro_acc_agreement`): a rigid sensor's gyroscope
  must turn its gravity reading the way the accelerometer sees it turn. Over windows of slow motion
  (``WINDOW_S`` long, specific force within ``SLOW_MAX_DEV_G`` of 1 g, angular speed below
  ``SLOW_MAX_RATE_RAD_S``) the direction change of the specific force, ``Delta x a``, is compared
  with the gyroscope's rotation vector ``r`` over the window: for a consistent sensor
  ``Delta x a ~ r`` (its part perpendicular to a). Their agreement ``kappa = sum (Delta x a).r /
  sqrt(sum |Delta x a|^2 sum |r|^2)`` is near 1; swapped or mirrored accelerometer axes, another
  sensor's columns or a permuted gyroscope give values near or below 0. The sums are additive over
  windows and recordings; kappa is computed per test (its repetitions pooled) and the IMU is judged
  by its best test with enough evidence: a leg swing's linear accelerations pull a clean shank's or
  foot's kappa down to -0.63 (kong_sim), while a slow test of the same sensor gives 0.86 or more;
  a mirrored or permuted frame is wrong in every test. Windows whose turn is not about as large as
  the gyroscope's are left out (linear acceleration), and so is walking (``first_phase`` gait),
  where linear accelerations turn the specific force as much as the rotation does. A gyroscope
  read in the wrong units is caught by its range instead (the next check), or by Kong's no-movement rule.
* **Gyroscope range** (:data:`MAX_PLAUSIBLE_RATE_DEG_S`): the typical angular speed of a moving
  human segment (90th percentile of a motion recording) stays far below 1000 deg/s (walking:
  100-400); beyond it the units are wrong (deg/s read as rad/s: 57 times too fast). The 90th
  percentile is used so that brief spikes (a strap wobbling, as in the qmt example's thighs) do not
  trip it.
* **Forward is forward** (:func:`direction_checks`, :func:`swing_skew`): the protocol fixes
  the direction of the first movement phase (bowing and sit-to-stand flex forward: a rotation about
  body -y; the seated shank lift and the leg swing move forward: +y). A calibration whose y axis
  (and so its x axis) points the wrong way sees the opposite; e.g. a ``right_axis`` declared with
  the wrong sign. In walking the shank swings forward faster than it moves back: the third moment
  of its angular velocity about body y is positive; the foot's pitch and the trunk's inverted
  pendulum give each recording's right direction (:mod:`aceval.signals.gait_sign`), which votes
  as a first phase does. Where the votes judge a calibration, most agree and its y is the
  declared axis, the declared sign is verified by the data (``sign_verified``).
* **The declared right axis points roughly right** (:data:`MAX_RIGHT_AXIS_ANGLE_DEG`).
* **The static trial was taken standing** (:func:`static_posture`): the motion tests' own still
  portions (the samples Kong's trimmer leaves out, at least :data:`MIN_STILL_S`) give the sensor's
  vertical a second time; a static trial taken seated or leaning (a thigh 90 deg, a trunk 20-45
  deg off) disagrees with all of them. Judged only where at least two tests have still portions
  (a sit-to-stand test's still portions may be seated): the smallest angle over those tests above
  :data:`MAX_STATIC_ANGLE_DEG` flags every calibration of the IMU. The limit and the rates
  measured with it are in config/README.md's table of checks.
* **Kong's plane and the gyroscope's axis** (``normal_gyro_angle_deg`` of every Kong calibration, a
  diagnostic, not a flag): in a planar rotation the normal of the accelerations' plane and the
  gyroscope's principal axis agree. Random 3-D motion gives 70-88 deg; but so does a gyroscope
  whose principal axis is taken over by artefacts (the qmt example's thighs: strap wobble about the
  long axis, 80-89 deg while the accelerometer's plane is fine), so it does not decide alone.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
from scipy.ndimage import maximum_filter1d

from aceval.data.contract import GRAVITY, SignalFaults
from aceval.data.grouping import group_positions
from aceval.data.rotations import vector_angle_deg
from aceval.methods.sufficient import Part, Statistic

WINDOW_S = 0.25
SLOW_MAX_DEV_G = 0.1
SLOW_MAX_RATE_RAD_S = 2.0
MIN_TURN_DEG = 1.0
#: a window is used only when the specific force turns about as far as the gyroscope turns
#: (perpendicular to it): a window whose turn is mostly linear acceleration is left out, while a
#: mirrored or permuted frame, which turns as far but about another axis, stays in
SIZE_RATIO_BAND = (0.7, 1.4)
#: evidence (sum of the slow windows' direction changes, deg) below which a test's agreement is
#: not judged
MIN_EVIDENCE_DEG = 300.0
#: kappa below this: the accelerometer's turns do not follow the gyroscope's rotation (measured
#: values: config/README.md's table of checks)
MIN_AGREEMENT = 0.1
MAX_PLAUSIBLE_RATE_DEG_S = 1000.0
#: a recording votes on the first phase only when its own axis is within 45 deg of body y
MIN_AXIS_ALIGNMENT = np.cos(np.radians(45.0))
MAX_RIGHT_AXIS_ANGLE_DEG = 60.0
#: still samples (outside Kong's trimmed movement) a motion recording needs to give a vertical, s
MIN_STILL_S = 0.5
#: largest angle (deg) between z0 and the closest motion test's still-portion vertical (clean
#: simulated data: at most 4.0 deg, config/README.md; a seated or leaning static trial: 20-90)
MAX_STATIC_ANGLE_DEG = 10.0
#: tests with still portions needed to judge the static trial
MIN_STILL_TESTS = 2
STILL_COLUMNS = ["still_z0_x", "still_z0_y", "still_z0_z"]

AGREEMENT_COLUMNS = [f"ga_c{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)] + [
    "ga_ww",
    "ga_rr",
    "ga_turn_deg",
]
_TRIPLES = [(i, j, k) for i in range(3) for j in range(i, 3) for k in range(j, 3)]
THIRD_MOMENT_COLUMNS = ["w3_" + "".join("xyz"[a] for a in t) for t in _TRIPLES]
#: (value index, i, j, k) for every entry of the symmetric 3x3x3 tensor
_TENSOR_ENTRIES = [(v, *p) for v, t in enumerate(_TRIPLES) for p in set(itertools.permutations(t))]


#: samples per chunk of :func:`agreement_moments`: its windows are summed chunk by chunk, so its
#: memory is bounded by a chunk, whatever the recording's length (one chunk up to 33 min at 100 Hz)
CHUNK_SAMPLES = 200_000


def agreement_moments(acc: np.ndarray, gyr: np.ndarray, fs_hz: float) -> dict:
    """Sums over the slow-motion windows of one recording (columns ``AGREEMENT_COLUMNS``): the
    cross-moment C = sum (Delta x a) r^T (3x3), sum |Delta x a|^2, sum |r|^2 and the summed
    direction change (deg). ``acc`` m/s^2, ``gyr`` rad/s, both (N, 3). Long recordings are
    summed in chunks of :data:`CHUNK_SAMPLES` windows (each read with the samples around it
    that its windows and filters reach).
    """
    k = max(1, int(round(WINDOW_S * fs_hz)))
    total = np.zeros(len(AGREEMENT_COLUMNS))
    n_windows, halo = len(acc) - k, 2 * k + 2
    for first in range(0, max(n_windows, 0), CHUNK_SAMPLES):
        last = min(n_windows, first + CHUNK_SAMPLES)
        lo, hi = max(0, first - halo), min(len(acc), last + k + halo)
        total += _window_sums(acc[lo:hi], gyr[lo:hi], fs_hz, k, first - lo, last - lo)
    return dict(zip(AGREEMENT_COLUMNS, total.tolist()))


def _window_sums(acc, gyr, fs_hz: float, k: int, first: int, last: int) -> np.ndarray:
    """:func:`agreement_moments`' sums (in ``AGREEMENT_COLUMNS`` order) over the windows of
    ``k`` samples starting at ``first`` to ``last`` (exclusive) of the samples given.
    """
    norm = np.linalg.norm(acc, axis=1)
    direction = acc / np.where(norm > 0, norm, 1.0)[:, None]
    start = np.arange(first, last)
    cumulative = np.vstack([np.zeros(3), np.cumsum(gyr, axis=0) / fs_hz])
    rotation = (cumulative[k:] - cumulative[:-k])[start]  # rad, over [start, start + k)
    deviation = maximum_filter1d(np.abs(norm - GRAVITY), k + 1, origin=-(k // 2))[start]
    speed = maximum_filter1d(np.linalg.norm(gyr, axis=1), k + 1, origin=-(k // 2))[start]
    a, b = direction[start], direction[start + k]
    turn = vector_angle_deg(a, b)
    seen = np.cross(
        b - a, a
    )  # the direction change as a rotation vector (its part perpendicular to a)
    middle = a + b
    middle /= np.maximum(np.linalg.norm(middle, axis=1, keepdims=True), 1e-12)
    rotation_perpendicular = np.linalg.norm(
        rotation - middle * np.sum(rotation * middle, axis=1, keepdims=True), axis=1
    )
    size_ratio = np.linalg.norm(seen, axis=1) / np.maximum(rotation_perpendicular, 1e-12)
    slow = (
        (deviation < SLOW_MAX_DEV_G * GRAVITY)
        & (speed < SLOW_MAX_RATE_RAD_S)
        & (turn >= MIN_TURN_DEG)
        & (size_ratio > SIZE_RATIO_BAND[0])
        & (size_ratio < SIZE_RATIO_BAND[1])
    )
    seen, r = seen[slow], rotation[slow]
    return np.concatenate(
        [(seen.T @ r).ravel(), [np.sum(seen * seen), np.sum(r * r), turn[slow].sum()]]
    )


def gyro_acc_agreement(summed: np.ndarray) -> tuple[float, float]:
    """(kappa, evidence_deg) from summed ``AGREEMENT_COLUMNS`` (one row, in that order)."""
    C, ww, rr, evidence = summed[:9].reshape(3, 3), summed[9], summed[10], float(summed[11])
    if ww <= 0 or rr <= 0:
        return np.nan, evidence
    return float(np.trace(C) / np.sqrt(ww * rr)), evidence


def best_test_agreement(summed_per_test: np.ndarray) -> np.ndarray:
    """The summed ``AGREEMENT_COLUMNS`` row (n_tests, 12) of the test with the highest kappa among
    those with at least :data:`MIN_EVIDENCE_DEG` of evidence (else of the most evidence; zeros when
    there is no test).
    """
    if len(summed_per_test) == 0:
        return np.zeros(len(AGREEMENT_COLUMNS))
    found = [gyro_acc_agreement(row) for row in summed_per_test]
    judged = [k if e >= MIN_EVIDENCE_DEG and np.isfinite(k) else -np.inf for k, e in found]
    if np.isfinite(max(judged)):
        return summed_per_test[int(np.argmax(judged))]
    return summed_per_test[int(np.argmax([e for _, e in found]))]


def agreement_problem(kappa: float, evidence_deg: float) -> str:
    """'' when the gyroscope and accelerometer agree (or there is too little slow motion to tell),
    else the cause.
    """
    if not evidence_deg >= MIN_EVIDENCE_DEG or not np.isfinite(kappa) or kappa >= MIN_AGREEMENT:
        return ""
    return (
        f"the accelerometer's turns do not follow the gyroscope's rotation (agreement {kappa:.2f} < "
        f"{MIN_AGREEMENT} over {evidence_deg:.0f} deg of slow motion, in its best test): swapped or "
        f"mirrored axes, or "
        f"columns of two different sensors?"
    )


def third_moments(gyr: np.ndarray) -> dict:
    """The unique entries of the third-moment tensor sum w_i w_j w_k of angular velocities (rad/s)."""
    return {
        name: float(np.sum(gyr[:, i] * gyr[:, j] * gyr[:, k]))
        for name, (i, j, k) in zip(THIRD_MOMENT_COLUMNS, _TRIPLES)
    }


def _third_of_kept(acc: np.ndarray, gyr: np.ndarray, kept: np.ndarray, fs_hz: float) -> dict:
    """:func:`third_moments` of the kept angular velocities."""
    return third_moments(gyr[kept])


#: the third moments of the kept angular velocities, per repetition (not summed when pooled: the
#: direction checks weigh each repetition's, :func:`direction_checks`)
GYRO_THIRD = Statistic(
    "gyro_third",
    {
        "third": Part(
            tuple(THIRD_MOMENT_COLUMNS), (len(THIRD_MOMENT_COLUMNS),), missing=None, summed=False
        )
    },
    reduce=_third_of_kept,
)


def swing_skew(moments: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Sum (u . w)^3 for each unit vector u in ``axes`` (..., 3), from summed third moments
    (..., 10): positive when the fastest rotations about u are positive.
    """
    tensor = np.zeros(moments.shape[:-1] + (3, 3, 3))
    for value_index, i, j, k in _TENSOR_ENTRIES:
        tensor[..., i, j, k] = moments[..., value_index]
    return np.einsum("...ijk,...i,...j,...k->...", tensor, axes, axes, axes)


def right_axis_angle_deg(body_y: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The angle (deg) between each calibration's body y in the sensor frame (``R[:, 1]``, (n, 3))
    and the declared right axis ``right`` ((3,) or (n, 3)); NaN where R is undetermined.
    """
    return vector_angle_deg(body_y, right)


def _voting_axes(expected, segment, phase_axes, gait_axes) -> tuple[np.ndarray, np.ndarray]:
    """(B, n_rep, 3) each recording's axis that votes on the direction, and (B,) which
    calibrations vote: a first phase's, or in walking a foot's or trunk's right direction by the
    physics of walking (``gait_axes``, when given; the shank is judged by its swing instead).
    """
    phased = np.isin(expected, ["-y", "+y"])
    walking = (expected == "gait") & (np.asarray(segment, dtype=object) != "shank")
    axes = np.asarray(phase_axes, float)
    if gait_axes is not None and walking.any():
        axes = np.where(walking[:, None, None], np.asarray(gait_axes, float), axes)
        phased = phased | walking
    return axes, phased


def direction_checks(
    expected: np.ndarray,
    segment: np.ndarray,
    phase_axes: np.ndarray,
    third: np.ndarray | None,
    membership: np.ndarray,
    R: np.ndarray,
    right: np.ndarray,
    undetermined: np.ndarray | None = None,
    gait_axes: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Is forward forward? For each calibration ``R`` (B, 3, 3) of an IMU from the recordings
    ``membership`` (B, n_rep) weighs (0/1) among those of its test.

    ``expected`` (B,): the test's ``first_phase`` ('-y', '+y', 'gait' or ''); ``segment`` (B,).
    ``phase_axes`` (B, n_rep, 3): each recording's rotation axis signed so that its first phase is
    positive about it; a recording votes when that axis is within 45 deg of the calibration's body
    y (sensor frame: ``R[:, 1]``) and agrees when the sign is the protocol's. ``gait``: the shank
    from the summed third moments ``third`` (B, n_rep, 10) (:func:`swing_skew`); the foot and the
    trunk from ``gait_axes`` (B, n_rep, 3), optional: each recording's right direction by the
    physics of walking (:func:`aceval.signals.gait_sign.gait_right`; NaN where it does not tell),
    voting as a first phase of sign +y does. ``right`` (B, 3): the declared right axis.
    ``undetermined`` (B,), optional: True where the calibration's y axis is itself undetermined
    (Kong's plane normal: eigenvalue ratio above 0.5), so that its angle to the declared right
    axis says nothing about the declaration.

    Returns ``flag`` ('backward' when most votes disagree or the shank swings backward,
    'right_axis_mismatch' when the declared right axis is more than 60 deg from y0 (where y0 is
    undetermined: 'right_axis_unchecked', not a mislabel), joined by ';' when both hold, else ''),
    ``mismatch`` (that angle test alone, whatever the vote; False where undetermined),
    ``first_phase_agreement`` (share of agreeing votes; NaN without votes),
    ``right_axis_angle_deg`` and ``sign_verified`` (the recordings judged the direction, most of
    them agree, and y is within 60 deg of the declared right axis: the declared sign is the
    data's).
    """
    expected = np.asarray(expected, dtype=object)
    body_y = R[:, 1, :]
    axes, phased = _voting_axes(expected, segment, phase_axes, gait_axes)
    with np.errstate(invalid="ignore"):
        dots = np.einsum("bri,bi->br", axes, body_y)
    voting = (np.isfinite(dots) & (np.abs(dots) >= MIN_AXIS_ALIGNMENT)).astype(float)
    protocol_sign = np.where(expected == "-y", -1.0, 1.0)[:, None]
    agree = voting * (np.sign(dots) == protocol_sign)
    votes = np.einsum("br,br->b", membership, voting)
    with np.errstate(invalid="ignore", divide="ignore"):
        agreement = np.where(
            phased & (votes > 0), np.einsum("br,br->b", membership, agree) / votes, np.nan
        )
    backward = phased & (agreement < 0.5)
    swing = (expected == "gait") & (np.asarray(segment, dtype=object) == "shank")
    if third is not None and swing.any():
        skew = swing_skew(np.einsum("br,brk->bk", membership[swing], third[swing]), body_y[swing])
        agreement[swing] = (skew > 0).astype(float)
        backward[np.flatnonzero(swing)[skew < 0]] = True
    angle = right_axis_angle_deg(body_y, right)
    far = angle > MAX_RIGHT_AXIS_ANGLE_DEG
    unchecked = far & (False if undetermined is None else np.asarray(undetermined, dtype=bool))
    mismatch = far & ~unchecked
    flag = np.array(
        [
            ";".join(
                f
                for f, on in (
                    ("backward", b),
                    ("right_axis_mismatch", m),
                    ("right_axis_unchecked", u),
                )
                if on
            )
            for b, m, u in zip(backward, mismatch, unchecked)
        ],
        dtype=object,
    )
    return {
        "flag": flag,
        "mismatch": mismatch,
        "first_phase_agreement": agreement,
        "right_axis_angle_deg": angle,
        "sign_verified": (agreement > 0.5) & ~far,
    }


def static_posture(z0: np.ndarray, still: dict[str, np.ndarray]) -> dict:
    """Does the static trial's vertical ``z0`` (3,) agree with the motion tests' still portions?
    ``still``: test -> (n_rep, 3) the still-portion verticals of its repetitions (NaN rows: none).

    Returns ``static_vertical_angle_deg`` (the smallest, over the tests with still portions, of the
    median angle of their repetitions to z0; NaN when none), ``static_check_tests`` (how many
    tests have still portions) and ``flag`` ('static_not_standing' when at least
    :data:`MIN_STILL_TESTS` tests have them and the smallest angle exceeds
    :data:`MAX_STATIC_ANGLE_DEG`, else '').
    """
    angles = []
    for verticals in still.values():
        verticals = np.asarray(verticals, float)
        verticals = verticals[np.isfinite(verticals).all(axis=1)]
        if len(verticals):
            angles.append(float(np.median(vector_angle_deg(verticals, z0))))
    smallest = min(angles) if angles else np.nan
    judged = len(angles) >= MIN_STILL_TESTS
    return {
        "static_vertical_angle_deg": smallest,
        "static_check_tests": len(angles),
        "flag": "static_not_standing" if judged and smallest > MAX_STATIC_ANGLE_DEG else "",
    }


def sensor_problem(summed_agreement: np.ndarray, fastest_deg_s: float, gyr_units: str) -> dict:
    """The sensor-level verdict of one IMU from the summed ``AGREEMENT_COLUMNS`` of its best test
    (:func:`best_test_agreement`; walking left out) and the largest typical angular speed of its
    motion recordings (90th percentile, deg/s):
    ``flag`` ('gyro_implausible',
    'gyro_acc_inconsistent' or ''), ``message``, ``gyro_acc_agreement``, ``gyro_acc_evidence_deg``.
    """
    kappa, evidence = gyro_acc_agreement(summed_agreement)
    message = agreement_problem(kappa, evidence)
    flag = "gyro_acc_inconsistent" if message else ""
    if fastest_deg_s > MAX_PLAUSIBLE_RATE_DEG_S:
        flag, message = (
            "gyro_implausible",
            (
                f"typical angular speed {fastest_deg_s:.0f} deg/s (90th percentile) > "
                f"{MAX_PLAUSIBLE_RATE_DEG_S:.0f}: are units.gyr ({gyr_units}) right?"
            ),
        )
    return {
        "flag": flag,
        "message": message,
        "gyro_acc_agreement": kappa,
        "gyro_acc_evidence_deg": evidence,
    }


# --- a sensor's own signals: stuck channels, spikes, gyroscope offset, static trials, the
# accelerometer's sign (each statistic per recording in the one pass, judged per IMU)

#: a recording's still samples (a static trial, or a motion recording's still portions) give the
#: gyroscope's offset only when the sensor is at rest there: the SD of its angular velocity (norm
#: of the three axes' SDs) below :data:`REST_MAX_SD_DEG_S` and the median |specific force| within
#: :data:`REST_BAND_G`. Quiet standing: 0.1-1.7 deg/s (the committed datasets but one qmt static
#: trial at 18.8) and 0.95-1.04 g; HuGaDB's walking-based static fallback (T0w, walking low-passed
#: at 0.5 Hz) is none of its 215 recordings within both (2.1-53 deg/s, 1.02-1.38 g)
REST_MAX_SD_DEG_S = 3.0
REST_BAND_G = (0.95, 1.05)
REST_GYRO_COLUMNS = ["rest_gyro_x", "rest_gyro_y", "rest_gyro_z"]
#: the gyroscope's offset at rest (median over the IMU's still recordings of each axis's median,
#: deg/s) above which it is flagged ``gyro_bias``: the axis methods take it for rotation (a 5
#: deg/s offset on two axes moved TRIAD's leg-swing calibration of the thigh 4.6 -> 27.5 deg);
#: the rates measured with it are in config/README.md
GYRO_BIAS_LIMIT_DEG_S = 4.0
#: two static recordings of one IMU whose verticals are farther apart than this (deg) disagree:
#: z0 averages them (``static_disagree``; the limit of ``static_not_standing``; HuGaDB's
#: walking-based verticals of one subject are up to 5.7 deg apart; rates in config/README.md)
STATIC_DISAGREE_DEG = 10.0
#: the vendor's up (from ``quat_w..z``) and the accelerometer's at rest farther apart than this
#: (deg): one of them has the other sign convention (``acc_sign_mismatch``)
ACC_SIGN_LIMIT_DEG = 90.0
_SIGNAL_NAMES = ["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]


def recording_signals(
    acc: np.ndarray, gyr: np.ndarray, rest: np.ndarray | None, faults: SignalFaults | None = None
) -> tuple:
    """The signal checks of one recording (SI, (N, 3) each): ``(statistics, spikes)``, the
    summary columns ``n_spikes`` and :data:`REST_GYRO_COLUMNS` (each axis's median angular
    velocity over the ``rest`` samples, rad/s; NaN when there are none or the sensor is not at
    rest there, :data:`REST_MAX_SD_DEG_S`), and the (N,) spike mask
    (:func:`aceval.data.recording_checks.acc_spikes`). StuckChannelError when a channel is stuck
    (:func:`aceval.data.recording_checks.stuck_channel`; ``rest`` None: a static recording,
    whose accelerometer only is judged: a still gyroscope may hold its value). ``faults``: what
    the checks found when the file was read (:class:`aceval.data.contract.SignalFaults`), used
    as it is; without it they run here.
    """
    from aceval.data.errors import StuckChannelError
    from aceval.data.recording_checks import NOISY_SHARE, acc_spikes, stuck_channel

    static = rest is None
    if faults is None:
        found = stuck_channel(acc, _SIGNAL_NAMES[:3])
        if not static and not found:
            found = stuck_channel(gyr, _SIGNAL_NAMES[3:])
        faults = SignalFaults(found, None if found else acc_spikes(acc, gyr))
    if faults.stuck:
        raise StuckChannelError(
            f"{faults.stuck[0]} holds one value for {faults.stuck[1]:.0%} of the recording while "
            f"the sensor's other two channels are noisy (new values at {NOISY_SHARE:.0%} of the "
            "samples): a dead or frozen axis"
        )
    spikes = faults.spikes
    still, still_acc = (gyr, acc) if static else (gyr[rest], acc[rest])
    at_rest = (
        len(still) >= 10
        and np.degrees(np.linalg.norm(still.std(axis=0))) < REST_MAX_SD_DEG_S
        and REST_BAND_G[0] * GRAVITY
        < np.median(np.linalg.norm(still_acc, axis=1))
        < REST_BAND_G[1] * GRAVITY
    )
    offset = np.median(still, axis=0) if at_rest else np.full(3, np.nan)
    return {"n_spikes": int(spikes.sum()), **dict(zip(REST_GYRO_COLUMNS, offset))}, spikes


def signal_verdict(offsets: np.ndarray, z0: np.ndarray, vendor: np.ndarray) -> dict:
    """What one IMU's per-recording statistics say about its signals, from its rest offsets
    ``offsets`` ((m, 3), :data:`REST_GYRO_COLUMNS` of its static, then its motion recordings;
    NaN rows: none), and its usable static recordings' verticals ``z0`` ((k, 3)) and vendor's up
    angles ``vendor`` ((k,), NaN: none): ``flag`` ('gyro_bias', 'static_disagree',
    'acc_sign_mismatch', ';'-joined, or ''), ``messages`` and the evidence ``gyro_bias_deg_s``
    (the offset at rest, median over its still recordings), ``static_spread_deg`` (the largest
    angle between its static recordings' verticals) and ``vendor_up_angle_deg`` (the vendor's up
    from the accelerometer's at rest).
    """
    offsets = offsets[np.isfinite(offsets).all(axis=1)]
    bias = float(np.degrees(np.linalg.norm(np.median(offsets, axis=0)))) if len(offsets) else np.nan
    z0 = z0[np.isfinite(z0).all(axis=1)]
    spread = float(np.nanmax(vector_angle_deg(z0[:, None], z0[None]))) if len(z0) > 1 else np.nan
    vendor = vendor[~np.isnan(vendor)]
    vendor = float(vendor.max()) if len(vendor) else np.nan
    found = []
    if bias > GYRO_BIAS_LIMIT_DEG_S:
        cause = (
            f"its gyroscope reads {bias:.1f} deg/s at rest (median over {len(offsets)} still "
            f"recording(s); more than {GYRO_BIAS_LIMIT_DEG_S:g}): an offset that the axis methods "
            "take for rotation"
        )
        found.append(("gyro_bias", cause))
    if spread > STATIC_DISAGREE_DEG:
        cause = (
            f"its {len(z0)} static recordings give verticals {spread:.0f} deg apart (more than "
            f"{STATIC_DISAGREE_DEG:g}): z0 blends them; was one taken leaning or seated?"
        )
        found.append(("static_disagree", cause))
    if vendor > ACC_SIGN_LIMIT_DEG:
        cause = (
            f"its accelerometer points {vendor:.0f} deg from the vendor's up (quat_w..z) at "
            "rest: it reads down where the vendor's orientation says up; is dataset.yaml "
            "acc_at_rest right, or this sensor's accelerometer reversed?"
        )
        found.append(("acc_sign_mismatch", cause))
    return {
        "flag": ";".join(f for f, _ in found),
        "messages": [m for _, m in found],
        "gyro_bias_deg_s": bias,
        "static_spread_deg": spread,
        "vendor_up_angle_deg": vendor,
    }


#: the pair moments' columns (:data:`aceval.signals.reduction.PAIR_COLUMNS`): both means and the
#: centred scatters and cross-moment of the overlap
MEAN_A, MEAN_B = ["ma_x", "ma_y", "ma_z"], ["mb_x", "mb_y", "mb_z"]
C_AA, C_BB, C_AB = (
    [f"{m}{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)] for m in ("caa", "cbb", "cab")
)


def _kabsch_best(M: np.ndarray) -> float:
    """Max over rotations R of trace(R^T M) (the sum of M's singular values, the last signed)."""
    U, S, Vt = np.linalg.svd(M)
    return float(S[0] + S[1] + np.sign(np.linalg.det(U @ Vt)) * S[2])


def acc_sign_agreement(pairs: pd.DataFrame) -> dict[tuple[str, str, str], float]:
    """Two sensors on one segment (Kong's Obj 1 pairs: the same IMU in the two sensor sets) see
    one motion: a rotation R maps one's angular velocities and specific forces onto the other's.
    Fitted to both signals (each normalised) once as read and once with one accelerometer
    negated: ``agreement`` = how much better the first fits (Kabsch's maximum of trace(R^T M) of
    the pooled uncentred cross-moments M, from the pair moments of every test and repetition of
    the subject: nothing reads the samples again). About +1 for a consistent pair, about -1 when
    one accelerometer reads with the other sign. Returns ``{(subject, set, imu): agreement}`` for
    both sensors of each pair.
    """
    if pairs is None or pairs.empty:
        return {}
    rows = pairs[
        (pairs["objective"] == "frontal_lateral")
        & (pairs["window"] == "all")
        & (pairs["flag"].fillna("") == "")
        & (pairs["n"] > 0)
    ]
    n = rows["n"].to_numpy(float)[:, None, None]
    ma, mb = rows[MEAN_A].to_numpy(float), rows[MEAN_B].to_numpy(float)
    centred = {c[0]: rows[c].to_numpy(float) for c in (C_AA, C_BB, C_AB)}
    signals = rows["signal"].to_numpy(object)
    out = {}
    for (subject, sets, imu), at in group_positions(rows, ["subject", "sensor_set", "imu"]):
        moments = {}
        for signal in sorted(set(signals[at])):
            part = at[signals[at] == signal]
            aa, bb, ab = (
                (
                    centred[c[0]][part].reshape(-1, 3, 3)
                    + n[part] * x[part][:, :, None] * y[part][:, None, :]
                ).sum(axis=0)
                for c, x, y in ((C_AA, ma, ma), (C_BB, mb, mb), (C_AB, ma, mb))
            )  # uncentred: the centred moments plus n times the product of the means
            moments[signal] = ab / np.sqrt(np.trace(aa) * np.trace(bb))
        if set(moments) != {"acc", "gyr"}:
            continue
        agreement = _kabsch_best(moments["gyr"] + moments["acc"]) - _kabsch_best(
            moments["gyr"] - moments["acc"]
        )
        for sensor_set in str(sets).split("|"):
            out[(subject, sensor_set, imu)] = agreement
    return out


#: the accelerometer-sign agreement of two sensors of a segment is judged when it is at least
#: this far from 0 (:func:`acc_sign_agreement`): it rests on the motion out of the sagittal plane,
#: which the head of Kong's protocol barely has (-0.0004 to 0.022 on the six 1-subject
#: simulations of benchmarks/check_rates.py, the other IMUs 0.05 or more)
ACC_SIGN_MIN_AGREEMENT = 0.03


def acc_sign_problem(agreement: float) -> str:
    """'' when the two sensors of a segment agree on the accelerometer's sign, when there is no
    pair, or too little motion out of the plane to tell (:data:`ACC_SIGN_MIN_AGREEMENT`); else
    the cause.
    """
    if not agreement < -ACC_SIGN_MIN_AGREEMENT:
        return ""
    return (
        "its accelerometer and that of the other sensor on the segment (the other sensor set) "
        f"disagree on the sign of gravity (agreement {agreement:.2f} < "
        f"-{ACC_SIGN_MIN_AGREEMENT:g}): one of them reads it reversed (dataset.yaml "
        "acc_at_rest, or that sensor's export), or has a gyroscope axis negated (left-handed)"
    )
