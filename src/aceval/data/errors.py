"""Exceptions raised for bad input. Each names its cause; callers add the file/sensor context."""


class InputError(ValueError):
    """A file or value given to a command cannot be used; the message names it and the cause."""


#: what an OSError's cause means for the user, where its text does not say it
_OS_HINTS = {
    "EFBIG": "the disk is full or a file size limit was reached",
    "ENOSPC": "free some space, or write elsewhere",
    "ENAMETOOLONG": "a file or folder name is limited to 255 bytes",
    "EROFS": "choose a writable place",
    "EACCES": "check the permissions, or choose another place",
}


def describe_os_error(exc: OSError) -> str:
    """One line for an OSError: the file (both, for a rename), the cause and what it means."""
    import errno

    where = " -> ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
    cause = exc.strerror or str(exc)
    hint = _OS_HINTS.get(errno.errorcode.get(exc.errno or 0, ""), "")
    return f"{where + ': ' if where else ''}{cause}{f' ({hint})' if hint else ''}"


class CalibrationError(ValueError):
    """Base class: the input cannot give a trustworthy calibration."""

    #: short machine-readable code, used as the flag in flagged (non-raising) results
    code = "calibration_error"


class TooFewSamplesError(CalibrationError):
    """Fewer samples than the method needs."""

    code = "too_few_samples"


class NonFiniteError(CalibrationError):
    """NaN or inf samples."""

    code = "non_finite"


class ZeroGravityError(CalibrationError):
    """The quiet-stance median is too short to be gravity."""

    code = "zero_gravity"


class NoMovementError(CalibrationError):
    """A motion recording without movement (peak angular velocity too low)."""

    code = "no_movement"


class TooShortError(CalibrationError):
    """A motion recording shorter than a repetition can be (a part of one: a cut file?)."""

    code = "too_short"


class SaturatedError(CalibrationError):
    """Too many samples clipped at the accelerometer range."""

    code = "saturated"


class StuckChannelError(CalibrationError):
    """A channel of the recording holds one value while the sensor's others are noisy."""

    code = "stuck_channel"


class NotPlanarError(CalibrationError):
    """Accelerations not in a plane, or its normal undetermined (Kong)."""

    code = "not_planar"


class NormalParallelToVerticalError(CalibrationError):
    """The plane normal is too close to the vertical (Kong)."""

    code = "normal_parallel_to_vertical"


class TooFewAxesError(CalibrationError):
    """Fewer than 2 axes for an axis method."""

    code = "too_few_axes"


class AlignedAxesError(CalibrationError):
    """The two axes of TRIAD are too close to each other."""

    code = "aligned_axes"


def check_samples(samples, *, name: str, min_samples: int, ndim_last: int = 3):
    """Return ``samples`` as a float (N, 3) array after checking shape, count and finiteness.

    Raises TooFewSamplesError / NonFiniteError naming ``name`` and the cause.
    """
    import numpy as np

    array = np.asarray(samples, dtype=float)
    if array.ndim != 2 or array.shape[1] != ndim_last:
        raise ValueError(f"{name}: expected an (N, {ndim_last}) array, got shape {array.shape}")
    if array.shape[0] < min_samples:
        raise TooFewSamplesError(
            f"{name}: {array.shape[0]} samples, at least {min_samples} are needed"
        )
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise NonFiniteError(
            f"{name}: {int(bad.sum())} samples contain NaN or inf (first at sample {first})"
        )
    return array


def check_axes(v_ref, v_est, weights):
    """Axis pairs ``v_ref ~ R v_est`` ((N, 3) each, N >= 2) and their weights (N,), checked and
    unit-normalised: ValueError for NaN, zero-length axes or bad weights, TooFewAxesError for
    fewer than 2 pairs.
    """
    import numpy as np

    v_ref = np.atleast_2d(np.asarray(v_ref, dtype=float))
    v_est = np.atleast_2d(np.asarray(v_est, dtype=float))
    if v_ref.shape != v_est.shape or v_ref.shape[-1] != 3:
        raise ValueError(f"v_ref {v_ref.shape} and v_est {v_est.shape} must both be (N, 3)")
    if len(v_ref) < 2:
        raise TooFewAxesError(
            f"{len(v_ref)} axis pair(s) given: at least 2 non-aligned axes define a rotation"
        )
    for name, vectors in (("v_ref", v_ref), ("v_est", v_est)):
        if not np.isfinite(vectors).all():
            raise ValueError(f"{name} contains NaN or inf")
        norms = np.linalg.norm(vectors, axis=1)
        if np.any(norms < 1e-9):
            raise ValueError(f"{name} contains a zero-length axis")
    weights = np.ones(len(v_ref)) if weights is None else np.asarray(weights, dtype=float)
    if weights.shape != (len(v_ref),) or np.any(weights < 0) or not np.isfinite(weights).all():
        raise ValueError(f"weights must be {len(v_ref)} finite non-negative numbers, got {weights}")
    v_ref = v_ref / np.linalg.norm(v_ref, axis=1, keepdims=True)
    v_est = v_est / np.linalg.norm(v_est, axis=1, keepdims=True)
    return v_ref, v_est, weights
