"""The builders the outputs' registry (:mod:`aceval.report.outputs`) names: each builds a table
from the dict of tidy tables, or draws a figure, importing its module only when called (so
reading the registry costs no start-up time).
"""

from __future__ import annotations

from collections.abc import Callable


def kong_table(number: int) -> Callable:
    """Kong et al. 2016's Table ``number`` from the correlations and angles."""

    def build(data: dict):
        from aceval.report import kong2016

        return kong2016.build(
            number,
            data.get("correlations"),
            data.get("angles"),
            data["sensor_sets"],
            data["paper_names"],
        )

    return build


def kong_markdown(table, output, dataset: str, simulated: bool) -> str:
    """A Kong table as Markdown beside the paper's values."""
    from aceval.report import kong2016

    return kong2016.to_markdown(table, output, dataset, simulated)


def named_markdown(table, output, dataset: str, simulated: bool) -> str:
    """Any other table as Markdown under its title."""
    from aceval.report.kong2016 import named_markdown

    return named_markdown(table, output.title, output.unit, dataset, simulated)


def named(
    function: str, *kinds: str, optional: tuple[str, ...] = (), exact: bool | str = False
) -> Callable:
    """A builder calling ``module.function(data[kind], ...)`` (``optional`` kinds may be None),
    then rounding as every table is rounded (``exact``: not, for a table whose numbers feed a
    recomputation; 'rotation': all but the rotation r11..r33, which another command applies).
    """
    module, name = function.rsplit(".", 1)

    def build(data: dict):
        import importlib

        from aceval.data.contract import R_COLUMNS
        from aceval.report.kong2016 import rounded

        call = getattr(importlib.import_module(f"aceval.{module}"), name)
        arguments = [data[k] for k in kinds] + [data.get(k) for k in optional]
        table = call(*arguments).reset_index(drop=True)
        if exact is True:
            return table
        kept = [c for c in R_COLUMNS if c in table] if exact == "rotation" else []
        return rounded(table.drop(columns=kept)).join(table[kept])[table.columns]

    return build


def kong_units(function: str) -> Callable:
    """A table of ``conditioning.function`` on Kong's per-unit conditioning rows."""

    def build(data: dict):
        from aceval.evaluation import conditioning
        from aceval.report.kong2016 import rounded

        units = conditioning.kong_units(data["axes"], data["calibrations"], data.get("angles"))
        return rounded(getattr(conditioning, function)(units).reset_index(drop=True))

    return build


def kong_figure(number: int) -> Callable:
    """Kong et al. 2016's Figure ``number``."""

    def draw(data: dict, out, title: str) -> None:
        from aceval.report import figures

        figures.plot(
            number, data.get("correlations"), data.get("angles"), out, title, data["paper_names"]
        )

    return draw


def named_figure(data: dict, out, title: str, name: str = "") -> None:
    """Draw the figure ``name`` (beyond the papers) to ``out``."""
    from aceval.report import figures

    figures.plot_named(name, data, out, title)


def figure(name: str) -> Callable:
    """The drawer of the figure ``name``."""
    return lambda data, out, title: named_figure(data, out, title, name)
