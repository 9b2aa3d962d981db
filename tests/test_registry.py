"""The registry of methods is the one source of what a method is (issue 38): the worked example of
docs/architecture.md, "Add a method", added at run time, appears in every table, figure and
summary that shows the methods, in its registry place; the registry's facts hold together."""

import dataclasses
import re
import sys

import numpy as np
import pandas as pd
import pytest

from aceval.methods import registry
from aceval.methods.interface import CalibrationMethod

from .runner import REPO


def _example_blocks() -> tuple[str, str]:
    """The two code blocks of docs/architecture.md's "Add a method": the module and its line."""
    text = (REPO / "docs" / "architecture.md").read_text()
    section = text[text.index("## Add a method") :]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    return blocks[0], blocks[1]


@pytest.fixture
def with_identity(tmp_path, monkeypatch):
    """docs/architecture.md's example method, registered before the peers (its module written
    where Python finds it, its registry line as the doc writes it, pointed at that module)."""
    module, line = _example_blocks()
    (tmp_path / "doc_identity_method.py").write_text(module)
    monkeypatch.syspath_prepend(str(tmp_path))
    entry = eval(line.strip().rstrip(","), {"Method": registry.Method})
    entry = dataclasses.replace(entry, implementation="doc_identity_method:Identity")
    methods = list(registry.METHODS)
    methods.insert(registry.names().index("step_harmonic") + 1, entry)
    monkeypatch.setattr(registry, "METHODS", methods)
    yield entry
    sys.modules.pop("doc_identity_method", None)


def _legends(monkeypatch) -> list[list[str]]:
    """Every figure's legend texts, in the order the figures are saved."""
    from aceval.report import figures

    seen: list[list[str]] = []
    save = figures._save

    def recording(figure, out):
        legends = list(figure.legends) + [ax.get_legend() for ax in figure.axes if ax.get_legend()]
        seen.append([text.get_text() for legend in legends for text in legend.get_texts()])
        save(figure, out)

    monkeypatch.setattr(figures, "_save", recording)
    return seen


@pytest.mark.slow  # simulates, calibrates and writes a results folder (about 20 s)
def test_a_method_added_to_the_registry_appears_in_every_table_figure_and_summary(
    with_identity, tmp_path, monkeypatch
):
    from aceval.cli import main

    data, out = tmp_path / "sim", tmp_path / "out"
    assert (
        main(["simulate", "kong", "--out", str(data), "--subjects", "1", "--repetitions", "4"]) == 0
    )
    assert "identity" in __import__("aceval.commands").commands.method_choices()
    files = {k: str(out / f"{k}.csv") for k in ("cal", "axes", "angles", "retest", "corr")}
    out.mkdir()
    code = main(
        ["calibrate", str(data), "--out", files["cal"], "--axes-out", files["axes"]]
        + ["--angles-out", files["angles"], "--retest-out", files["retest"]]
        + ["--correlations-out", files["corr"]]
    )
    assert code == 0
    calibrations = pd.read_csv(files["cal"], low_memory=False)
    identity = calibrations[calibrations["method"] == "identity"]
    assert len(identity) and np.allclose(
        identity[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(),
        np.eye(3).ravel(),
    )
    full = identity[identity["n_reps"] == 4]
    assert len(full) and (full["spread95_deg"] == 0).all()  # it resamples: every resample gives I
    legends = _legends(monkeypatch)
    results = tmp_path / "results"
    code = main(
        ["outputs", "--dataset", str(data), "--results", str(results)]
        + ["--analyses", "kong", "methods", "retest", "--calibrations", files["cal"]]
        + ["--axes", files["axes"], "--angles", files["angles"]]
        + ["--retest-units", files["retest"], "--correlations", files["corr"]]
    )
    assert code == 0
    for table in ("methods", "methods_retest", "methods_best"):
        rows = pd.read_csv(results / "tables" / f"{table}.csv")
        # methods_best lists a method's unflagged calibrations only: the identity has none
        assert ("identity" in set(rows["method"])) == (table != "methods_best"), table
        cell = [
            c for c in ("segment", "test", "sensor_set") if c in rows and table != "methods_best"
        ]
        for _, group in rows.groupby(
            cell or ["segment"], sort=False
        ):  # each cell in registry order
            shown = list(group["method"])
            assert shown == sorted(shown, key=registry.rank), (table, shown)
    # the identity is wrong by the simulated mountings (10 deg spread): its error is no small
    # one, and the gates catch it: every calibration is flagged (right_axis_mismatch where its y
    # axis is not the declared right; methods_disagree where it is far from the other methods')
    assert full["error_deg"].min() > 10.0
    errors = pd.read_csv(results / "tables" / "methods.csv")
    mine = errors[errors["method"] == "identity"]
    assert len(mine) and (mine["n"] == 0).all() and (mine["n_calibrations"] > 0).all()
    assert mine["flags"].str.contains("methods_disagree").any()
    assert mine["flags"].str.contains("right_axis_mismatch").any()
    (legend,) = [texts for texts in legends if "step_harmonic" in texts]  # the methods figure
    # the figure draws unflagged calibrations only, in the registry's order: the identity has none
    assert "identity" not in legend
    drawn = [m for m in legend if m in registry.names()]
    assert drawn == sorted(drawn, key=registry.rank) and "step_harmonic" in drawn
    assert "identity" in (results / "SUMMARY.md").read_text()


def test_every_method_of_aceval_is_a_class_with_the_interface_and_every_name_is_unique():
    assert len(set(registry.names())) == len(registry.METHODS)
    for name, cls in registry.classes().items():
        assert issubclass(cls, CalibrationMethod), name
        assert cls.fit is not CalibrationMethod.fit, name
        assert set(cls.needs) <= set(registry.own()), name
        assert registry.method(name).peer is None
    for name, peer in registry.peers().items():
        assert (REPO / "workflow" / "peers" / peer.adapter).is_file(), name
        assert (REPO / "workflow" / "peers" / f"{peer.environment}.txt").is_file(), name
    order = registry.fit_order(registry.classes())
    for name, cls in registry.classes().items():
        assert all(order.index(n) < order.index(name) for n in cls.needs)


def test_the_fit_order_follows_needs_not_the_registry_order(monkeypatch):
    """A method listed before the one it needs is fitted after it; a circle is refused."""

    class First(CalibrationMethod):
        needs = ("second",)

    class Second(CalibrationMethod):
        pass

    assert registry.fit_order({"first": First, "second": Second}) == ["second", "first"]

    class Circle(CalibrationMethod):
        needs = ("circle",)

    with pytest.raises(ValueError, match="circle"):
        registry.fit_order({"circle": Circle})


def test_the_registry_reads_without_numpy():
    """The workflow reads the peers from the registry at every start: it must not import the
    methods (NumPy, SciPy, pandas)."""
    import subprocess

    code = "import sys, aceval.methods.registry as r; r.peers(); print('numpy' in sys.modules)"
    found = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert found.stdout.strip() == "False"


def test_no_module_picks_a_method_by_a_literal_name():
    """Facts about methods live in the registry: outside it (and a method's own module, which
    names the methods it needs), no module of the package compares a ``method`` with a literal
    name or defaults to one (they ask the registry: ``registry.paper_method('kong2016')``, the
    peers' facts, the order)."""
    names = "|".join(map(re.escape, registry.names()))
    picks = re.compile(
        rf"method\"?\]?\s*(==|!=|=|:\s*str\s*=)\s*[\"']({names})[\"']"
        rf"|isin\(\[?[\"']({names})[\"']"
    )
    own = {registry.method(n).implementation.split(":")[0] for n in registry.own()}
    found = []
    for path in (REPO / "src" / "aceval").rglob("*.py"):
        module = ".".join(path.relative_to(REPO / "src").with_suffix("").parts)
        if module in own | {"aceval.methods.registry"}:
            continue
        found += [f"{module}: {m.group(0)}" for m in picks.finditer(path.read_text())]
    assert not found, found
