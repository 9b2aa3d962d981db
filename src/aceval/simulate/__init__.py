"""Physical simulator of the papers' protocols, writing datasets in the contract with ground truth.

Every simulated dataset says ``simulated: true`` in its dataset.yaml. Parameters and their sources:
docs/simulation.md. They come from physiology and sensor datasheets and are never tuned to make a
reproduced table match a published one.
"""

from aceval.simulate.box import simulate_box
from aceval.simulate.kong_dataset import simulate_kong
from aceval.simulate.options import SimOptions
from aceval.simulate.ricci_dataset import simulate_ricci

GENERATORS = {"kong": simulate_kong, "ricci": simulate_ricci, "box": simulate_box}

__all__ = ["GENERATORS", "SimOptions", "simulate_box", "simulate_kong", "simulate_ricci"]
