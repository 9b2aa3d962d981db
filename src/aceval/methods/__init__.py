"""Calibration methods of Kong's protocol, each a module with the interface of
:mod:`aceval.methods.interface`, listed in :mod:`aceval.methods.registry`: Kong's PCA plane
(kong), Ricci's SVD axis and weighted LM (ricci), the closed-form optimum (align_vectors), TRIAD
(triad), the combined heading (combined) and the step-harmonic heading (step_harmonic). The
names below are the papers' equations as functions of samples and axes.
"""

from aceval.methods.align_vectors import wahba_fit
from aceval.methods.kong import (
    KongLimits,
    KongResult,
    kong_calibrate,
    kong_from_scatters,
    scatter,
    vertical_axis,
)
from aceval.methods.ricci import AxisEstimate, LMResult, functional_axis, lm_fit
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
