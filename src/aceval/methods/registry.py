"""The one list of calibration methods: aceval's own and the peers beside them, in the order every
table, figure and summary shows them. Each line is everything the rest of aceval knows about a
method by its name; aceval's own methods are classes (:mod:`aceval.methods.interface`) that
declare, besides, all the rest: the statistics they read, the methods they build on, their
subset policy, their diagnostics columns, their signal and whether it is that signal's reference
in the cones, and whether Ricci's functional design fits them.

Adding a method is its module (a :class:`aceval.methods.interface.CalibrationMethod`), one line
here and a test: calibration, the one pass's statistics, the uncertainty, the tables, the figures,
the summaries and ``aceval calibrate --method`` follow this list (docs/architecture.md, "Add a
method"). A peer (a published tool run in its own environment by the workflow, workflow/peers/)
is one line too: its environment, its adapter and where its authors meant it.

This module imports no method (nor NumPy): the workflow reads the peers from it at every start.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Peer:
    """A peer tool: ``environment`` (its own virtual environment, .venv-peers/<environment>, from
    the pinned workflow/peers/<environment>.txt), ``adapter`` (workflow/peers/<adapter>: a plan
    in, rotations in aceval's convention out), ``design_segments`` (where its authors meant it;
    None: no such limit), ``design_note`` (what SUMMARY.md says where it is shown elsewhere;
    ``{others}`` names the segments), ``static_pose`` (it calibrates from a static pose, so its
    cells are the static test's, not the motion tests').
    """

    environment: str
    adapter: str
    design_segments: tuple[str, ...] | None = None
    design_note: str = ""
    static_pose: bool = False


@dataclass(frozen=True)
class Method:
    """One line of the registry: ``name`` (the ``method`` column of every table), ``summary`` (one
    line, for the command line and the docs), ``implementation`` ('module:Class' of aceval's own
    method; '' for a peer), ``paper`` (the paper whose method it is, e.g. 'kong2016': its
    analyses read this method's calibrations), ``peer`` (a peer's facts).
    """

    name: str
    summary: str
    implementation: str = ""
    paper: str = ""
    peer: Peer | None = None

    def load(self) -> type:
        """The method's class (imported on first use)."""
        if not self.implementation:
            raise ValueError(f"{self.name} is a peer: it runs in its own environment")
        module, cls = self.implementation.split(":")
        return getattr(importlib.import_module(module), cls)


METHODS: list[Method] = [
    Method(
        "kong",
        "Kong et al. 2016: z0 from quiet standing, body y from the normal of the plane of the "
        "motion test's accelerations (every subset of repetitions)",
        "aceval.methods.kong:Kong",
        paper="kong2016",
    ),
    Method(
        "ricci_lm",
        "Ricci et al. 2014: the rho-weighted Levenberg-Marquardt fit of z0 and the gyroscope's "
        "principal axis onto body z and y",
        "aceval.methods.ricci:RicciLM",
        paper="ricci2014",
    ),
    Method(
        "align_vectors",
        "the closed-form optimum of Ricci's weighted cost (SciPy's Rotation.align_vectors)",
        "aceval.methods.align_vectors:AlignVectors",
    ),
    Method(
        "triad",
        "TRIAD: z0 kept exactly, body y from the gyroscope's principal axis",
        "aceval.methods.triad:Triad",
    ),
    Method(
        "combined",
        "Kong's plane normal and the gyroscope's principal axis, weighted by their conditioning "
        "(beyond the papers)",
        "aceval.methods.combined:Combined",
    ),
    Method(
        "step_harmonic",
        "walking: body x from the horizontal acceleration at the step frequency (beyond the "
        "papers)",
        "aceval.methods.step_harmonic:StepHarmonic",
    ),
    Method(
        "gaitmap_pca",
        "gaitmap's PcaAlignment: the horizontal principal axis of the gravity-aligned gyroscope "
        "(a peer)",
        peer=Peer(
            "gaitmap",
            "gaitmap_pca.py",
            design_segments=("foot",),
            design_note="gaitmap's PCA alignment is written for the foot's medial-lateral axis in "
            "gait (its docstring); its rows on {others} are outside that design",
        ),
    ),
    Method(
        "qmt_hinge",
        "qmt's hinge joint axis estimation (Olsson et al. 2020): the knee axis in the thigh's and "
        "the shank's frames at once (a peer)",
        peer=Peer("qmt", "qmt_hinge.py"),
    ),
    Method(
        "opensense_imuplacer",
        "OpenSim's OpenSense IMUPlacer: the static pose and the vendor's heading (a peer)",
        peer=Peer(
            "opensim",
            "opensense_imuplacer.py",
            design_note="OpenSense's IMUPlacer reads the static pose (the first sample of quiet "
            "standing) and the vendor's magnetometer-aided headings only: it is reported under "
            "the static test, and its cells are not the motion tests' (more information than the "
            "others get: a heading)",
            static_pose=True,
        ),
    ),
]


def names() -> list[str]:
    """Every method's name, in the registry's order."""
    return [m.name for m in METHODS]


def method(name: str) -> Method:
    """The registry's line of ``name`` (ValueError naming the others if there is none)."""
    for candidate in METHODS:
        if candidate.name == name:
            return candidate
    raise ValueError(f"no calibration method {name!r}; aceval's are {', '.join(own())}")


def own() -> list[str]:
    """The names of aceval's own methods (not the peers), in the registry's order."""
    return [m.name for m in METHODS if m.peer is None]


def peers() -> dict[str, Peer]:
    """The peers, name -> :class:`Peer`, in the registry's order."""
    return {m.name: m.peer for m in METHODS if m.peer is not None}


def rank(name: str) -> int:
    """A method's place in the registry (every table's and figure's order); a name the
    registry does not know comes after all of them.
    """
    order = names()
    return order.index(name) if name in order else len(order)


def ordered(found) -> list[str]:
    """The method names in ``found`` (any iterable), in the registry's order (unknown ones last,
    by name).
    """
    return sorted(set(found), key=lambda name: (rank(name), name))


def signals() -> dict[str, str]:
    """What each of aceval's own methods' heading comes from (its class's ``signal``), by method
    name.
    """
    return {name: cls.signal for name, cls in classes().items() if cls.signal}


def cone_references() -> dict[str, str]:
    """Each signal's reference method (the one whose class declares ``cone_reference``): the
    estimate of that signal every other method's cone is compared with
    (:func:`aceval.methods.uncertainty.heading_terms`). ValueError where a signal has two.
    """
    found: dict[str, str] = {}
    for name, cls in classes().items():
        if cls.cone_reference:
            if cls.signal in found:
                raise ValueError(
                    f"{found[cls.signal]} and {name} both declare themselves the cone reference "
                    f"of signal {cls.signal!r}: one per signal"
                )
            found[cls.signal] = name
    return found


def paper_method(paper: str) -> str:
    """The method whose calibrations a paper's analyses read ('kong2016' -> 'kong')."""
    for candidate in METHODS:
        if candidate.paper == paper:
            return candidate.name
    raise ValueError(f"no method reproduces {paper!r}")


def functional_design() -> list[str]:
    """The methods Ricci's functional design fits from its axes: those whose class has
    ``fit_functional``, in the registry's order.
    """
    return [name for name, cls in classes().items() if cls.serves_functional_design()]


def diagnostics() -> list[str]:
    """Every diagnostics column aceval's methods declare, each once, in the registry's order (the
    calibrations table's last columns, :mod:`aceval.calibrate.rows`).
    """
    return list(dict.fromkeys(c for cls in classes().values() for c in cls.diagnostics))


def classes(chosen=None) -> dict[str, type]:
    """The classes of aceval's own methods, name -> class, in the registry's order (``chosen``: only
    these and the methods they need, transitively).
    """
    wanted = set(own() if chosen is None else chosen)
    found: dict[str, type] = {}
    while wanted - set(found):
        for name in sorted(wanted - set(found)):
            found[name] = method(name).load()
            wanted |= set(found[name].needs)
    return {name: found[name] for name in own() if name in found}


def fit_order(methods: dict[str, type]) -> list[str]:
    """The names of ``methods`` in an order where each comes after the ones it ``needs`` (the
    registry's order otherwise).
    """
    order: list[str] = []

    def visit(name: str, path: tuple[str, ...]) -> None:
        if name in order:
            return
        if name in path:
            raise ValueError(f"methods need each other in a circle: {' -> '.join(path + (name,))}")
        for needed in methods[name].needs:
            visit(needed, path + (name,))
        order.append(name)

    for name in methods:
        visit(name, ())
    return order


def statistics(chosen=None) -> list:
    """Every statistic aceval's methods declare (``chosen``: these methods and those they need),
    each once, in the registry's order: what the one pass computes
    (:mod:`aceval.signals.reduction`).
    """
    found = {}
    for cls in classes(chosen).values():
        for statistic in cls.statistics:
            found.setdefault(statistic.name, statistic)
    return list(found.values())
