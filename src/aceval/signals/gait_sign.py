"""Which way is right, from the physics of walking, for the segments whose swing says nothing.

aceval's direction checks (:mod:`aceval.signals.checks`) read the right axis's sign from a
movement whose direction the protocol fixes (a first phase) or, in walking, from the shank's swing
(forward faster than back). Two more segments carry a sign in every step:

* **the foot** (:func:`foot_pitch_votes`): from foot flat (the foot at rest in mid-stance) the
  foot first pitches toe-down (heel rise and push-off: a rotation about body -y, to about 50-70 deg
  at toe-off), then toe-up through the swing (to about 15-25 deg at heel strike) and back to flat
  (Perry & Burnfield 2010, Ch. 4; the simulator's ankle curve, Winter 2009, gives -44 and +25 deg
  about its stance level). Integrated from one rest to the next (the angle about the foot's main
  rotation axis, drift removed linearly between the two rests), a stride votes for the sign that
  makes its larger excursion *and* its first one toe-down; a stride where the two disagree, or
  that turns less than :data:`MIN_STRIDE_DEG`, abstains. Walking backwards reverses the order but
  not the sizes: its strides abstain;
* **the trunk** (:func:`pendulum_right`; head, chest, waist, lower back): walking is an inverted
  pendulum, which trades forward speed for height once per step (Cavagna, Heglund & Taylor 1977):
  the trunk is fastest at its lowest point and slowest at its highest, so its forward acceleration
  is opposite to its upward velocity. The horizontal direction (the recording's mean specific force
  is up) whose band-passed acceleration best anti-correlates with the upward velocity (the
  band-passed vertical acceleration integrated) is forward; right = down x forward. Running, whose
  kinetic and potential energies rise and fall together, would reverse it: the cue is read in
  walking (``first_phase`` gait) only.

Both are per-recording statistics of the one pass (:data:`GAIT_SIGN`): a direction in the sensor
frame that points to the subject's right by the physics (NaN where the recording does not tell),
and how strongly it was told. The direction checks compare each calibration's body y with them, as
with a first phase; the rates measured on clean and sign-flipped data are in config/README.md's
table of checks.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_opening
from scipy.signal import butter, sosfiltfilt

from aceval.methods.sufficient import Part, Statistic

#: segments read as trunk (the pendulum cue); the foot is ``foot``
TRUNK_SEGMENTS = ("head", "chest", "waist", "lower_back")
#: a foot is at rest (foot flat) where its angular speed, less its offset, stays below this for at
#: least :data:`REST_S` (a walking foot's swing turns at 5-10 rad/s; mid-stance below 0.5)
REST_RAD_S = 0.7
REST_S = 0.08
#: a stride (rest to rest) whose foot turns less than this (deg, largest minus smallest angle) does
#: not vote (clean walking: 60-90 deg)
MIN_STRIDE_DEG = 20.0
#: a stride longer than this (s, between two rests) is not one stride
MAX_STRIDE_S = 2.5
#: the trunk's band (Hz) around the step frequency, and the high-pass of the integrated velocity
PENDULUM_BAND_HZ = (0.5, 4.0)
#: the pendulum cue tells the sign when the forward acceleration's correlation with the upward
#: velocity is at least this strong (clean walking, every trunk recording measured: 0.68-0.93)
MIN_PENDULUM_CORRELATION = 0.4
#: shortest recording the pendulum cue reads (s): two steps at a slow cadence
MIN_PENDULUM_S = 1.2
FOOT_COLUMNS = ["foot_right_x", "foot_right_y", "foot_right_z"]
TRUNK_COLUMNS = ["trunk_right_x", "trunk_right_y", "trunk_right_z"]
STRENGTH_COLUMNS = ["foot_strides_for", "foot_strides_against", "trunk_correlation"]


def _rest(gyr: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(rest mask, offset): the samples where the foot is at rest (:data:`REST_RAD_S` for at least
    :data:`REST_S`) once the gyroscope's offset (the median of its slowest quarter) is removed.
    """
    norm = np.linalg.norm(gyr, axis=1)
    offset = np.median(gyr[norm <= np.percentile(norm, 25)], axis=0)
    slow = np.linalg.norm(gyr - offset, axis=1) < REST_RAD_S
    width = max(2, int(round(REST_S * fs_hz)))
    return binary_opening(slow, np.ones(width, dtype=bool)), offset


def foot_pitch_votes(gyr: np.ndarray, fs_hz: float) -> tuple[np.ndarray, int, int]:
    """``(axis, n_for, n_against)`` of one walking recording of a foot (``gyr`` (N, 3) rad/s):
    its main rotation axis (the largest eigenvector of the moving samples' scatter, sign
    arbitrary) and how many strides vote that it points right (toe-down first and farther) or
    left; NaN axis when the foot is never at rest or never moves.
    """
    rest, offset = _rest(np.asarray(gyr, float), fs_hz)
    moving = ~rest
    if moving.sum() < 3 or not rest.any():
        return np.full(3, np.nan), 0, 0
    turning = gyr[moving] - offset
    axis = np.linalg.eigh(turning.T @ turning)[1][:, 2]
    pitch = (gyr - offset) @ axis
    change = np.flatnonzero(np.diff(rest.astype(int)))
    starts = [i + 1 for i in change if rest[i]]
    ends = [i for i in change if not rest[i]]
    votes = [0, 0]
    for start in starts:
        end = next((e for e in ends if e >= start), None)
        if end is None or (end - start) / fs_hz > MAX_STRIDE_S:
            continue
        angle = np.degrees(np.cumsum(pitch[start : end + 1]) / fs_hz)
        angle -= np.linspace(0.0, angle[-1], len(angle))  # flat at both rests
        low, high = angle.min(), angle.max()
        if high - low < MIN_STRIDE_DEG:
            continue
        down_first = np.argmin(angle) < np.argmax(angle)
        if down_first == (-low > high):
            votes[0 if down_first else 1] += 1
    return axis, votes[0], votes[1]


def pendulum_right(acc: np.ndarray, fs_hz: float) -> tuple[np.ndarray, float]:
    """``(right, correlation)`` of one walking recording of a trunk sensor (``acc`` (N, 3) m/s^2):
    down x forward, forward being the horizontal direction whose band-passed acceleration
    (:data:`PENDULUM_BAND_HZ`) anti-correlates best with the upward velocity, and that (positive)
    correlation; NaN and 0 for a recording too short to filter.
    """
    acc = np.asarray(acc, float)
    if len(acc) < MIN_PENDULUM_S * fs_hz:
        return np.full(3, np.nan), 0.0
    up = acc.mean(axis=0)
    up /= np.linalg.norm(up)
    band = sosfiltfilt(
        butter(2, PENDULUM_BAND_HZ, btype="band", fs=fs_hz, output="sos"), acc, axis=0
    )
    high = butter(2, PENDULUM_BAND_HZ[0], btype="high", fs=fs_hz, output="sos")
    rising = sosfiltfilt(high, np.cumsum(band, axis=0) / fs_hz, axis=0) @ up
    forward = -(band.T @ rising)
    forward -= (forward @ up) * up
    size = np.linalg.norm(forward)
    if not size > 0:
        return np.full(3, np.nan), 0.0
    forward /= size
    along = band @ forward
    correlation = -float(along @ rising / np.sqrt((along @ along) * (rising @ rising)))
    return np.cross(-up, forward), correlation


def walking_cues(acc: np.ndarray, gyr: np.ndarray, fs_hz: float) -> dict:
    """Both cues of one recording (SI, (N, 3)): :data:`FOOT_COLUMNS` (the foot's main rotation
    axis signed by its strides' majority; NaN on a tie), :data:`TRUNK_COLUMNS` and
    :data:`STRENGTH_COLUMNS` (the majority's and the minority's strides, the pendulum's
    correlation).
    """
    axis, n_for, n_against = foot_pitch_votes(gyr, fs_hz)
    right, correlation = pendulum_right(acc, fs_hz)
    foot = axis * np.sign(n_for - n_against) if n_for != n_against else np.full(3, np.nan)
    return {
        **dict(zip(FOOT_COLUMNS, foot)),
        **dict(zip(TRUNK_COLUMNS, right)),
        "foot_strides_for": max(n_for, n_against),
        "foot_strides_against": min(n_for, n_against),
        "trunk_correlation": correlation,
    }


def _reduce(acc: np.ndarray, gyr: np.ndarray, kept: np.ndarray, fs_hz: float) -> dict:
    """:data:`GAIT_SIGN`'s columns of one motion recording: :func:`walking_cues` of every sample
    (the cues need the rests and a continuous signal, not the trimmed movement).
    """
    return walking_cues(acc, gyr, fs_hz)


#: each walking recording's right direction by the foot's and the trunk's physics, per repetition
GAIT_SIGN = Statistic(
    "gait_sign",
    {
        "foot_right": Part(tuple(FOOT_COLUMNS), (3,), absent=np.nan, missing=None, summed=False),
        "trunk_right": Part(tuple(TRUNK_COLUMNS), (3,), absent=np.nan, missing=None, summed=False),
        "gait_strength": Part(
            tuple(STRENGTH_COLUMNS), (3,), absent=np.nan, missing=None, summed=False
        ),
    },
    reduce=_reduce,
)


#: a foot recording tells the sign when at least this share of its voting strides agree
MIN_STRIDE_AGREEMENT = 2 / 3


def gait_right(
    segment: np.ndarray, foot: np.ndarray, trunk: np.ndarray, strength: np.ndarray
) -> np.ndarray:
    """(B, n_rep, 3) each recording's right direction by the physics of walking, for the units'
    ``segment`` (B,): a foot's (``foot`` (B, n_rep, 3), where at least
    :data:`MIN_STRIDE_AGREEMENT` of its voting strides agree), a trunk sensor's (``trunk``, where
    the pendulum's correlation is at least :data:`MIN_PENDULUM_CORRELATION`); NaN elsewhere.
    ``strength`` (B, n_rep, 3): the :data:`STRENGTH_COLUMNS`.
    """
    segment = np.asarray(segment, dtype=object)[:, None, None]
    n_for, n_against, correlation = (strength[..., k : k + 1] for k in range(3))
    with np.errstate(invalid="ignore", divide="ignore"):
        told_foot = n_for / (n_for + n_against) >= MIN_STRIDE_AGREEMENT
    told_trunk = correlation >= MIN_PENDULUM_CORRELATION
    out = np.where((segment == "foot") & told_foot, foot, np.nan)
    return np.where(np.isin(segment, TRUNK_SEGMENTS) & told_trunk, trunk, out)
