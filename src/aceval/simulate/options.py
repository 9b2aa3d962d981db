"""Options shared by the simulated protocols, and the step from segment pose to sensor signals."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aceval.simulate.engine import (
    OVERSAMPLE,
    PAD,
    ImuErrorModel,
    band_noise,
    each_times,
    measure,
    small_rotations,
)


@dataclass(frozen=True)
class SimOptions:
    """Switches of the physical effects (all on by default). ``offplane``, ``wobble`` and
    ``sensor_bias`` scale out-of-sagittal-plane motion, soft-tissue wobble and the sensors'
    constant biases (1 = physiological or datasheet value, 0 = off).
    """

    fs_hz: float = 100.0
    noise: bool = True
    offplane: float = 1.0
    wobble: float = 1.0
    #: scale of the sensors' constant biases (1 = the datasheet's, :class:`ImuErrorModel`)
    sensor_bias: float = 1.0
    #: scale of the heel strike's shaking of the leg sensors in walking
    #: (:func:`heel_strike_shaking`; 0 = none, as in the committed datasets; 1 = the walk whose
    #: planarity sits in the real recordings' range, docs/simulation.md)
    impacts: float = 0.0
    #: the walk's lower-leg variability: 'measured' (set from real walking, docs/simulation.md)
    #: or 'assumed' (a sagittal lower leg, as before the variability was measured: the datasets
    #: simulated then, exactly)
    variability: str = "measured"
    misalignment_sd_deg: float = 10.0
    repetitions: int = 5
    jobs: int = 1  # processes writing subjects side by side (the output does not depend on it)
    #: the recordings' files (aceval.data.writer.FILE_FORMATS): Parquet, or CSV as a lab's export
    file_format: str = "parquet"


def sensor_signals(
    rng,
    R_seg,
    origin,
    mount,
    position,
    envelope,
    wobble_deg,
    options,
    acc_range_g,
    error_model=ImuErrorModel(),
    shaking=None,
):
    """Measured (gyr rad/s, acc m/s^2) of a sensor mounted with ``mount`` (sensor -> segment) at
    ``position`` (segment frame, m) on a segment with pose ``R_seg``/``origin`` on the fine grid.

    Soft-tissue wobble: a small rotation of the sensor on its segment, 0.5-3 Hz, RMS ``wobble_deg``
    while the segment moves (scaled by the movement ``envelope``), zero at rest. ``shaking``: a
    displacement of the sensor on its soft tissue (m, world frame, on the fine grid), e.g.
    :func:`heel_strike_shaking`.
    """
    R_ws = each_times(R_seg, mount)
    amplitude = np.radians(wobble_deg) * options.wobble
    if amplitude > 0:
        t = (np.arange(len(R_seg)) - PAD) / (options.fs_hz * OVERSAMPLE)  # as fine_time
        envelope = np.clip(np.broadcast_to(envelope, t.shape), 0.0, 1.0)
        rotvec = np.column_stack([band_noise(rng, t, 0.5, 3.0) for _ in range(3)]) / np.sqrt(3)
        R_ws = R_ws @ small_rotations(amplitude * envelope[:, None] * rotvec)
    p_w = origin + each_times(R_seg, position)
    if shaking is not None:
        p_w = p_w + shaking
    gyr, acc = measure(R_ws, p_w, options.fs_hz)
    return error_model.apply(
        rng,
        gyr,
        acc,
        options.fs_hz,
        acc_range_g,
        enabled=options.noise,
        bias_scale=options.sensor_bias,
    )


#: the heel strike's shaking of a leg sensor on its soft tissue (:func:`heel_strike_shaking`):
#: peak acceleration (g) by segment, frequency (Hz) and the SD (s) of its Gaussian envelope.
#: Soft tissue of the leg rings at tens of Hz after heel strike, damped within about 0.1 s
#: (Wakeling & Nigg 2001, J Appl Physiol 90:412); the impact reaches the tibia as a transient of a
#: few g in walking, less higher up the leg (Lafortune et al. 1996, J Biomech 29:1531). The peaks
#: are set so that the simulated walk's planarity falls in the real recordings' range
#: (docs/simulation.md, "Real and simulated variability"); the shaking is a variant of the
#: coverage study (aceval.evaluation.coverage), off in the committed datasets
SHAKING_PEAK_G = {"foot": 3.5, "shank": 2.5, "thigh": 0.5}
SHAKING_HZ, SHAKING_SD_S = 15.0, 0.02


def heel_strike_shaking(rng, t: np.ndarray, strikes, peak_g: float) -> np.ndarray:
    """(M, 3) displacement (m, world) of a sensor shaken at every heel strike (times ``strikes``,
    s) on the fine grid ``t``: a Gaussian-windowed oscillation of :data:`SHAKING_HZ` centred
    two SDs after the strike, each in its own random direction, with peak acceleration
    ``peak_g``. Smooth (its derivatives are exact on the grid) and zero between strikes.
    """
    omega = 2 * np.pi * SHAKING_HZ
    amplitude = peak_g * 9.81 / omega**2
    out = np.zeros((len(t), 3))
    for strike in np.asarray(strikes, float):
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        lag = t - strike - 2 * SHAKING_SD_S
        pulse = np.exp(-0.5 * (lag / SHAKING_SD_S) ** 2) * np.sin(omega * lag)
        out += amplitude * pulse[:, None] * direction
    return out
