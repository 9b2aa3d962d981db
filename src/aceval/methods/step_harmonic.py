"""The step-harmonic heading of a sensor in walking (beyond the papers).

While walking, the trunk's forward speed rises and falls once per step (the inverted pendulum:
fastest in double support, slowest at midstance), so its anterior-posterior acceleration is
strongest at the step frequency; its medial-lateral sway repeats once per stride, at half of it
(Zijlstra & Hof 2003, Gait Posture 18:1-10). The anterior-posterior axis is then the horizontal
direction (orthogonal to z0 from quiet standing) of largest acceleration power in a band around
the step frequency. A foot swings forward once per stride: its axis is read at half the step
frequency (:func:`harmonic`). The step frequency is that of one subject's walking test: the
dominant frequency of the acceleration-magnitude spectra of all its repetitions pooled (the
trunk's and pelvis' where there are any; :func:`pooled_steps`, which also says when the
recordings disagree: flag ``step_frequency_disagrees``).

Per recording, :func:`step_scatter` reduces the trimmed samples to the 3x3 scatter of the
band-passed acceleration (so subsets of repetitions add, as Kong's scatters do);
:func:`step_harmonic_rotation` turns a summed scatter and z0 into R. Conditioning: the ratio of
the two horizontal eigenvalues (middle / largest); near 1 no horizontal direction dominates and
the heading is undetermined (flag ``no_step_heading`` above :data:`MAX_STEP_RATIO`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from aceval.methods.combined import horizontal_right
from aceval.methods.interface import CalibrationMethod, combine_flags
from aceval.methods.sufficient import Part, Pooled, Statistic, median_where

#: walking step frequencies searched (Hz): 36-210 steps/min, beyond slow and fast walking
STEP_BAND_HZ = (0.6, 3.5)
#: the band-pass around the segment's frequency f: [0.75 f, 1.25 f] keeps the neighbouring
#: harmonics (f/2 and 2 f for the trunk's step) out
PASS_BAND = (0.75, 1.25)
#: above this middle/largest horizontal eigenvalue ratio the heading is undetermined (the same
#: 0.5 as Kong's smallest/middle eigenvalue ratio)
MAX_STEP_RATIO = 0.5
SCATTER_COLUMNS = [f"h{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
#: the leg segments: their acceleration magnitude mixes the stride's harmonics, so the step
#: frequency is taken from the trunk, head and pelvis where a test has them
LEG_SEGMENTS = ("thigh", "shank", "foot")
#: the segments read at the stride (half the step frequency): the foot swings forward once per
#: stride. The thigh and shank are read at the step, where their magnitude peaks: on kong_sim
#: the stride gave them 4.3-7.9 deg median error against 1.4-4.1 deg at the step (the kong_sim of
#: the assumed walking variability, measured with both rules; the trunk surges once per step,
#: Zijlstra & Hof 2003)
STRIDE_SEGMENTS = ("foot",)
#: resolution (Hz) of the acceleration-magnitude spectra that are pooled over repetitions
SPECTRUM_RESOLUTION_HZ = 0.005


def harmonic(segment: str) -> float:
    """The multiple of the step frequency at which a segment's anterior-posterior acceleration
    is read: 0.5 (the stride) for :data:`STRIDE_SEGMENTS`, else 1 (the step).
    """
    return 0.5 if segment in STRIDE_SEGMENTS else 1.0


def magnitude_spectrum(acc: np.ndarray, fs_hz: float) -> np.ndarray:
    """Power of the acceleration magnitude (mean removed, Hann window) on the fixed grid of
    :func:`spectrum_frequencies` (the same for every recording of a dataset, so that the
    spectra of several repetitions add).
    """
    magnitude = np.linalg.norm(acc, axis=1)
    magnitude = (magnitude - magnitude.mean()) * np.hanning(len(magnitude))
    frequency = spectrum_frequencies(fs_hz)
    n_fft = max(2 * (len(frequency) - 1), 1 << int(np.ceil(np.log2(max(len(magnitude), 2)))))
    power = np.abs(np.fft.rfft(magnitude, n_fft)) ** 2
    return np.interp(frequency, np.fft.rfftfreq(n_fft, 1.0 / fs_hz), power)


def spectrum_frequencies(fs_hz: float) -> np.ndarray:
    """The grid (Hz) of :func:`magnitude_spectrum`: 0 to Nyquist at about
    :data:`SPECTRUM_RESOLUTION_HZ`.
    """
    n_fft = 1 << int(np.ceil(np.log2(fs_hz / SPECTRUM_RESOLUTION_HZ)))
    return np.fft.rfftfreq(n_fft, 1.0 / fs_hz)


def peak_frequency(power: np.ndarray, fs_hz: float) -> float:
    """The frequency (Hz) of the largest ``power`` within :data:`STEP_BAND_HZ`."""
    frequency = spectrum_frequencies(fs_hz)
    band = (frequency >= STEP_BAND_HZ[0]) & (frequency <= STEP_BAND_HZ[1])
    return float(frequency[band][np.argmax(power[band])])


def long_enough(n_samples: int, fs_hz: float) -> bool:
    """Two cycles of the slowest step: enough samples to find a step frequency."""
    return n_samples >= 2 * fs_hz / STEP_BAND_HZ[0]


def step_frequency(acc: np.ndarray, fs_hz: float) -> float:
    """Dominant frequency (Hz) of one recording's acceleration magnitude within
    :data:`STEP_BAND_HZ`; NaN when it is shorter than :func:`long_enough`.
    """
    if not long_enough(len(acc), fs_hz):
        return float("nan")
    return peak_frequency(magnitude_spectrum(acc, fs_hz), fs_hz)


def pooled_steps(
    recordings: list[tuple[np.ndarray, np.ndarray, str, int]], fs_hz: float
) -> tuple[dict, float, list[float], bool]:
    """The step frequency of one subject's walking test from its recordings ``(acc, mask,
    segment, rep)`` (every IMU and repetition; ``mask``: the moving samples):

    * ``test_hz``: the peak of the acceleration-magnitude spectra of all repetitions pooled
      (each recording's spectrum over its moving span, scaled to unit power in
      :data:`STEP_BAND_HZ`, so that no sensor dominates), of the trunk's, head's and pelvis'
      recordings where there are any (their magnitude peaks at the step; a leg's mixes the
      stride's harmonics), else of every recording;
    * ``step_hz`` (rep -> Hz): each repetition's own peak of the same pooled spectra within
      :data:`PASS_BAND` of ``test_hz`` (a person walks at slightly different speeds), or
      ``test_hz`` where the repetition is too short on its own (:func:`long_enough`);
    * ``own_hz``: each recording's own peak in the whole band (NaN where too short);
    * ``disagree``: a repetition whose pooled spectra peak, searched over the whole band, lies
      outside :data:`PASS_BAND` of ``test_hz`` (another harmonic won there).

    NaN frequencies when all the moving spans together are too short.
    """
    spans = []
    for acc, mask, *_ in recordings:
        moving = np.flatnonzero(mask)
        spans.append(acc[moving[0] : moving[-1] + 1] if len(moving) else acc[:0])
    own = [step_frequency(span, fs_hz) if len(span) > 1 else float("nan") for span in spans]
    trunk = [i for i, (*_, segment, _) in enumerate(recordings) if segment not in LEG_SEGMENTS]
    voters = [i for i in (trunk or range(len(recordings))) if len(spans[i]) > 1]
    reps = sorted({rep for *_, rep in recordings})
    if not voters or not long_enough(sum(len(spans[i]) for i in voters), fs_hz):
        return dict.fromkeys(reps, float("nan")), float("nan"), own, False
    frequency = spectrum_frequencies(fs_hz)
    band = (frequency >= STEP_BAND_HZ[0]) & (frequency <= STEP_BAND_HZ[1])
    spectra = {i: magnitude_spectrum(spans[i], fs_hz) for i in voters}
    spectra = {i: p / max(p[band].sum(), 1e-300) for i, p in spectra.items()}
    test_hz = peak_frequency(sum(spectra.values()), fs_hz)
    near = (frequency >= PASS_BAND[0] * test_hz) & (frequency <= PASS_BAND[1] * test_hz)
    step_hz, disagree = {}, False
    for rep in reps:
        mine = [i for i in voters if recordings[i][3] == rep]
        if not mine or not long_enough(sum(len(spans[i]) for i in mine), fs_hz):
            step_hz[rep] = test_hz
            continue
        power = sum(spectra[i] for i in mine)
        step_hz[rep] = float(frequency[near][np.argmax(power[near])])
        anywhere = peak_frequency(power, fs_hz)
        disagree |= not PASS_BAND[0] <= anywhere / test_hz <= PASS_BAND[1]
    return step_hz, test_hz, own, disagree


def step_scatter(
    acc: np.ndarray, fs_hz: float, mask: np.ndarray, frequency_hz: float
) -> np.ndarray:
    """The scatter ``sum b b^T`` (3x3, m^2/s^4) of the acceleration band-passed around
    ``frequency_hz`` (:data:`PASS_BAND`; 2nd-order Butterworth, zero phase), over the samples of
    ``mask`` (the trimmer's moving samples). NaN when there is no frequency, the band reaches the
    Nyquist frequency or the recording is too short to filter.
    """
    nan = np.full((3, 3), np.nan)
    low, high = PASS_BAND[0] * frequency_hz, PASS_BAND[1] * frequency_hz
    if not np.isfinite(frequency_hz) or high >= 0.5 * fs_hz or not mask.any():
        return nan
    from scipy import signal  # here, not above: its import costs every job about 1 s (SciPy 1.17)

    sos = signal.butter(2, [low, high], btype="bandpass", fs=fs_hz, output="sos")
    if len(acc) <= 3 * 2 * len(sos):  # sosfiltfilt's padding needs a few samples
        return nan
    band = signal.sosfiltfilt(sos, acc, axis=0)[mask]
    return band.T @ band


def step_harmonic_rotation(H, z0, right) -> tuple[np.ndarray, np.ndarray]:
    """``(R, ratio)`` of each scatter in ``H`` (..., 3, 3) and z0 (3,) or (..., 3): R (..., 3, 3,
    sensor -> body) with z = z0 exactly, x the horizontal principal axis of the band-passed
    scatter (the anterior-posterior direction), its sign chosen so that y = z x x points along
    ``right``; ``ratio`` = middle / largest eigenvalue of the scatter projected on the horizontal
    plane (0: one direction, 1: none). NaN where a scatter is not finite or has no horizontal
    power.
    """
    H, z0 = np.asarray(H, float), np.asarray(z0, float)
    P = np.eye(3) - z0[..., :, None] * z0[..., None, :]
    finite = np.isfinite(H).all(axis=(-2, -1))
    projected = P @ np.where(finite[..., None, None], H, 0.0) @ P
    eigenvalues, vectors = np.linalg.eigh(projected)  # ascending; the smallest is along z0
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = eigenvalues[..., 1] / eigenvalues[..., 2]
    y = horizontal_right(np.cross(z0, vectors[..., :, 2]), z0, right)  # right of the AP axis
    R = np.stack([np.cross(y, z0), y, np.broadcast_to(z0, y.shape)], axis=-2)
    valid = finite & (eigenvalues[..., 2] > 0)
    return np.where(valid[..., None, None], R, np.nan), np.where(valid, ratio, np.nan)


# --- the method's interface in Kong's protocol (aceval.methods.interface) -----------------------

#: why a walking test has no step-harmonic calibration
TOO_SHORT = (
    "needs walking of at least two cycles of the slowest step (3.3 s, all repetitions of the "
    "test together) to find the step frequency; this test's recordings are shorter"
)


def reduce_walking(recordings: list, fs_hz: float, summaries: dict) -> None:
    """The step-harmonic columns of one subject's walking test (``recordings``: (summary index or
    None, acceleration, moving mask, segment, repetition) of every recording read, every
    repetition and IMU, those not calibrated in this test too: they tell the step frequency,
    :func:`pooled_steps`), added to ``summaries`` (index -> the recording's summary row):
    ``step_hz``, the repetition's step frequency, ``step_hz_own``, the recording's own,
    ``step_disagrees`` (1 where the test's repetitions disagree on it) and ``h11..h33``, the
    scatter of the acceleration band-passed at the segment's harmonic of the step over the kept
    samples (the row's ``kept`` ranges).
    """
    step_hz, _, own, disagree = pooled_steps([r[1:] for r in recordings], fs_hz)
    for (index, acc, _, segment, rep), own_hz in zip(recordings, own):
        if index is None:
            continue
        kept = np.zeros(len(acc), dtype=bool)
        for part in filter(None, str(summaries[index].get("kept", "")).split(";")):
            start, stop = map(int, part.split(":"))
            kept[start:stop] = True
        scatter = step_scatter(acc, fs_hz, kept, harmonic(segment) * step_hz[rep])
        summaries[index].update(
            step_hz=step_hz[rep], step_hz_own=own_hz, step_disagrees=float(disagree)
        )
        summaries[index].update(zip(SCATTER_COLUMNS, scatter.ravel()))


def _pooled_steps(units, unit, weights, sums, subsets) -> dict:
    """The step-band scatter of each row's chosen repetitions (NaN where the unit is not a
    walking test with every repetition's scatter), their median step frequency (a subset's) and
    whether the test's recordings disagree on it.
    """
    steps_per_rep = units.get("steps")
    walking = np.isfinite(steps_per_rep).all(axis=(1, 2, 3))[unit]
    chosen = weights > 0
    with np.errstate(invalid="ignore"):
        steps = np.einsum(
            "br,brij->bij", weights, np.where(chosen[..., None, None], steps_per_rep[unit], 0.0)
        )
    steps[~walking] = np.nan
    nan = np.full(len(unit), np.nan)
    return {
        "steps": steps,
        "walking": walking,
        "step_hz": median_where(units.get("step_hz")[unit], chosen) if subsets else nan,
        "step_disagrees": (np.where(chosen, units.get("step_disagrees")[unit], 0.0) > 0).any(
            axis=1
        ),
    }


#: the scatter of the acceleration band-passed at the segment's harmonic of the step, per
#: repetition of a walking test (:func:`reduce_walking`: after the subject's whole test is read),
#: with the repetition's step frequency and whether the test's recordings disagree on it
STEP_SCATTER = Statistic(
    "step_scatter",
    {
        "steps": Part(tuple(SCATTER_COLUMNS), (3, 3), absent=0.0, missing=np.nan, summed=False),
        "step_hz": Part(("step_hz",), absent=np.nan, missing=np.nan, summed=False),
        "step_disagrees": Part(("step_disagrees",), summed=False),
    },
    reduce_test=reduce_walking,
    test_phase="gait",
    derive=_pooled_steps,
)


class StepHarmonic(CalibrationMethod):
    """The step-harmonic calibration of each walking row from its summed step-band scatter,
    flagged ``no_step_heading`` when no horizontal direction dominates (:data:`MAX_STEP_RATIO`),
    ``step_frequency_disagrees`` when the test's recordings disagree on the step frequency, and
    ``not_applicable`` (with a ``note``) when the test's walking is too short. Diagnostics:
    ``step_ratio`` (middle / largest horizontal eigenvalue), ``step_hz`` (Hz), ``note``. The
    step's reference in the others' cones.
    """

    statistics = (STEP_SCATTER,)
    diagnostics = ("step_ratio", "step_hz", "note")
    signal = "step"
    cone_reference = True

    def applies(self, pooled: Pooled) -> np.ndarray:
        """Walking rows: those with a step-band scatter, and (flagged ``not_applicable``) the
        calibration from all repetitions of a walking test whose repetitions are too short.
        """
        return pooled.walking | ((pooled.first_phase == "gait") & pooled.all_repetitions)

    def fit(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod] | None = None):
        """The step-harmonic calibration of each row (class docstring)."""
        R, ratio = step_harmonic_rotation(pooled.steps, pooled.z0, pooled.right)
        flag = np.where(ratio <= MAX_STEP_RATIO, "", "no_step_heading").astype(object)
        flag[pooled.step_disagrees] = [
            combine_flags(f, "step_frequency_disagrees") for f in flag[pooled.step_disagrees]
        ]
        flag[~pooled.walking] = "not_applicable"
        note = np.where(pooled.walking, None, TOO_SHORT).astype(object)
        step_hz = np.where(pooled.walking, pooled.step_hz, np.nan)
        return self._set(R, flag, {"step_ratio": ratio, "step_hz": step_hz, "note": note})

    def resample(self, pooled: Pooled, fitted: Mapping[str, CalibrationMethod] | None = None):
        """The step-harmonic calibration of bootstrap resamples, NaN where flagged."""
        R, ratio = step_harmonic_rotation(pooled.steps, pooled.z0, pooled.right)
        ok = ratio <= MAX_STEP_RATIO
        return self._set(
            np.where(ok[:, None, None], R, np.nan), np.where(ok, "", "no_step_heading")
        )
