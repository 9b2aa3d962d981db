"""The one list of aceval's calibration methods of Kong's protocol, in the order they are fitted
and shown (each fit may read the fits of the methods before it: the combined heading builds on
Kong's plane and the axis methods' verdict on the gyroscope axis). Adding a method is a module
with the interface of :mod:`aceval.methods.interface`, one row here and a test; calibration,
uncertainty, the tables, the figures and the command line's ``--method`` follow this list.

Ricci's functional design (``functional_axes.tsv``) fits the three axis methods from every axis
its sheet lists instead (:func:`aceval.methods.functional.functional_fits`).
"""

from __future__ import annotations

from aceval.methods.align_vectors import METHOD as ALIGN_VECTORS
from aceval.methods.combined import METHOD as COMBINED
from aceval.methods.interface import Method
from aceval.methods.kong import METHOD as KONG
from aceval.methods.ricci import METHOD as RICCI_LM
from aceval.methods.step_harmonic import METHOD as STEP_HARMONIC
from aceval.methods.triad import METHOD as TRIAD

METHODS: tuple[Method, ...] = (KONG, RICCI_LM, ALIGN_VECTORS, TRIAD, COMBINED, STEP_HARMONIC)
#: the method names, in the registry's order
NAMES: tuple[str, ...] = tuple(m.name for m in METHODS)
#: the axis methods (Ricci's LM, the closed-form optimum, TRIAD): the ones Ricci's functional
#: design fits too
AXIS_METHODS: tuple[str, ...] = (RICCI_LM.name, ALIGN_VECTORS.name, TRIAD.name)


def method(name: str) -> Method:
    """The registered method called ``name`` (ValueError naming the others if there is none)."""
    for candidate in METHODS:
        if candidate.name == name:
            return candidate
    raise ValueError(f"no calibration method {name!r}; aceval's are {', '.join(NAMES)}")
