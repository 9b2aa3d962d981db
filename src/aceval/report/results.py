"""A dataset's results folder in one process: the Obj 3-5 angles, every table and figure of its
analyses (:mod:`aceval.report.outputs`), SUMMARY.md and validation.txt.

One process per dataset, not one per output: starting Python with pandas, SciPy, statsmodels and
Matplotlib costs seconds, far more than most tables take to build (benchmarks/README.md).
"""

from __future__ import annotations

import io
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from aceval.data.contract import R_COLUMNS, file_problem
from aceval.data.errors import InputError
from aceval.data.safety import FileSet, atomic_file
from aceval.report.outputs import Output, outputs_of

#: the name columns of aceval's tables, read as text: a subject '001' stays '001' (a CSV reader
#: left to guess reads the number 1, and '1' and '01' become one subject)
NAME_DTYPES = {c: str for c in ("subject", "sensor_set", "imu", "imu_b", "test", "segment", "side")}
#: the columns a calibrations table (of `aceval calibrate`, or a peer's) must have
CALIBRATION_TABLE_COLUMNS = ["subject", "sensor_set", "imu", "test", "repetitions", "n_reps"]
CALIBRATION_TABLE_COLUMNS += ["method", *R_COLUMNS, "flag"]


def read_tables(paths, keep: Callable | None = None, required=()) -> pd.DataFrame | None:
    """The CSV tables at ``paths`` concatenated (an empty file, e.g. a subject with nothing to
    calibrate, is skipped but keeps its columns when all are empty); None for no paths. ``keep``:
    a table -> its rows to hold, applied file by file (memory holds no more). The name columns
    are read as text (:data:`NAME_DTYPES`). InputError naming the file and the cause when one is
    missing, not a CSV table, or lacks one of the ``required`` columns.

    Each file is parsed in one piece (``low_memory=False``): one type per column from the whole
    file, and no chunk arrays left to fragment the heap (at 200 subjects the correlations held
    435 MiB of RSS read in chunks, 222 MiB in one piece; benchmarks/README.md).
    """
    if not paths:
        return None
    parts = []
    for path in paths:
        if problem := file_problem(path):
            raise InputError(f"{path}: {problem}")
        try:
            part = pd.read_csv(path, low_memory=False, dtype=NAME_DTYPES)
        except pd.errors.EmptyDataError:
            continue
        except (UnicodeDecodeError, pd.errors.ParserError, ValueError) as exc:
            cause = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(f"{path}: cannot be read as a CSV table ({cause})") from None
        missing = [c for c in required if c not in part.columns]
        if missing:
            raise InputError(
                f"{path}: missing column(s) {', '.join(missing)}: not a table of the kind this "
                f"option takes (the columns are {', '.join(map(str, part.columns))[:80]!r})"
            )
        parts.append(keep(part) if keep is not None and len(part) else part)
    non_empty = [p for p in parts if len(p)] or parts[:1]
    return pd.concat(non_empty, ignore_index=True) if non_empty else pd.DataFrame()


def dataset_sheet(root, name: str) -> pd.DataFrame | None:
    """An importer's extra sheet in the dataset folder, or None: ``ground_truth_method.tsv`` (how
    a marker-based ground truth was made), ``loose_reference.tsv`` (a hand-set reference).
    """
    path = Path(root) / name
    return pd.read_csv(path, sep="\t", dtype={"flag": str}) if path.is_file() else None


def dataset_meta(root) -> dict:
    """dataset.yaml of the dataset at ``root``."""
    return yaml.safe_load((Path(root) / "dataset.yaml").read_text())


def _as_read_back(table: pd.DataFrame, text: str) -> pd.DataFrame:
    """The table as a reader of its CSV sees it (what the summary's rules are written against)."""
    try:
        return pd.read_csv(io.StringIO(text))
    except pd.errors.EmptyDataError:
        return table


def _write_text(path: Path, text: str, files: FileSet | None = None) -> None:
    _put(path, lambda tmp: Path(tmp).write_text(text), files)


def _put(path: Path, write, files: FileSet | None = None) -> Path:
    """``write`` the output ``path`` into ``files`` (committed with the others) or, without a
    set, atomically on its own; returns where it is now (readable before the commit).
    """
    if files is None:
        atomic_file(path, write)
        return Path(path)
    files.write(path, write)
    return files.staged[Path(path)]


def ground_truth_sheet(root) -> pd.DataFrame | None:
    """The dataset's ground_truth.tsv indexed by subject, set and IMU (None without one)."""
    path = Path(root) / "ground_truth.tsv"
    if not path.is_file():
        return None
    return pd.read_csv(path, sep="\t", dtype=NAME_DTYPES).set_index(
        ["subject", "sensor_set", "imu"]
    )


def build_data(
    root,
    calibrations=None,
    axes=None,
    correlations=None,
    angles=None,
    paper_names=None,
    peers=None,
    test_retest_k: int = 3,
    retest_units=None,
    recordings=None,
    tolerance_deg: float | None = None,
) -> dict:
    """The ``data`` dict the builders read: the tidy tables (the ``peers``' calibrations joined
    to aceval's, through every gate aceval's rows pass (:func:`aceval.evaluation.peer_gates.
    gate_peers`: ``recordings``, the one pass's summaries, for their direction vote) and with
    their error to the ground truth), the dataset's truth (``ground_truth``) and
    reference sheets,
    its ``paper_names`` (this dataset's test names -> the paper's), sensor sets and Obj 4's k;
    ``retest_units``: aceval's methods' test-retest units, computed per subject
    (:func:`aceval.evaluation.methods_comparison.retest_units`; None: from the calibrations);
    ``tolerance_deg``: the heading accuracy the decision judges against (None: its default).
    """
    from aceval.data.dataset import load_dataset
    from aceval.evaluation.decision import flag_disagreements
    from aceval.evaluation.decision_rules import DEFAULT_TOLERANCE_DEG
    from aceval.evaluation.methods_comparison import with_truth
    from aceval.evaluation.peer_gates import gate_peers

    meta = dataset_meta(root)
    truth = ground_truth_sheet(root)
    if peers is not None and len(peers):
        dataset = load_dataset(root)
        peers = gate_peers(
            peers,
            dataset.right_axis,
            calibrations,
            recordings,
            dataset.first_phase,
            test_retest_k,
        )
        calibrations = pd.concat([calibrations, peers], ignore_index=True)
    if calibrations is not None and len(calibrations):  # against the truth as it is now
        errors = ["error_deg", "error_vertical_share"]
        calibrations = with_truth(
            calibrations.drop(columns=errors, errors="ignore").assign(
                error_deg=np.nan, error_vertical_share=np.nan
            ),
            truth,
        )
    tolerance_deg = DEFAULT_TOLERANCE_DEG if tolerance_deg is None else float(tolerance_deg)
    if calibrations is not None and len(calibrations):
        calibrations = flag_disagreements(calibrations, tolerance_deg)
    return {
        "test_retest_k": test_retest_k,
        "tolerance_deg": tolerance_deg,
        "calibrations": calibrations,
        "axes": axes,
        "correlations": correlations,
        "angles": angles,
        "retest_units": retest_units,
        "ground_truth": truth,
        "truth_method": dataset_sheet(root, "ground_truth_method.tsv"),
        "loose_reference": dataset_sheet(root, "loose_reference.tsv"),
        "sensor_sets": list(meta["sensor_sets"])[:2],
        "paper_names": paper_names or {},
        "meta": meta,
    }


def write_table(
    output: Output, data: dict, csv: Path, md: Path, files: FileSet | None = None
) -> pd.DataFrame:
    """Build one table, write it as CSV and Markdown; returns it as read back from the CSV."""
    meta = data["meta"]
    table = output.build(data)
    if "n" in table.columns and output.name.startswith("table") and not (table["n"] > 0).any():
        print(
            f"aceval: {output.name}: no data in {meta.get('name')} for this table", file=sys.stderr
        )
    text = table.to_csv(index=False)
    _write_text(csv, text, files)
    _write_text(
        md, output.markdown(table, output, meta.get("name", ""), bool(meta.get("simulated"))), files
    )
    return _as_read_back(table, text)


def write_figure(output: Output, data: dict, png: Path, files: FileSet | None = None) -> None:
    """Draw one figure to ``png``; its title names the dataset (and says SIMULATED)."""
    meta = data["meta"]
    title = str(meta.get("name", "")) + (" (SIMULATED)" if meta.get("simulated") else "")
    _put(png, lambda tmp: output.build(data, tmp, title), files)


def write_results(
    results: Path,
    root,
    analyses: list[str],
    data: dict,
    test_retest_k: int = 3,
    notes: list[str] = (),
    validation: str | None = None,
    progress: Callable[[str], None] = lambda message: None,
    kinds: tuple[str, ...] = ("table", "figure"),
    files: FileSet | None = None,
) -> None:
    """Write into ``results`` (a dataset's folder under results/) the outputs of ``analyses`` of
    these ``kinds``: for tables also ``angles.csv`` (Kong's Obj 3-5 angles; without Kong's
    analyses, its header only), ``SUMMARY.md`` and, when
    given, the ``validation`` report as validation.txt. ``data`` from :func:`build_data`. Tables
    and figures can be written by two processes at once (the workflow does). With ``files``
    every output is staged there and put in place when the set is committed (all or none).
    """
    from aceval.evaluation.objectives import all_angles

    results = Path(results)
    chosen = [o for o in outputs_of(analyses) if o.kind in kinds]
    if "kong" in analyses and data.get("angles") is None:
        with tempfile.TemporaryDirectory() as scratch:
            # written, then read back as every reader of angles.csv sees it (one copy in memory:
            # for 200 subjects it has 1.6 million rows)
            path = results / "angles.csv" if "table" in kinds else Path(scratch) / "angles.csv"
            angles = all_angles(data["calibrations"], test_retest_k)
            written = _put(path, lambda tmp: angles.to_csv(tmp, index=False), files)
            del angles
            data["angles"] = pd.read_csv(written, low_memory=False)
    elif "kong" in analyses and "table" in kinds:  # computed per subject (calibrate --angles-out)
        _put(results / "angles.csv", lambda tmp: data["angles"].to_csv(tmp, index=False), files)
    if "kong" not in analyses and "table" in kinds:  # no Obj 3-5 here: the file, with no row
        _put(results / "angles.csv", lambda tmp: _no_angles().to_csv(tmp, index=False), files)
    if "table" in kinds:
        progress("angles.csv")
    tables = {}
    for output in chosen:
        (results / f"{output.kind}s").mkdir(parents=True, exist_ok=True)
        if output.kind == "table":
            table = write_table(
                output, data, results / output.path, results / f"tables/{output.name}.md", files
            )
            key = output.name.removeprefix("table")
            tables[int(key) if key.isdigit() else output.name] = table
        else:
            write_figure(output, data, results / output.path, files)
        progress(output.path)
    if "table" in kinds:
        from aceval.report import summary

        found = summary.claims(tables, data)
        _write_text(
            results / "SUMMARY.md", summary_text(found, tables, analyses, data, notes), files
        )
        progress("SUMMARY.md")
        write_claim_tables(found, results / "tables", files)
        if validation is not None:
            _write_text(results / "validation.txt", validation, files)


def _no_angles() -> pd.DataFrame:
    """The Obj 3-5 angles table with no row (a dataset without Kong's analyses)."""
    from aceval.evaluation.objectives import ANGLE_COLUMNS

    return pd.DataFrame(columns=ANGLE_COLUMNS)


#: the tables behind SUMMARY.md's verdicts (aceval.report.claims): one row per claim, per cell of
#: a claim (its simultaneous interval) and per subject and cell (the values it is judged on)
CLAIM_TABLES = {
    "claims": "claims_table",
    "claim_estimates": "estimates_table",
    "claim_cells": "cells_table",
}


def write_claim_tables(found: list, folder: Path, files: FileSet | None = None) -> None:
    """The claims' tables (:data:`CLAIM_TABLES`) as CSV in ``folder`` (numbers to 10 significant
    digits: enough to recompute every interval, stable across machines).
    """
    from aceval.report import claims

    folder.mkdir(parents=True, exist_ok=True)
    for name, function in CLAIM_TABLES.items():
        text = getattr(claims, function)(found).to_csv(index=False, float_format="%.10g")
        _write_text(folder / f"{name}.csv", text, files)


def _has_peers(calibrations) -> bool:
    """Whether the calibrations (the peers' joined in) hold any peer's."""
    from aceval.methods import registry

    return calibrations is not None and calibrations["method"].isin(registry.peers()).any()


def summary_text(
    found: list, tables: dict, analyses: list[str], data: dict, notes: list[str]
) -> str:
    """SUMMARY.md from the claims ``found`` and the tables as read back (Kong's keyed by number,
    the others by name).
    """
    from aceval.evaluation.truth_warnings import truth_warning
    from aceval.report import summary
    from aceval.report.decisions import decision_section
    from aceval.report.methods_section import methods_section

    meta = data["meta"]
    calibrations = data.get("calibrations") if "kong" in analyses else None
    notes = [f"- {line}" for line in notes if line]
    truth = data.get("ground_truth")
    if calibrations is not None and (warning := truth_warning(calibrations, truth)):
        notes.append(f"- {warning}")
    if calibrations is not None and "z0_tests" in calibrations:
        from aceval.calibrate.plan import PER_REPETITION

        own = calibrations.loc[calibrations["z0_tests"].astype(str).str.endswith(PER_REPETITION)]
        if len(own):
            notes.append(
                f"- Each repetition has its own vertical (z0): the quiet standing of its own "
                f"recording (verticals.tsv; {own['subject'].nunique()} subject(s), tests "
                f"{', '.join(sorted(own['test'].unique()))}), so repeated trials with the sensors "
                "put on again stay repetitions of one subject; a calibration from several "
                "repetitions uses the mean of their verticals."
            )
    return summary.to_markdown(
        found,
        meta.get("name", ""),
        meta.get("description", ""),
        bool(meta.get("simulated")),
        notes,
        decision_section(tables, _has_peers(data.get("calibrations"))),
        methods_section(tables)
        + summary.retest_section(tables)
        + summary.uncertainty_section(tables)
        + summary.conditioning_section(tables)
        + summary.truth_section(tables)
        + summary.loose_reference_section(tables),
        tables=tables,
    )
