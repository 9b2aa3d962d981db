"""Calibration methods of Kong's protocol, each a class with the interface of
:mod:`aceval.methods.interface`, listed in :mod:`aceval.methods.registry` with the peers: Kong's PCA
plane (kong), Ricci's SVD axis and weighted LM (ricci), the closed-form optimum (align_vectors),
TRIAD (triad), the combined heading (combined) and the step-harmonic heading (step_harmonic). The
names below are the papers' equations as functions of samples and axes, imported on first use (so
that reading the registry costs no NumPy).
"""

import importlib

_WHERE = {
    "AxisEstimate": "moments",
    "functional_axis": "moments",
    "scatter": "moments",
    "vertical_axis": "moments",
    "KongLimits": "kong",
    "KongResult": "kong",
    "kong_calibrate": "kong",
    "kong_from_scatters": "kong",
    "LMResult": "ricci",
    "lm_fit": "ricci",
    "wahba_fit": "align_vectors",
}
__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(f"aceval.methods.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'aceval.methods' has no attribute {name!r}")
