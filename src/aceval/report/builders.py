"""The builders the outputs' registry (:mod:`aceval.report.outputs`) refers to: each builds a table
from the dict of tidy tables, or draws a figure, importing its module only when called (so
reading the registry costs no start-up time: importing every builder's module would cost about
1 s, scipy.stats' and statsmodels'), by an import statement that import-linter and refactoring
tools see.
"""

from __future__ import annotations

import functools
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


def rounded_table(exact: bool | str = False) -> Callable:
    """A table builder's decorator: its table re-indexed, then rounded as every table is rounded
    (``exact``: not, for a table whose numbers feed a recomputation; 'rotation': all but the
    rotation r11..r33, which another command applies).
    """

    def decorate(function: Callable) -> Callable:
        @functools.wraps(function)
        def build(data: dict):
            from aceval.data.contract import R_COLUMNS
            from aceval.report.kong2016 import rounded

            table = function(data).reset_index(drop=True)
            if exact is True:
                return table
            kept = [c for c in R_COLUMNS if c in table] if exact == "rotation" else []
            return rounded(table.drop(columns=kept)).join(table[kept])[table.columns]

        return build

    return decorate


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


# --- the tables built by one function of their module (its import in the builder) --------------


@rounded_table(exact=True)
def set_test_units(data: dict):
    """:func:`aceval.report.set_tests.set_test_units` of the data."""
    from aceval.report import set_tests

    return set_tests.set_test_units(
        data["sensor_sets"], data.get("correlations"), data.get("angles")
    )


@rounded_table()
def correlation_factors(data: dict):
    """:func:`aceval.report.kong2016.correlation_factors` of the data."""
    from aceval.report import kong2016

    return kong2016.correlation_factors(data["correlations"])


@rounded_table()
def correlation_sensitivity(data: dict):
    """:func:`aceval.report.kong2016.correlation_sensitivity` of the data."""
    from aceval.report import kong2016

    return kong2016.correlation_sensitivity(data["correlations"])


@rounded_table()
def variability_table(data: dict):
    """:func:`aceval.evaluation.variability.variability_table` of the data."""
    from aceval.evaluation import variability

    return variability.variability_table(data["calibrations"], data["angles"], data["correlations"])


@rounded_table()
def conditioning_table(data: dict):
    """:func:`aceval.evaluation.conditioning.conditioning_table` of the data."""
    from aceval.evaluation import conditioning

    return conditioning.conditioning_table(data["calibrations"])


@rounded_table()
def rho_table(data: dict):
    """:func:`aceval.report.ricci2014.rho_table` of the data."""
    from aceval.report import ricci2014

    return ricci2014.rho_table(data["axes"], data["paper_names"])


@rounded_table()
def supported_ttest(data: dict):
    """:func:`aceval.report.ricci2014.supported_ttest` of the data."""
    from aceval.report import ricci2014

    return ricci2014.supported_ttest(data["axes"])


@rounded_table()
def lm_table(data: dict):
    """:func:`aceval.report.ricci2014.lm_table` of the data."""
    from aceval.report import ricci2014

    return ricci2014.lm_table(data["calibrations"])


@rounded_table()
def residual_table(data: dict):
    """:func:`aceval.report.ricci2014.residual_table` of the data."""
    from aceval.report import ricci2014

    return ricci2014.residual_table(data["axes"], data["paper_names"])


@rounded_table(exact="rotation")
def decision_table(data: dict):
    """:func:`aceval.evaluation.decision.decision_table` of the data."""
    from aceval.evaluation import decision

    return decision.decision_table(
        data["calibrations"],
        data["test_retest_k"],
        data.get("retest_units"),
        data.get("tolerance_deg"),
    )


@rounded_table()
def methods_table(data: dict):
    """:func:`aceval.evaluation.methods_comparison.methods_table` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.methods_table(
        data["calibrations"], data["test_retest_k"], data.get("retest_units")
    )


@rounded_table()
def retest_table(data: dict):
    """:func:`aceval.evaluation.methods_comparison.retest_table` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.retest_table(
        data["calibrations"], data["test_retest_k"], data.get("retest_units")
    )


@rounded_table()
def uncertainty_table(data: dict):
    """:func:`aceval.evaluation.methods_comparison.uncertainty_table` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.uncertainty_table(data["calibrations"], data["truth_method"])


@rounded_table()
def flag_value_table(data: dict):
    """:func:`aceval.evaluation.flag_value.flag_value_table` of the data."""
    from aceval.evaluation import flag_value

    return flag_value.flag_value_table(data["calibrations"])


@rounded_table()
def best_tests(data: dict):
    """:func:`aceval.evaluation.methods_comparison.best_tests` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.best_tests(data["calibrations"])


@rounded_table()
def methods_ranking(data: dict):
    """:func:`aceval.evaluation.ranking.methods_ranking` of the data."""
    from aceval.evaluation import ranking

    return ranking.methods_ranking(data["calibrations"])


@rounded_table()
def truth_errors(data: dict):
    """:func:`aceval.evaluation.methods_comparison.truth_errors` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.truth_errors(data["calibrations"], data["truth_method"])


@rounded_table()
def loose_reference_angles(data: dict):
    """:func:`aceval.evaluation.methods_comparison.loose_reference_angles` of the data."""
    from aceval.evaluation import methods_comparison

    return methods_comparison.loose_reference_angles(data["calibrations"], data["loose_reference"])
