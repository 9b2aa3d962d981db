"""The cone model's coverage study (beyond the papers): its constants fitted across simulator
variants and real truths, and its coverage on what each fit did not see.

A cone (:mod:`aceval.methods.uncertainty`) adds what the recording shows of a calibration's
uncertainty; one factor per method turns it into a 95 % cone, split-conformally
(:mod:`aceval.evaluation.cone_fit`). The study:

1. calibrates Kong's protocol simulated under each of :data:`VARIANTS` (seeds :data:`SEEDS`,
   :data:`N_SUBJECTS` subjects each: the simulator's effects halved and doubled, 3 and 10
   repetitions, the walk's variability as assumed before it was measured, and a walk whose
   planarity sits in the real recordings' range) and the real datasets with a marker-based truth
   given on the command line (NeuRA, gaitmap_feet: their truth's own uncertainty allowed for);
2. fits the constants on all of them (the committed :data:`aceval.methods.uncertainty.CONE_MODEL`);
3. leaves each variant out in turn (fitted on the others and the real truths, judged on it), and
   each real dataset (fitted on every variant and the other real dataset, judged on it; the two
   judged together: the real truths pooled), against :data:`aceval.evaluation.cone_fit.GOAL`
   (column ``goal``: 'met', or what is missed). The fits without each real dataset are the
   constants that dataset's own calibrations get (:data:`aceval.methods.uncertainty.LEFT_OUT`).

``python -m aceval.evaluation.coverage study --real resources/neura resources/gaitmap_feet``
(the datasets the workflow imports) writes ``results/coverage/``: ``rows.csv.gz`` (every row the
study judges, with its terms), ``model.csv`` (the constants of each fit), ``coverage.csv`` and
``coverage.md``; ``python -m aceval.evaluation.coverage judge`` redoes steps 2-3 from the
committed rows (seconds; tests/test_coverage.py checks the committed tables and the constants in
the code against them).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.calibrate.pipeline import calibrate
from aceval.calibrate.table import full_set_rows
from aceval.data.dataset import load_dataset
from aceval.evaluation.cone_fit import (
    ROW_COLUMNS,
    cones_of,
    criteria,
    fit_cone_model,
    goal,
    judged,
    usable,
)
from aceval.evaluation.methods_comparison import with_truth
from aceval.evaluation.stats import coverage_interval
from aceval.methods.uncertainty import ConeModel
from aceval.signals.reduction import reduce_recordings
from aceval.simulate.kong_dataset import simulate_kong
from aceval.simulate.options import SimOptions

#: the simulator's variants (the committed kong_sim is 'as committed' at seed 0)
VARIANTS = {
    "as committed": SimOptions(),
    "off-plane motion x0.5": SimOptions(offplane=0.5),
    "off-plane motion x2": SimOptions(offplane=2.0),
    "sensor bias x0.5": SimOptions(sensor_bias=0.5),
    "sensor bias x2": SimOptions(sensor_bias=2.0),
    "3 repetitions": SimOptions(repetitions=3),
    "10 repetitions": SimOptions(repetitions=10),
    "walk variability assumed": SimOptions(variability="assumed"),
    "walk as planar as real": SimOptions(impacts=1.0),
}
SEEDS = (301, 302)
N_SUBJECTS = 5
RESULTS = Path("results/coverage")


def _rows(calibrations: pd.DataFrame, dataset: str, kind: str, sheet=None) -> pd.DataFrame:
    """The study's columns of a dataset's calibrations from all repetitions (with a truth)."""
    full = full_set_rows(calibrations).assign(dataset=dataset, kind=kind)
    full = full.assign(subject=f"{dataset}:" + full["subject"].astype(str))
    if sheet is not None and "truth_uncertainty_deg" in sheet:
        truth = sheet.assign(subject=f"{dataset}:" + sheet["subject"].astype(str))
        full = full.merge(
            truth[["subject", "sensor_set", "imu", "truth_uncertainty_deg"]],
            on=["subject", "sensor_set", "imu"],
            how="left",
        )
    full = full.reindex(columns=ROW_COLUMNS)
    return full[np.isfinite(full["spread95_deg"].astype(float))]


def _calibrated(root: Path) -> pd.DataFrame:
    """Every method's calibrations from all repetitions of a dataset, with their error."""
    dataset = load_dataset(root)
    summaries = pd.concat(
        [reduce_recordings(dataset, subject).summaries for subject in dataset.subjects.index],
        ignore_index=True,
    )
    calibrations, _ = calibrate(dataset, summaries, subsets="full", retest_k=None)
    return with_truth(calibrations, dataset.ground_truth)


def simulated_rows(name: str, seed: int, workdir: Path) -> pd.DataFrame:
    """The study's rows of one variant and seed."""
    options = replace(VARIANTS[name], jobs=1)
    root = simulate_kong(workdir / f"kong_{seed}", seed, N_SUBJECTS, options)
    return _rows(_calibrated(root), f"{name} / {seed}", "simulated").assign(dataset=name)


def real_rows(root: Path) -> pd.DataFrame:
    """The study's rows of a real dataset with a marker-based truth (ground_truth_method.tsv)."""
    sheet_path = Path(root) / "ground_truth_method.tsv"
    sheet = pd.read_csv(sheet_path, sep="\t") if sheet_path.is_file() else None
    return _rows(_calibrated(Path(root)), load_dataset(root).name, "real", sheet)


def study_rows(real: list[Path], workdir: Path) -> pd.DataFrame:
    """Every variant's and real dataset's rows."""
    parts = []
    for name in VARIANTS:
        for seed in SEEDS:
            parts.append(simulated_rows(name, seed, workdir))
            print(f"coverage: {name}, seed {seed}", file=sys.stderr)
    parts += [real_rows(root) for root in real]
    return pd.concat(parts, ignore_index=True)


def walk_variability(name: str, seeds=(12, 13), n_subjects: int = 3) -> pd.DataFrame:
    """How variable a variant's walk is, measured as on the real recordings
    (:func:`aceval.evaluation.variability.variability_table`, T6): per seed, statistic and
    segment the median over the subjects (docs/simulation.md quotes the walk as planar as real).
    """
    from aceval.evaluation.correlations import correlations
    from aceval.evaluation.objectives import all_angles
    from aceval.evaluation.variability import variability_table

    parts = []
    for seed in seeds:
        with tempfile.TemporaryDirectory(prefix="aceval-walk-") as tmp:
            options = replace(VARIANTS[name], jobs=1)
            dataset = load_dataset(simulate_kong(Path(tmp) / "kong", seed, n_subjects, options))
            reduced = [reduce_recordings(dataset, s, tests=["T6"]) for s in dataset.subjects.index]
            summaries = pd.concat([r.summaries for r in reduced], ignore_index=True)
            pairs = pd.concat([r.pairs for r in reduced], ignore_index=True)
            calibrations, _ = calibrate(dataset, summaries, subsets="all", retest_k=3)
            table = variability_table(
                calibrations,
                all_angles(calibrations),
                correlations(dataset, calibrations, pairs, headings_deg=()),
            )
        medians = table.groupby(["statistic", "test", "segment"])["value"].median()
        parts.append(medians.rename("value").reset_index().assign(seed=seed))
    return pd.concat(parts, ignore_index=True).pivot_table(
        index=["statistic", "test", "segment"], columns="seed", values="value"
    )


def judge(rows: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(models, coverage)``: the constants of every fit and the coverage of each on what it
    did not see (module docstring, steps 2-3).
    """
    rows = usable(rows)
    fits = {"all": fit_cone_model(rows)}
    judged_parts = []
    for name in rows.loc[rows["kind"] == "simulated", "dataset"].unique():
        fits[f"left out: {name}"] = model = fit_cone_model(rows[rows["dataset"] != name])
        mine = rows[rows["dataset"] == name]
        judged_parts.append(judged(mine, cones_of(mine, model)).assign(study=f"left out: {name}"))
    real = []
    for name in rows.loc[rows["kind"] == "real", "dataset"].unique():
        fits[f"left out: {name}"] = model = fit_cone_model(rows[rows["dataset"] != name])
        mine = rows[rows["dataset"] == name]
        real.append(judged(mine, cones_of(mine, model)).assign(study=f"left out: {name}"))
    if real:
        judged_parts += real
        judged_parts.append(pd.concat(real).assign(study="real truths pooled (each left out)"))
    every = rows.assign(study="all (as fitted)")
    judged_parts.append(judged(every, cones_of(every, fits["all"])))
    for name in rows.loc[rows["kind"] == "real", "dataset"].unique():  # in-sample, for contrast
        mine = rows[rows["dataset"] == name].assign(study=f"as fitted: {name}")
        judged_parts.append(judged(mine, cones_of(mine, fits["all"])))
    coverage = pd.concat([_coverage(part) for part in judged_parts], ignore_index=True)
    models = pd.DataFrame(
        [
            {"fit": name, **{k: v for k, v in asdict(model).items() if k != "q"}, **model.q}
            for name, model in fits.items()
        ]
    )
    return models, coverage


def _coverage(data: pd.DataFrame) -> pd.DataFrame:
    """Per method and over all methods: :func:`aceval.evaluation.cone_fit.criteria` with the
    subject-resampled 95 % interval of the coverage (binomial with few subjects).
    """
    data = pd.concat([data, data.assign(method="all")], ignore_index=True)
    table = criteria(data, ["study", "method"])
    kept = data[~data["undetermined"]]
    intervals = {
        key: coverage_interval(group["hit"], group["subject"])
        for key, group in kept.groupby(["study", "method"], sort=False)
    }
    table["coverage_low"] = [intervals[k][0] for k in zip(table["study"], table["method"])]
    table["coverage_high"] = [intervals[k][1] for k in zip(table["study"], table["method"])]
    table["n_subjects"] = [
        kept.loc[(kept["study"] == s) & (kept["method"] == m), "subject"].nunique()
        for s, m in zip(table["study"], table["method"])
    ]
    table["goal"] = [goal(c, r) for c, r in zip(table["coverage"], table["cone_over_error"])]
    return table


def model_of(models: pd.DataFrame, fit: str = "all") -> ConeModel:
    """The :class:`ConeModel` of one row of ``model.csv``."""
    row = models.set_index("fit").loc[fit]
    scalar = ["signals", "tests", "conditioning", "q_other"]
    q = {k: float(v) for k, v in row.drop(scalar).items() if np.isfinite(v)}
    return ConeModel(**{k: float(row[k]) for k in scalar}, q=q)


def write(out: Path, rows: pd.DataFrame | None, models, coverage) -> None:
    """The study's files in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    if rows is not None:
        rows.to_csv(out / "rows.csv.gz", index=False, float_format="%.5g")
    models.to_csv(out / "model.csv", index=False, float_format="%.6f")
    coverage.to_csv(out / "coverage.csv", index=False, float_format="%.4f")
    (out / "coverage.md").write_text(_markdown(models, coverage))


def main(argv: list[str] | None = None) -> int:
    """``study``: simulate, calibrate, fit and judge; ``judge``: fit and judge the committed
    rows again; ``walk``: a variant's walking variability (:func:`walk_variability`).
    """
    parser = argparse.ArgumentParser(prog="python -m aceval.evaluation.coverage")
    parser.add_argument("what", choices=["study", "judge", "walk"])
    parser.add_argument("--variant", default="walk as planar as real", help="walk: the variant")
    parser.add_argument("--real", nargs="*", default=[], help="imported datasets with a truth")
    parser.add_argument("--out", default=str(RESULTS), help="the folder written")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if args.what == "walk":
        print(walk_variability(args.variant).round(3).to_string())
        return 0
    if args.what == "study":
        with tempfile.TemporaryDirectory(prefix="aceval-coverage-") as tmp:
            rows = study_rows([Path(r) for r in args.real], Path(tmp))
    else:
        rows = pd.read_csv(out / "rows.csv.gz")
    models, coverage = judge(rows)
    write(out, rows if args.what == "study" else None, models, coverage)
    print(coverage.round(3).to_string(index=False))
    return 0


def _markdown(models: pd.DataFrame, coverage: pd.DataFrame) -> str:
    variants = ", ".join(VARIANTS)
    return (
        "# The cone's coverage on what each fit did not see\n\n"
        f"Simulated variants ({variants}; seeds {', '.join(map(str, SEEDS))}, {N_SUBJECTS} "
        "simulated subjects each) and the real truths of NeuRA and gaitmap_feet. Each variant "
        "is judged by the constants fitted without it (and with the real truths), each real "
        "dataset by those fitted on every variant and the other real dataset. Coverage: the "
        "share of the unflagged calibrations from all repetitions whose error to the truth (on "
        "real data: minus the truth's own uncertainty) is inside their cone; cones beyond 90 "
        "deg are `heading_undetermined`, left out (`n_undetermined`) and never counted covered; "
        "interval from 1,000 resamples of the subjects (binomial with fewer than 5). The fit: "
        "every term at its own size, and per method the 95th percentile of the error over the "
        "cone on the datasets the fit sees, each weighing alike (split-conformal). Goal on a "
        "dataset left out: covered 90-99 %, median cone at most 3 times the median error "
        "(column `goal`). Made by "
        "`python -m aceval.evaluation.coverage study --real resources/neura "
        "resources/gaitmap_feet`.\n\n## The constants of each fit\n\n"
        + models.round(3).to_markdown(index=False)
        + "\n\n## Coverage\n\n"
        + coverage.round(3).to_markdown(index=False)
        + "\n"
    )


if __name__ == "__main__":
    sys.exit(main())
