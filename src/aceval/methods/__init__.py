"""Calibration methods: Kong PCA plane (kong), Ricci SVD axis + weighted LM (ricci), TRIAD (triad)."""

from aceval.methods.kong import (
    KongLimits,
    KongResult,
    kong_calibrate,
    kong_from_scatters,
    scatter,
    vertical_axis,
)
from aceval.methods.ricci import AxisEstimate, LMResult, functional_axis, lm_fit, wahba_fit
from aceval.methods.triad import triad

__all__ = [
    "AxisEstimate",
    "KongLimits",
    "KongResult",
    "LMResult",
    "functional_axis",
    "kong_calibrate",
    "kong_from_scatters",
    "lm_fit",
    "scatter",
    "triad",
    "vertical_axis",
    "wahba_fit",
]
