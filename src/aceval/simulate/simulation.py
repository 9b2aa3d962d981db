"""A simulated dataset before it is written: what every protocol (Kong's, the box's, Ricci's)
gives, so that the dataset is written whole (:func:`write_simulation`, ``aceval simulate``) or
subject by subject by the workflow's job, which calibrates each batch of subjects from the
recordings it has just simulated (:mod:`aceval.batches`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from aceval.data.writer import DatasetWriter
from aceval.simulate.options import SimOptions


@dataclass(frozen=True)
class Simulation:
    """``meta`` (dataset.yaml), ``subjects`` (the subjects' names, in subjects.tsv order),
    ``sheets`` (writes every sheet but recordings.tsv and ground_truth.tsv into a writer's
    folder), ``subject`` (``subject(k, writer)``: subject ``k``'s recordings and ground truth,
    from its own random streams, into a writer) and the ``label`` of the progress line.
    """

    meta: dict
    subjects: list[str]
    sheets: Callable[[DatasetWriter], None]
    subject: Callable[[int, DatasetWriter], None]
    label: str


def write_simulation(simulation: Simulation, out: Path, options: SimOptions) -> Path:
    """Write ``simulation`` into ``out`` whole (``options.jobs`` processes side by side: the same
    bytes whatever their number); returns ``out``.
    """
    writer = DatasetWriter(out, simulation.meta, file_format=options.file_format)
    simulation.sheets(writer)
    count = len(simulation.subjects)
    writer.each_subject(simulation.subject, count, options.jobs, f"{simulation.label} {out}")
    writer.close()
    return Path(out)


def written(simulation: Callable[..., Simulation]) -> Callable[..., Path]:
    """The function that writes ``simulation``'s dataset into a folder (:func:`write_simulation`):
    ``(out, seed, ...) -> out``, its other arguments ``simulation``'s (their defaults too).
    """
    signature = inspect.signature(simulation)

    def simulate(out: Path, *args, **kwargs) -> Path:
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        options = bound.arguments["options"]
        return write_simulation(simulation(*bound.args, **bound.kwargs), out, options)

    simulate.__doc__ = (
        f"Write :func:`{simulation.__name__}` into ``out`` (then its other arguments); returns "
        "``out``."
    )
    return simulate
