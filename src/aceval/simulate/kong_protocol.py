"""Kong et al. 2016 Section 2.2: the seven tests as segment kinematics, one repetition at a time.

Each builder draws its repetition's own parameters (per-repetition variability) from ``rng`` and
returns the :class:`Posture` on the fine time grid plus the fixed ankle (if any). ``offplane``
scales every out-of-sagittal-plane component (1 = physiological values, 0 = pure sagittal motion).
Parameter values and their sources are tabled in docs/simulation.md.
"""

from __future__ import annotations

import numpy as np

from aceval.simulate.engine import band_noise, fine_time
from aceval.simulate.motion import Posture, bell, sitting_hip, standing_hip, step

D2R = np.pi / 180.0
TRUNK = ("waist", "chest", "head")


def _vary(rng, value, cv=0.1):
    """A repetition's value: nominal times a normal factor with coefficient of variation ``cv``."""
    return value * max(0.3, rng.normal(1.0, cv))


def _sway(rng, posture, t, offplane):
    """Quiet-stance sway as an inverted pendulum about the ankles: AP pitch RMS 0.3 deg, ML roll RMS
    0.2 deg, 0.1-0.7 Hz (Winter 1995, Gait Posture 3:193; Prieto et al. 1996).
    """
    pitch = 0.3 * D2R * band_noise(rng, t, 0.1, 0.7)
    roll = 0.2 * D2R * offplane * band_noise(rng, t, 0.1, 0.7)
    for seg in ("waist", "chest", "head", "thigh_r", "shank_r", "thigh_l", "shank_l"):
        posture.add(seg, pitch=pitch, roll=roll)


def _sitting(posture):
    for s in ("r", "l"):
        posture.add(f"thigh_{s}", pitch=90 * D2R)


def t0_quiet_standing(rng, body, fs, offplane):
    """T0: 20 s of quiet standing with postural sway."""
    t = fine_time(20.0, fs)
    posture = Posture(t, envelope=np.zeros_like(t))
    _sway(rng, posture, t, offplane)
    return posture, "r"


def _bow(rng, body, fs, offplane, amplitude_deg, seated):
    rest, duration = _vary(rng, 1.5), _vary(rng, 3.5)
    t = fine_time(2 * rest + duration, fs)
    profile = bell(t, rest, duration)
    amplitude = _vary(rng, amplitude_deg) * D2R
    # lumbo-pelvic rhythm: pelvis ~2/3, lumbar spine ~1/3 of trunk flexion (Esola et al. 1996,
    # Spine 21:71); the head follows the chest with a little extra neck flexion
    posture = Posture(t, envelope=profile)
    posture.add("waist", pitch=-amplitude * 0.67 * profile)
    posture.add("chest", pitch=-amplitude * profile)
    posture.add("head", pitch=-amplitude * 1.1 * profile)
    roll, yaw = offplane * rng.normal(0, 3 * D2R, 2)  # asymmetric bending, a few degrees
    for seg in TRUNK:
        posture.add(seg, roll=roll * profile, yaw=yaw * profile)
    if seated:
        _sitting(posture)
        posture.hip = sitting_hip(body)
        return posture, None
    return posture, "r"


def t1_bow_standing(rng, body, fs, offplane):
    """T1: bowing while standing, trunk flexion 60 deg."""
    return _bow(rng, body, fs, offplane, 60.0, seated=False)


def t2_bow_sitting(rng, body, fs, offplane):
    """T2: bowing while sitting, trunk flexion 40 deg."""
    return _bow(rng, body, fs, offplane, 40.0, seated=True)


def t3_sit_to_stand(rng, body, fs, offplane):
    """Sit, lean forward, rise, stand, sit down (Schenkman et al. 1990, Phys Ther 70:638: trunk
    flexion ~40 deg, rise ~1.5 s, knees moving forward ~15 deg over the feet).
    """
    sit, rise, stand, descend = _vary(rng, 1.0), _vary(rng, 1.6), _vary(rng, 1.5), _vary(rng, 1.9)
    t = fine_time(2 * sit + rise + stand + descend, fs)
    up = step(t, sit, rise) - step(t, sit + rise + stand, descend)
    lean = bell(t, sit, rise) + bell(t, sit + rise + stand, descend)  # trunk lean and knees forward
    trunk_lean = _vary(rng, 40.0) * D2R
    posture = Posture(t, envelope=np.clip(up + lean, 0, 1))
    for s in ("r", "l"):
        posture.add(f"thigh_{s}", pitch=90 * D2R * (1 - up))
        posture.add(f"shank_{s}", pitch=-_vary(rng, 15.0) * D2R * lean)
        posture.add(f"foot_{s}")
    # the trunk leans forward to move the centre of mass over the feet; pelvis tilts with the
    # thighs while seated (posterior tilt ~0) and the trunk stays upright when standing
    posture.add("waist", pitch=-trunk_lean * 0.6 * lean)
    posture.add("chest", pitch=-trunk_lean * lean)
    posture.add("head", pitch=-trunk_lean * 0.8 * lean)
    roll = offplane * rng.normal(0, 2 * D2R)
    for seg in TRUNK:
        posture.add(seg, roll=roll * lean)
    return posture, "r"


def t4_shank_lift(rng, body, fs, offplane):
    """Seated knee extension, left then right, shank and foot as one rigid body (Kong Sec. 2.2)."""
    rest, lift = _vary(rng, 1.0), _vary(rng, 2.5)
    t = fine_time(3 * rest + 2 * lift, fs)
    posture = Posture(t, hip=sitting_hip(body), envelope=np.zeros_like(t))
    _sitting(posture)
    for k, s in enumerate(("l", "r")):
        profile = bell(t, rest + k * (rest + lift), lift)
        amplitude = _vary(rng, 70.0) * D2R
        sign = 1.0 if s == "r" else -1.0
        rot = offplane * rng.normal(0, 4 * D2R)  # hip rotation during the lift
        for seg in (f"shank_{s}", f"foot_{s}"):
            posture.add(seg, pitch=amplitude * profile, yaw=sign * rot * profile)
        posture.add(f"foot_{s}", pitch=0.05 * amplitude * profile)  # imperfect rigidity
        posture.envelope = posture.envelope + profile
    return posture, None


def t5_leg_swing(rng, body, fs, offplane):
    """Standing leg swing, left then right: the leg (thigh, shank, foot rigid) swings ~35 deg
    forward and ~15 deg back about the hip; pelvis tilts and shifts weight a few degrees.
    """
    rest, swing = _vary(rng, 1.0), _vary(rng, 2.0)
    t = fine_time(3 * rest + 2 * swing, fs)
    # the hip centre stays put: each stance leg is still while the other swings
    posture = Posture(t, hip=standing_hip(body), envelope=np.zeros_like(t))
    for k, s in enumerate(("l", "r")):
        start = rest + k * (rest + swing)
        forward = bell(t, start, swing / 2)
        backward = bell(t, start + swing / 2, swing / 2)
        pitch = _vary(rng, 35.0) * D2R * forward - _vary(rng, 15.0) * D2R * backward
        abduction = offplane * rng.normal(0, 5 * D2R) * (forward + backward)
        sign = 1.0 if s == "r" else -1.0
        for seg in (f"thigh_{s}", f"shank_{s}", f"foot_{s}"):
            posture.add(seg, pitch=pitch, roll=-sign * abduction)
        posture.add(f"shank_{s}", pitch=-0.1 * np.abs(pitch))  # knee not perfectly straight
        posture.add(
            "waist", pitch=-0.1 * pitch, roll=offplane * sign * 3 * D2R * (forward + backward)
        )
        posture.envelope = posture.envelope + forward + backward
    return posture, None


def _lower_leg(rng, posture, s: str, sign: float, gait, angle, hip_roll, offplane) -> None:
    """The shank's and foot's out-of-sagittal motion in walking (``angle``: the stride's phase,
    rad) and this repetition's heading (:data:`KNEE_ADDUCTION_DEG` ...
    :data:`LOWER_LEG_HEADING_SD_DEG`), scaled by ``offplane``.
    """
    heading = rng.normal(0.0, LOWER_LEG_HEADING_SD_DEG * D2R)
    knee = offplane * sign * KNEE_ADDUCTION_DEG * D2R * gait * np.sin(angle)
    tibia = offplane * sign * (TIBIAL_ROTATION_DEG * D2R * gait * np.cos(angle) + heading * gait)
    subtalar = offplane * sign * SUBTALAR_DEG * D2R * gait * np.sin(angle)
    posture.add(f"shank_{s}", roll=hip_roll + knee, yaw=tibia)
    posture.add(f"foot_{s}", roll=hip_roll + knee + subtalar, yaw=tibia)


def _gait_angles(phase):
    """Sagittal joint angles (rad) over a stride (phase 0-1, heel strike at 0), shaped after the
    normative curves of Winter (2009, Ch. 1; Perry & Burnfield 2010): hip +30 -> -10 deg, knee
    5-15 deg in stance and 60 deg in swing, ankle -5 / +10 / -15 deg.
    """

    def bump(center, width):
        # periodic (von Mises) bump, ~Gaussian of SD ``width`` near its centre and smooth where the
        # stride wraps (a wrapped Gaussian steps there, which shows as an acceleration spike)
        return np.exp((np.cos(2 * np.pi * (phase - center)) - 1) / (2 * np.pi * width) ** 2)

    hip = (10 + 20 * np.cos(2 * np.pi * (phase - 0.9))) * D2R
    knee = (5 + 12 * bump(0.15, 0.07) + 55 * bump(0.72, 0.11)) * D2R
    ankle = (-5 * bump(0.06, 0.04) + 10 * bump(0.45, 0.10) - 17 * bump(0.63, 0.05)) * D2R
    return hip, knee, ankle


#: the lower leg's out-of-sagittal motion over the stride (deg, amplitudes of sinusoids at the
#: stride frequency): knee ab/adduction 3 and tibial rotation 4 (the
#: tibiofemoral arcs of about 6 and 8-10 deg in walking, Lafortune et al. 1992, J Biomech
#: 25:347), subtalar eversion/inversion 5 (about 10 deg in all, Perry & Burnfield 2010, Ch. 4).
#: The shank and foot also inherit the thigh's frontal tilt (hip ab/adduction), as the chain does
KNEE_ADDUCTION_DEG, TIBIAL_ROTATION_DEG, SUBTALAR_DEG = 3.0, 4.0, 5.0
#: the lower leg's heading from one walking repetition to the next (deg, SD of a per-repetition
#: turn of shank and foot about the vertical): set from real walking, where one repetition's Kong
#: calibration of the shank turns 1.82 deg from all of them (median over HuGaDB's 9 sessions,
#: range 0.55-3.61; table variability, repetition_heading_deg). The shank's plane turns by less
#: than its heading, since its acceleration also follows the knee's path: 4.2 deg gives 1.5-1.7
#: on seeds 0-1 (measured with aceval.evaluation.variability's tools)
LOWER_LEG_HEADING_SD_DEG = 4.2


def t6_walk(rng, body, fs, offplane, measured: bool = True):
    """7 m straight walk at preferred speed (1.3 m/s, cadence 110 steps/min; Perry & Burnfield
    2010), standing 1 s before and after, 0.8 s ramps at start and end. ``measured``: the lower
    leg's out-of-sagittal motion and its repetition-to-repetition heading (:data:`KNEE_ADDUCTION_DEG`
    ... :data:`LOWER_LEG_HEADING_SD_DEG`); False: the assumed walk of earlier versions (a
    sagittal lower leg), which ``aceval simulate --assumed-variability`` keeps for comparison.
    """
    speed, cadence = _vary(rng, 1.3, 0.08), _vary(rng, 110.0, 0.05)
    stride = 120.0 / cadence
    ramp, pause = 0.8, 1.0
    walking = 7.0 / speed + ramp
    t = fine_time(2 * pause + walking, fs)
    gait = step(t, pause, ramp) - step(t, pause + walking - ramp, ramp)
    progress = np.cumsum(gait) * (t[1] - t[0]) * speed
    phase_r = (t - pause) / stride
    posture = Posture(t, envelope=gait)
    amplitude = _vary(rng, 1.0, 0.05)
    for s, shift in (("r", 0.0), ("l", 0.5)):
        hip, knee, ankle = _gait_angles((phase_r + shift) % 1.0)
        thigh = amplitude * gait * hip
        shank = thigh - amplitude * gait * knee
        foot = shank + amplitude * gait * ankle
        posture.add(f"thigh_{s}", pitch=thigh)
        posture.add(f"shank_{s}", pitch=shank)
        posture.add(f"foot_{s}", pitch=foot)
        sign = 1.0 if s == "r" else -1.0
        # hip ab/adduction ~ +-5 deg over the stride (Perry & Burnfield 2010)
        angle = 2 * np.pi * (phase_r + shift)
        hip_roll = offplane * sign * 5 * D2R * gait * np.sin(angle)
        posture.add(f"thigh_{s}", roll=hip_roll)
        if measured:
            _lower_leg(rng, posture, s, sign, gait, angle, hip_roll, offplane)
    for s, shift in (("r", 0.0), ("l", 0.5)):  # heel strike where the side's phase is whole
        strikes = pause + (np.arange(np.floor(t[-1] / stride) + 2) - shift) * stride
        posture.strikes[s] = strikes[np.interp(strikes, t, gait, left=0.0, right=0.0) > 0.5]
    stride_wave = 2 * np.pi * phase_r
    # pelvis: rotation +-4 deg, obliquity +-3 deg, tilt +-1.5 deg at step frequency (Perry &
    # Burnfield 2010); trunk counter-rotates; COM moves +-2.5 cm vertically and +-2 cm sideways
    posture.add(
        "waist",
        pitch=1.5 * D2R * gait * np.sin(2 * stride_wave),
        roll=offplane * 3 * D2R * gait * np.sin(stride_wave),
        yaw=offplane * 4 * D2R * gait * np.cos(stride_wave),
    )
    posture.add(
        "chest", pitch=-3 * D2R * gait, yaw=-offplane * 3 * D2R * gait * np.cos(stride_wave)
    )
    posture.add("head", pitch=-3 * D2R * gait)
    # fore-aft: the inverted pendulum trades forward kinetic for potential energy once per step,
    # fastest at the lowest point (double support). With the two fluctuations of equal size, as
    # Cavagna, Heglund & Taylor (1977, Am J Physiol 233:R243) measured them near 4.5 km/h,
    # 2 v A = g dh for the 5 cm peak-to-peak bob above: A = 0.19 m/s at 1.3 m/s, the hip 1.6 cm
    # ahead of and behind its steady progress (integral of A cos(2 w t); z points down)
    surge = 9.81 * 0.05 / (2.0 * speed)
    progress = progress + gait * surge * stride / (4 * np.pi) * np.sin(2 * stride_wave)
    base = standing_hip(body)
    posture.hip = np.column_stack(
        [
            base[0] + progress,
            base[1] + offplane * 0.02 * gait * np.sin(stride_wave),
            base[2] + 0.025 * gait * np.cos(2 * stride_wave),
        ]
    )
    return posture, None


PROTOCOL = {
    "T0": (t0_quiet_standing, "static", "quiet standing, 20 s"),
    "T1": (t1_bow_standing, "motion", "bowing while standing"),
    "T2": (t2_bow_sitting, "motion", "bowing while sitting"),
    "T3": (t3_sit_to_stand, "motion", "standing up and sitting down"),
    "T4": (t4_shank_lift, "motion", "lifting shanks while sitting, left then right"),
    "T5": (t5_leg_swing, "motion", "swinging legs while standing, left then right"),
    "T6": (t6_walk, "motion", "walking straight 7 m at preferred speed"),
}
