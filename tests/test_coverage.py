"""The cone model's coverage study (aceval.evaluation.coverage, cone_fit): its committed tables
follow from its committed rows, the constants in the code are the study's, and
``heading_undetermined`` is exactly the rows whose cone is no cone."""

import numpy as np
import pandas as pd
import pytest

from aceval.evaluation.cone_fit import (
    WEIGHTS,
    cones_of,
    criteria,
    factors,
    fit_cone_model,
    goal,
    judged,
    usable,
)
from aceval.evaluation.coverage import _coverage, judge, model_of
from aceval.methods.uncertainty import (
    CONE_MODEL,
    LEFT_OUT,
    TILT_SD_DEG,
    Z95,
    ConeModel,
    cone_model,
)

from .runner import REPO

STUDY = REPO / "results" / "coverage"


def _committed():
    return (
        pd.read_csv(STUDY / "rows.csv.gz", low_memory=False),
        pd.read_csv(STUDY / "model.csv"),
        pd.read_csv(STUDY / "coverage.csv"),
    )


@pytest.mark.parametrize("dataset", [None, *LEFT_OUT])
def test_the_constants_in_the_code_are_the_committed_studys(dataset):
    """CONE_MODEL is the fit on everything; a real truth's dataset gets the fit without it."""
    _, models, _ = _committed()
    fit, model = cone_model(dataset) if dataset else ("all", CONE_MODEL)
    assert fit == ("all" if dataset is None else f"left out: {dataset}")
    fitted = model_of(models, fit)
    for name in ("signals", "tests", "conditioning", "q_other"):
        assert getattr(model, name) == pytest.approx(getattr(fitted, name), abs=5e-3), name
    assert set(model.q) == set(fitted.q)
    for method, q in fitted.q.items():
        assert model.q[method] == pytest.approx(q, abs=5e-3), method
    assert cone_model("my_lab") == ("all", CONE_MODEL)


def test_a_methods_factor_is_its_95th_percentile_of_error_over_rms_every_dataset_alike():
    """Two datasets of 1 and 19 rows: weighing alike, the lone row carries half the weight (a
    row-weighted quantile would give the 19 rows' 95th percentile); every term counts at its size
    (weights 1), so a disagreement of 3 deg adds 3 deg in quadrature."""
    rows = pd.DataFrame(
        {
            "dataset": ["small"] + ["big"] * 19,
            "kind": "simulated",
            "segment": "thigh",
            "method": "kong",
            "error_deg": [100.0] + list(np.linspace(0.1, 1.9, 19)),
            "truth_uncertainty_deg": np.nan,
            "spread95_deg": Z95,  # a spread term of 1 deg
            "heading_signals_deg": 3.0,
            "heading_tests_deg": np.nan,
            "conditioning_deg": np.nan,
        }
    )
    rms = np.sqrt(1.0 + TILT_SD_DEG**2 + 3.0**2)
    assert cones_of(rows, ConeModel(**WEIGHTS, q={}, q_other=1.0)) == pytest.approx(rms)
    assert factors(rows) == {"kong": pytest.approx(100.0 / rms)}
    assert factors(rows[rows["dataset"] == "big"]) == {"kong": pytest.approx(1.9 / rms)}
    model = fit_cone_model(rows)
    assert model.q_other == model.q["kong"] and (model.signals, model.tests) == (1.0, 1.0)


def test_the_goal_says_by_name_what_a_cone_misses():
    assert goal(0.95, 2.5) == "met"
    assert goal(0.684, 1.3) == "not met: coverage 68% below 90%"
    assert goal(1.0, 3.2) == (
        "not met: coverage 100% above 99%; median cone 3.2 times the median error, above 3"
    )


def test_each_left_out_coverage_follows_from_the_rows_and_that_folds_constants():
    """Every study of coverage.csv recomputed from rows.csv.gz with the constants model.csv
    gives for that fit (the fit itself: the slow test below)."""
    rows, models, coverage = _committed()
    rows = usable(rows)
    for study, table in coverage.groupby("study", sort=False):
        if study.startswith("real truths pooled"):
            fits = [f for f in models["fit"] if f.startswith("left out: ")]
            parts = [
                judged(mine, cones_of(mine, model_of(models, fit)))
                for fit in fits
                if len(mine := rows[rows["dataset"] == fit.removeprefix("left out: ")])
                and (mine["kind"] == "real").all()
            ]
            data = pd.concat(parts)
        elif study == "all (as fitted)":
            data = judged(rows, cones_of(rows, model_of(models, "all")))
        elif study.startswith("as fitted: "):
            mine = rows[rows["dataset"] == study.removeprefix("as fitted: ")]
            data = judged(mine, cones_of(mine, model_of(models, "all")))
        else:
            mine = rows[rows["dataset"] == study.removeprefix("left out: ")]
            data = judged(mine, cones_of(mine, model_of(models, study)))
        again = _coverage(data.assign(study=study)).set_index("method")
        table = table.set_index("method")
        for column in ("n", "n_undetermined", "coverage", "cone_median_deg", "error_median_deg"):
            assert again[column].to_numpy(float) == pytest.approx(
                table.loc[again.index, column].to_numpy(float), abs=1e-3
            ), (study, column)


def test_the_studys_claims_hold_where_docs_say_so():
    """docs/uncertainty.md's verdicts, checked from the committed coverage: what the cone
    reaches and what it does not (a changed study fails here until the docs say what it shows)."""
    _, _, coverage = _committed()
    left_out = coverage[coverage["study"].str.startswith("left out: ")]
    simulated = left_out[~left_out["study"].isin(["left out: neura", "left out: gaitmap_feet"])]
    every = simulated[simulated["method"] == "all"]
    # pooled over methods, every left-out variant is covered 90-99 %; seven of nine meet the
    # goal, twice the off-plane motion and half the sensor bias have cones above 3 x the error
    assert every["coverage"].between(0.90, 0.99).all()
    assert (every["goal"] == "met").sum() == 7
    assert every.loc[every["goal"] != "met", "goal"].str.contains("median cone").all()
    real = coverage[coverage["study"] == "real truths pooled (each left out)"].set_index("method")
    assert real.loc["all", "n"] >= 40
    # each real truth left out: covered at least 90 %, its cone at most 3 x its error
    for name in ("neura", "gaitmap_feet"):
        row = coverage.set_index(["study", "method"]).loc[(f"left out: {name}", "all")]
        assert row["coverage"] >= 0.9 and row["cone_over_error"] <= 3.0, name
    # no row whose cone is beyond 90 deg is counted
    assert (coverage["n_undetermined"] >= 0).all()


@pytest.mark.slow
def test_the_committed_study_is_what_its_rows_give():
    """The whole fit again (every fold) from the committed rows: the committed constants and
    coverage come back."""
    rows, models, coverage = _committed()
    again_models, again = judge(rows)
    pd.testing.assert_frame_equal(
        again_models.round(3).reset_index(drop=True),
        models.round(3).reset_index(drop=True),
        check_dtype=False,
    )
    assert again["coverage"].to_numpy() == pytest.approx(coverage["coverage"].to_numpy(), abs=1e-3)


@pytest.mark.slow
def test_heading_undetermined_is_exactly_the_rows_without_a_cone(regenerated):
    """On every regenerated dataset: a calibration from all repetitions with a rotation and a
    cone column is flagged heading_undetermined where (and only where) its cone is beyond 90
    deg or its spread could not be estimated; and such a row is never counted covered."""
    from aceval.calibrate.table import full_set_rows, has_flag, matrices
    from aceval.methods.uncertainty import undetermined

    checked = flagged = 0
    others = ("_angles", "_axes", "_pairs", "_recordings", "_retest")
    for folder in sorted((regenerated.workdir / "results").glob("*/calibrations")):
        tables = [p for p in folder.glob("*.csv") if not p.stem.endswith(others)]
        calibrations = full_set_rows(pd.concat([pd.read_csv(p, low_memory=False) for p in tables]))
        if "cone_deg" not in calibrations:
            continue
        rows = calibrations[
            calibrations["method"].isin(list(CONE_MODEL.q))
            & np.isfinite(matrices(calibrations)).all(axis=(1, 2))
        ]
        lost = undetermined(rows["cone_deg"], rows["spread95_deg"])
        assert (has_flag(rows["flag"], "heading_undetermined").to_numpy() == lost).all(), folder
        checked += len(rows)
        flagged += int(lost.sum())
    assert checked > 1000 and flagged > 0


def test_criteria_count_an_undetermined_row_apart_never_covered():
    rows = pd.DataFrame(
        {
            "dataset": "d",
            "kind": "simulated",
            "subject": ["a", "b", "c"],
            "segment": "thigh",
            "test": "T6",
            "method": "kong",
            "error_deg": [1.0, 5.0, 2.0],
            "truth_uncertainty_deg": np.nan,
            "spread95_deg": [1.0, 1.0, 180.0],
        }
    )
    data = judged(rows, np.array([2.0, 2.0, 170.0]))
    table = criteria(data, ["dataset"]).iloc[0]
    assert table["n"] == 2 and table["n_undetermined"] == 1 and table["coverage"] == 0.5
