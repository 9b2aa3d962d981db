"""The uncertainty model's training and its coverage study (beyond the papers; issue 28).

A calibration's error against the truth has three parts that the model adds
(:mod:`aceval.methods.uncertainty`): the spread between its repetitions (the bootstrap), the tilt
from the accelerometer's constant bias in quiet standing (a datasheet value), and a heading bias
that every repetition shares, which no resampling of them can see: how far a test's motion leaves
the segment's sagittal plane. That last part, ``tau`` per method, test and segment, and the
factor ``q`` that turns the combined RMS into a 95 % cone, are learned here from simulations of
Kong's protocol with other seeds than the committed datasets' (:data:`TRAINING_SEEDS`).

The study then measures the cone's coverage (the share of calibrations whose error to the truth
is inside it) with subject-resampled 95 % intervals on fresh seeds (:data:`TEST_SEEDS`) and on
the simulator with its off-plane motion and its sensor biases halved and doubled
(:data:`VARIANTS`): a model learned from a simulator depends on it, and these say how much. The
committed datasets' and the real sensors' coverage are in their ``uncertainty`` tables.

``python -m aceval.evaluation.coverage fit`` writes the model
(``src/aceval/methods/cone_model.csv``); ``python -m aceval.evaluation.coverage study`` writes
``results/coverage/coverage.csv`` and ``.md`` (docs/uncertainty.md quotes them).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.calibrate.pipeline import calibrate
from aceval.calibrate.table import full_set_rows, unflagged
from aceval.data.dataset import load_dataset
from aceval.evaluation.methods_comparison import uncertainty_table, with_truth
from aceval.methods.uncertainty import MODEL_PATH, fit_model, model_cones
from aceval.signals.reduction import reduce_recordings
from aceval.simulate.kong_dataset import simulate_kong
from aceval.simulate.options import SimOptions

#: simulations the model learns from (the committed kong_sim is seed 0, box_sim and ricci_sim
#: have protocols of their own)
TRAINING_SEEDS = tuple(range(101, 109))
#: simulations it is tested on
TEST_SEEDS = (201, 202)
N_SUBJECTS = 5
#: the simulator's effects halved and doubled (each tested on the test seeds)
VARIANTS = {
    "as trained": SimOptions(),
    "off-plane motion x0.5": SimOptions(offplane=0.5),
    "off-plane motion x2": SimOptions(offplane=2.0),
    "sensor bias x0.5": SimOptions(sensor_bias=0.5),
    "sensor bias x2": SimOptions(sensor_bias=2.0),
}


def simulated_calibrations(seed: int, options: SimOptions, workdir: Path) -> pd.DataFrame:
    """Every method's calibrations from all repetitions of a simulated Kong dataset (``seed``,
    :data:`N_SUBJECTS` subjects), with their error to the truth and their spread; ``subject``
    prefixed with the seed so that datasets can be pooled.
    """
    root = simulate_kong(workdir / f"kong_{seed}", seed, N_SUBJECTS, replace(options, jobs=1))
    dataset = load_dataset(root)
    summaries = pd.concat(
        [reduce_recordings(dataset, subject).summaries for subject in dataset.subjects.index],
        ignore_index=True,
    )
    calibrations, _ = calibrate(dataset, summaries, subsets="full", retest_k=None)
    calibrations = with_truth(calibrations, dataset.ground_truth)
    return calibrations.assign(subject=f"{seed}:" + calibrations["subject"].astype(str))


def usable_rows(calibrations: pd.DataFrame) -> pd.DataFrame:
    """The unflagged calibrations from all repetitions with a spread and an error to the truth."""
    full = full_set_rows(calibrations)
    full = full[unflagged(full)]
    return full[np.isfinite(full["spread95_deg"]) & np.isfinite(full["error_deg"])]


def coverage_rows(rows: pd.DataFrame, label: str) -> pd.DataFrame:
    """Per method (and over all methods), from :func:`aceval.evaluation.methods_comparison.
    uncertainty_table`: ``n`` calibrations, ``n_subjects``, the pooled ``coverage`` of the cone
    and its 95 % interval from resampling the subjects (``coverage_low``, ``coverage_high``), the
    smallest coverage of a test x segment cell with at least 5 calibrations (``worst_cell``,
    ``worst_cell_coverage``), and the medians of the cone and of the error with their ratio.
    """
    table = pd.concat([uncertainty_table(rows), uncertainty_table(rows.assign(method="all"))])
    pooled = table[table["segment"] == "all"].set_index("method")
    cells = table[(table["segment"] != "all") & (table["n"] >= 5)].sort_values(["test", "segment"])
    out = []
    for method in [*rows["method"].unique(), "all"]:
        row, mine = pooled.loc[method], cells[cells["method"] == method]
        worst = mine.loc[mine["coverage"].idxmin()] if len(mine) else None
        out.append(
            {
                "study": label,
                "method": method,
                "n": row["n"],
                "n_subjects": row["n_subjects"],
                "coverage": row["coverage"],
                "coverage_low": row["coverage_low"],
                "coverage_high": row["coverage_high"],
                "worst_cell": "" if worst is None else f"{worst['test']} {worst['segment']}",
                "worst_cell_coverage": np.nan if worst is None else worst["coverage"],
                "cone95_median_deg": row["cone95_median_deg"],
                "spread95_median_deg": row["spread95_median_deg"],
                "error_median_deg": row["error_median_deg"],
                "cone_over_error": row["cone95_median_deg"] / row["error_median_deg"],
            }
        )
    return pd.DataFrame(out)


def with_model_cones(rows: pd.DataFrame, model: pd.DataFrame) -> pd.DataFrame:
    """``rows`` with the model's ``cone95_deg`` (and ``cone_model``) from their spread."""
    cone, source = model_cones(
        rows["spread95_deg"].to_numpy(float),
        rows["method"].to_numpy(),
        rows["test"].to_numpy(),
        rows["segment"].to_numpy(),
        model,
    )
    return rows.assign(cone95_deg=cone, cone_model=source)


def _fit(workdir: Path, out: Path) -> pd.DataFrame:
    rows = pd.concat(
        [
            usable_rows(simulated_calibrations(seed, SimOptions(), workdir))
            for seed in TRAINING_SEEDS
        ],
        ignore_index=True,
    )
    model = fit_model(rows)
    model.to_csv(out, index=False, float_format="%.4f")
    return model


def _study(workdir: Path, model: pd.DataFrame) -> pd.DataFrame:
    tables = []
    for label, options in VARIANTS.items():
        rows = pd.concat(
            [usable_rows(simulated_calibrations(seed, options, workdir)) for seed in TEST_SEEDS],
            ignore_index=True,
        )
        tables.append(coverage_rows(with_model_cones(rows, model), label))
        print(f"coverage: {label} done", file=sys.stderr)
    return pd.concat(tables, ignore_index=True)


def main(argv: list[str] | None = None) -> int:
    """``fit``: learn the model from :data:`TRAINING_SEEDS`; ``study``: its coverage table."""
    parser = argparse.ArgumentParser(prog="python -m aceval.evaluation.coverage")
    parser.add_argument("what", choices=["fit", "study"])
    parser.add_argument("--model", default=str(MODEL_PATH), help="the model CSV (written by fit)")
    parser.add_argument("--out", default="results/coverage", help="study: the folder written")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="aceval-coverage-") as tmp:
        if args.what == "fit":
            print(_fit(Path(tmp), Path(args.model)).to_string(index=False))
            return 0
        table = _study(Path(tmp), pd.read_csv(args.model))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "coverage.csv", index=False, float_format="%.4f")
    (out / "coverage.md").write_text(_markdown(table))
    print(table.to_string(index=False))
    return 0


def _markdown(table: pd.DataFrame) -> str:
    shown = table.round(3)
    return (
        "# The cone's coverage on simulations it did not learn from\n\n"
        f"Seeds {', '.join(map(str, TEST_SEEDS))} ({N_SUBJECTS} simulated subjects each; the "
        f"model learned from seeds {', '.join(map(str, TRAINING_SEEDS))}). Coverage: the share of "
        "the unflagged calibrations from all repetitions whose error to the truth is inside the "
        "95 % cone; its interval from 1,000 resamples of the subjects. Made by `python -m "
        "aceval.evaluation.coverage study`.\n\n" + shown.to_markdown(index=False) + "\n"
    )


if __name__ == "__main__":
    sys.exit(main())
