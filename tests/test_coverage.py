"""The cone model's coverage study (aceval.evaluation.coverage, cone_fit): its committed tables
follow from its committed rows, the constants in the code are the study's, and
``heading_undetermined`` is exactly the rows whose cone is no cone."""

import numpy as np
import pandas as pd
import pytest

from aceval.evaluation.cone_fit import cones_of, criteria, judged, usable
from aceval.evaluation.coverage import _coverage, judge, model_of
from aceval.methods.uncertainty import CONE_MODEL

from .runner import REPO

STUDY = REPO / "results" / "coverage"


def _committed():
    return (
        pd.read_csv(STUDY / "rows.csv.gz", low_memory=False),
        pd.read_csv(STUDY / "model.csv"),
        pd.read_csv(STUDY / "coverage.csv"),
    )


def test_the_constants_in_the_code_are_the_committed_studys():
    _, models, _ = _committed()
    fitted = model_of(models, "all")
    for name in ("signals", "tests", "conditioning", "q_other"):
        assert getattr(CONE_MODEL, name) == pytest.approx(getattr(fitted, name), abs=5e-3), name
    assert set(CONE_MODEL.q) == set(fitted.q)
    for method, q in fitted.q.items():
        assert CONE_MODEL.q[method] == pytest.approx(q, abs=5e-3), method


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
    # pooled over methods, every left-out variant is covered 85-100 %
    assert every["coverage"].between(0.85, 1.0).all()
    real = coverage[coverage["study"] == "real truths pooled (each left out)"].set_index("method")
    assert real.loc["all", "n"] >= 40
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
