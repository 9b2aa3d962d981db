"""Physical simulator of the papers' protocols, writing datasets in the contract with ground truth.

Every simulated dataset says ``simulated: true`` in its dataset.yaml. Parameters and their sources:
docs/simulation.md. They come from physiology and sensor datasheets and are never tuned to make a
reproduced table match a published one.
"""

from aceval.simulate.box import box_simulation, simulate_box
from aceval.simulate.kong_dataset import kong_simulation, simulate_kong
from aceval.simulate.options import SimOptions
from aceval.simulate.ricci_dataset import ricci_simulation, simulate_ricci
from aceval.simulate.simulation import Simulation, write_simulation

GENERATORS = {"kong": simulate_kong, "ricci": simulate_ricci, "box": simulate_box}
#: each protocol's dataset before it is written (``aceval simulate`` writes it whole; the
#: workflow's job per dataset subject by subject, :mod:`aceval.batches`)
SIMULATIONS = {"kong": kong_simulation, "ricci": ricci_simulation, "box": box_simulation}

__all__ = [
    "GENERATORS",
    "SIMULATIONS",
    "SimOptions",
    "Simulation",
    "simulate_box",
    "simulate_kong",
    "simulate_ricci",
    "write_simulation",
]
