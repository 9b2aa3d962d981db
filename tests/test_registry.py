"""The registry of methods is the one source of what a method is: the worked example of
docs/architecture.md, "Add a method" (a method with a statistic of its own), added at run time,
turns with the sensor through the equivariance test unchanged, appears in every table, figure and
summary that shows the methods, in its registry place, leaves the other methods' calibrations as
they were, and says its cone is not validated; the registry's facts hold together."""

import dataclasses
import re
import sys

import numpy as np
import pandas as pd
import pytest

from aceval.methods import registry
from aceval.methods.interface import CalibrationMethod

from .runner import REPO

#: the example's place: after the gyroscope's axis methods
AFTER = "triad"


def _example_blocks() -> tuple[str, str]:
    """The two code blocks of docs/architecture.md's "Add a method": the module and its line."""
    text = (REPO / "docs" / "architecture.md").read_text()
    section = text[text.index("## Add a method") :]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    return blocks[0], blocks[1]


@pytest.fixture
def with_example(tmp_path, monkeypatch):
    """docs/architecture.md's example method, registered after TRIAD (its module written where
    Python finds it, its registry line as the doc writes it, pointed at that module)."""
    module, line = _example_blocks()
    (tmp_path / "doc_example_method.py").write_text(module)
    monkeypatch.syspath_prepend(str(tmp_path))
    entry = eval(line.strip().rstrip(","), {"Method": registry.Method})
    name = entry.implementation.split(":")[1]
    entry = dataclasses.replace(entry, implementation=f"doc_example_method:{name}")
    methods = list(registry.METHODS)
    methods.insert(registry.names().index(AFTER) + 1, entry)
    monkeypatch.setattr(registry, "METHODS", methods)
    yield entry
    sys.modules.pop("doc_example_method", None)


def test_the_example_turns_with_the_sensor_through_the_equivariance_test_unchanged(with_example):
    """Its statistic reaches the equivariance test's unit by its own reduce: no edit there."""
    from scipy.spatial.transform import Rotation

    from .test_equivariance import ROWS, body_unit, calibrations, sensor_unit, turned_by

    mounting = Rotation.from_euler("zyx", [30, -20, 110], degrees=True)
    found = calibrations(sensor_unit(body_unit(5), mounting.as_matrix()), ROWS)
    assert with_example.name in found and np.isfinite(found[with_example.name][0]).all()
    for seed in range(3):
        turn = Rotation.random(random_state=seed)
        turned_by(mounting.as_quat(), turn.as_quat(), seed, ROWS, resample=False)
        turned_by(mounting.as_quat(), turn.as_quat(), seed, [[2, 1, 0], [1, 1, 1]], resample=True)


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


def _calibrate(data, out) -> tuple[dict, pd.DataFrame]:
    """``aceval calibrate`` of ``data`` into the folder ``out``: its files and calibrations."""
    from aceval.cli import main

    files = {k: str(out / f"{k}.csv") for k in ("cal", "axes", "angles", "retest", "corr")}
    out.mkdir()
    code = main(
        ["calibrate", str(data), "--out", files["cal"], "--axes-out", files["axes"]]
        + ["--angles-out", files["angles"], "--retest-out", files["retest"]]
        + ["--correlations-out", files["corr"]]
    )
    assert code == 0
    return files, pd.read_csv(files["cal"], low_memory=False)


@pytest.mark.slow  # simulates, calibrates twice and writes a results folder (about 30 s)
def test_a_method_added_to_the_registry_appears_in_every_table_figure_and_summary(
    with_example, tmp_path, monkeypatch
):
    from aceval.calibrate.pipeline import NOT_VALIDATED
    from aceval.cli import main

    name, data = with_example.name, tmp_path / "sim"
    assert (
        main(["simulate", "kong", "--out", str(data), "--subjects", "1", "--repetitions", "4"]) == 0
    )
    assert name in __import__("aceval.commands").commands.method_choices()
    files, calibrations = _calibrate(data, tmp_path / "out")
    mine = calibrations[calibrations["method"] == name]
    full = mine[mine["n_reps"] == 4]
    assert len(full) and np.isfinite(full["cone_deg"]).all() and (full["spread95_deg"] > 0).all()
    assert (full["cone_fit"] == NOT_VALIDATED).all()  # no fitted cone factor: it says so
    others = calibrations[calibrations["method"] != name]
    assert NOT_VALIDATED not in set(others["cone_fit"].dropna())
    # its diagnostics column sits with its place: after the axis methods', before combined's
    columns = list(calibrations.columns)
    assert columns.index("cost") < columns.index("gyro_pca_ratio")
    assert columns.index("gyro_pca_ratio") < columns.index("weight_kong")
    # the other methods' calibrations, flags and cones are the ones made without it
    with monkeypatch.context() as without:
        without.setattr(registry, "METHODS", [m for m in registry.METHODS if m.name != name])
        _, before = _calibrate(data, tmp_path / "without")
    assert set(others.columns) - set(before.columns) == {"gyro_pca_ratio"}
    pd.testing.assert_frame_equal(
        others[before.columns].reset_index(drop=True), before.reset_index(drop=True)
    )
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
        assert name in set(rows["method"]), table
        cell = [
            c for c in ("segment", "test", "sensor_set") if c in rows and table != "methods_best"
        ]
        for _, group in rows.groupby(
            cell or ["segment"], sort=False
        ):  # each cell in registry order
            shown = list(group["method"])
            assert shown == sorted(shown, key=registry.rank), (table, shown)
    # the gyroscope's principal axis of a leg swing is body y to within the mountings' noise
    assert full["error_deg"].median() < 10.0
    (legend,) = [texts for texts in legends if "step_harmonic" in texts]  # the methods figure
    drawn = [m for m in legend if m in registry.names()]
    assert name in drawn and drawn == sorted(drawn, key=registry.rank)
    assert name in (results / "SUMMARY.md").read_text()


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


def test_each_signal_has_one_declared_cone_reference_of_that_signal():
    references = registry.cone_references()
    assert {"acc", "gyr", "step"} <= set(references)
    classes = registry.classes()
    assert all(classes[name].signal == signal for signal, name in references.items())


def test_every_method_writes_the_diagnostics_it_declares_and_no_other():
    """The calibrations table's columns of a method are its class's ``diagnostics``: what its fit
    writes (on a walking unit, every row kind) it declares (Ricci's LM declares the random
    starts of the functional design too)."""
    from aceval.methods.sufficient import pool

    from .test_equivariance import ROWS, body_unit, sensor_unit

    units = sensor_unit(body_unit(1), np.eye(3))
    weights = np.asarray(ROWS, float)
    pooled = pool(units, np.zeros(len(weights), int), weights)
    classes = registry.classes()
    fitted = {}
    for name in registry.fit_order(classes):
        fitted[name] = classes[name]().fit(pooled, fitted)
        written = set(fitted[name].diagnostics_)
        assert written <= set(classes[name].diagnostics), (name, written)
        assert bool(written) == bool(classes[name].diagnostics), name
