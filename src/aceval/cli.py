"""Command line: ``aceval simulate|import|validate|calibrate|apply|angles|table|figure|outputs``
(also ``python -m aceval``). The workflow's rules are thin calls of these commands.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from aceval.data.safety import FileSet, UnsafeOutputError

if (
    TYPE_CHECKING
):  # imported where used: pandas costs start-up time for the commands that never need it
    import pandas as pd


def _staged(out: Path, force: bool, command: str, write) -> int:
    """Write a folder output through :func:`aceval.data.safety.staged_folder` (nothing is left behind
    on failure; ``--force`` replaces only a folder aceval wrote).
    """
    from aceval.data.safety import UnsafeOutputError, fail, staged_folder

    try:
        staged_folder(out, force, write)
    except UnsafeOutputError as exc:
        return fail(command, exc)
    print(f"wrote {out}", file=sys.stderr)
    return 0


def _simulate(args) -> int:
    from aceval.simulate import GENERATORS, SimOptions

    options = SimOptions(
        noise=not args.no_noise,
        offplane=0.0 if args.no_offplane else 1.0,
        wobble=0.0 if args.no_wobble else 1.0,
        repetitions=args.repetitions,
        jobs=args.jobs,
    )
    kwargs = {"options": options}
    if args.subjects is not None:
        kwargs["n_subjects"] = args.subjects
    return _staged(
        Path(args.out),
        args.force,
        "simulate",
        lambda folder: GENERATORS[args.protocol](folder, args.seed, **kwargs),
    )


def _import(args) -> int:
    from aceval.importers import FormatError
    from aceval.importers.run import run_import

    try:
        return _staged(
            Path(args.out),
            args.force,
            "import",
            lambda folder: print(
                run_import(
                    folder, args.format, args.src, args.sensors, args.subject, args.vicon, args.name
                ).summary(),
                file=sys.stderr,
            ),
        )
    except (FormatError, OSError) as exc:
        print(f"aceval import {args.format}: {exc}", file=sys.stderr)
        return 1


def _validate(args) -> int:
    from aceval.data.dataset import validate

    _, report = validate(args.dataset, check_files="headers" if args.sheets_only else "all")
    print(report.format(), file=sys.stdout if report.ok else sys.stderr)
    if report.ok and (args.out or args.findings_out):
        with FileSet([args.out, args.findings_out]) as files:
            if args.out:
                files.write(args.out, lambda tmp: Path(tmp).write_text(report.format() + "\n"))
            if args.findings_out:
                table = _findings_table(report)
                files.write(args.findings_out, lambda tmp: table.to_csv(tmp, sep="\t", index=False))
    return 0 if report.ok else 1


def _atomic(path: str | Path, write) -> None:
    from aceval.data.safety import atomic_file

    atomic_file(path, write)


def _write_csv(path, table) -> None:
    _atomic(path, lambda tmp: table.to_csv(tmp, index=False))


def _write_text(path, text: str) -> None:
    _atomic(path, lambda tmp: Path(tmp).write_text(text))


def _read_csvs(paths) -> pd.DataFrame:
    from aceval.report.results import read_tables

    return read_tables(paths)


#: ``--method`` choices of ``aceval calibrate`` -> the ``method`` values of the calibrations table
METHODS = {
    "kong": ["kong"],
    "ricci": ["ricci_lm"],
    "align_vectors": ["align_vectors"],
    "triad": ["triad"],
    "combined": ["combined"],
    "step_harmonic": ["step_harmonic"],
    "all": ["kong", "ricci_lm", "align_vectors", "triad", "combined", "step_harmonic"],
}


def _progress(done: int, total: int, what: str) -> None:
    """A one-line progress bar on stderr (only on a terminal: logs stay clean)."""
    if sys.stderr.isatty():
        filled = int(30 * done / total)
        print(
            f"\r[{'#' * filled}{'.' * (30 - filled)}] {done}/{total} {what}",
            end="" if done < total else "\n",
            file=sys.stderr,
            flush=True,
        )


def _calibrate(args) -> int:
    from aceval.data.dataset import DatasetError, load_dataset

    try:  # the sheets here; each recording file is checked in the pass that reads it
        dataset = load_dataset(args.dataset)
    except DatasetError as exc:
        print(f"aceval calibrate: {args.dataset} is not a valid dataset:\n{exc}", file=sys.stderr)
        return 1
    unknown = [s for s in args.subject or [] if s not in dataset.subjects.index]
    if unknown:
        print(
            f"aceval calibrate: subject(s) {', '.join(map(repr, unknown))} not in "
            f"{args.dataset}/subjects.tsv",
            file=sys.stderr,
        )
        return 2
    unknown = sorted(set(args.tests or []) - set(dataset.tests.index))
    if unknown:
        print(
            f"aceval calibrate: test(s) {', '.join(unknown)} not in {args.dataset}/tests.tsv",
            file=sys.stderr,
        )
        return 2
    outputs = [args.out, args.recordings_out, args.axes_out, args.pairs_out, args.correlations_out]
    outputs += [args.findings_out, args.angles_out, args.retest_out, args.plan_out]
    try:  # every folder writable before the work; all outputs put in place together, or none
        files = FileSet(outputs)
    except UnsafeOutputError as exc:
        print(f"aceval calibrate: {exc}", file=sys.stderr)
        return 2
    with files:
        return _calibrate_into(args, dataset, files)


def _calibrate_into(args, dataset, files) -> int:
    """The work of `aceval calibrate` once its inputs and outputs are checked: its outputs are
    written into ``files`` (a :class:`aceval.data.safety.FileSet`).
    """
    import json

    import pandas as pd

    from aceval.calibrate.pipeline import calibrate
    from aceval.calibrate.rows import AXES_COLUMNS
    from aceval.calibrate.table import CALIBRATION_COLUMNS
    from aceval.data.dataset import ValidationReport
    from aceval.evaluation.correlations import correlations
    from aceval.report.summary import calibration_screen
    from aceval.signals.reduction import reduce_recordings

    trim = _trim(args)
    segment_pairs = json.loads(args.pairs)
    subjects = args.subject if args.subject is not None else list(dataset.subjects.index)
    summaries, pairs, report = [], [], ValidationReport(dataset.name)
    for done, subject in enumerate(subjects, start=1):
        reduced = reduce_recordings(
            dataset, subject, trim, args.tests, segment_pairs, args.max_lag_s
        )
        summaries.append(reduced.summaries)
        pairs.append(reduced.pairs)
        report.findings += reduced.report.findings
        _progress(done, len(subjects), "subjects read")
    if not report.ok:
        print(
            f"aceval calibrate: {args.dataset}: recording files that cannot be used; no file "
            f"written:\n{report.format()}",
            file=sys.stderr,
        )
        return 1
    summaries = _concat_tables(summaries)
    pairs = _concat_tables(pairs)
    unusable = summaries[summaries["flag"] != ""] if len(summaries) else summaries
    for message in unusable.get("message", []):
        print(f"aceval calibrate: left out {message}", file=sys.stderr)
    calibrations, axes = (
        calibrate(dataset, summaries, args.subsets, retest_k=args.retest_k)
        if len(summaries)
        else (pd.DataFrame(columns=CALIBRATION_COLUMNS), pd.DataFrame(columns=AXES_COLUMNS))
    )
    if len(calibrations):
        from aceval.apply import FINGERPRINT, recordings_fingerprint
        from aceval.evaluation.methods_comparison import with_truth

        calibrations = with_truth(calibrations, dataset.ground_truth)

        calibrations = calibrations[calibrations["method"].isin(METHODS[args.method])].reset_index(
            drop=True
        )
        fingerprints = {
            s: recordings_fingerprint(dataset, s) for s in calibrations["subject"].unique()
        }
        calibrations[FINGERPRINT] = calibrations["subject"].map(fingerprints)
    if calibrations.empty and not args.allow_empty:
        why = (
            f"{len(unusable)} recording(s) were left out (listed above) and none remained"
            if len(unusable)
            else "no subject has a static test and a motion test that calibrates one of its IMUs "
            "(calibrates.tsv)"
            if len(summaries)
            else "no recording of a test that calibrates an IMU"
        )
        print(
            f"aceval calibrate: nothing to calibrate in {args.dataset}: {why}; no file written",
            file=sys.stderr,
        )
        return 1
    tables = {"out": calibrations, "recordings_out": summaries, "axes_out": axes}
    tables["pairs_out"] = pairs
    if args.correlations_out:
        tables["correlations_out"] = correlations(
            dataset, calibrations, pairs, args.mode, segment_pairs
        )
    _write_calibrate_outputs(args, files, tables, report, dataset)
    _say_findings(report, dataset, summaries)
    print(calibration_screen(calibrations, len(unusable), args.out), file=sys.stderr)
    return 0


def _say_findings(report, dataset, summaries) -> None:
    """The files' warnings and what the checks found about each sensor (its calibrations are
    flagged), on stderr.
    """
    if report.warnings:
        print(f"aceval calibrate: {len(report.warnings)} file warning(s):", file=sys.stderr)
        print("\n".join(map(str, report.warnings)), file=sys.stderr)
    if len(summaries):
        from aceval.calibrate.pipeline import imu_checks

        for verdict in imu_checks(dataset, summaries).values():
            if verdict["message"]:
                print(f"aceval calibrate: flagged {verdict['message']}", file=sys.stderr)


def _write_calibrate_outputs(args, files, tables: dict, report, dataset) -> None:
    """Stage every output `aceval calibrate` was asked for in ``files``: the ``tables`` (by the
    option that names each file), the findings, the Obj 3-5 angles and test-retest units, and
    the peers' plan.
    """
    import json

    for option, table in tables.items():
        if getattr(args, option):
            files.write(getattr(args, option), lambda tmp, t=table: t.to_csv(tmp, index=False))
    if args.findings_out:
        findings = _findings_table(report)
        files.write(args.findings_out, lambda tmp: findings.to_csv(tmp, sep="\t", index=False))
    if args.angles_out or args.retest_out:
        _write_angles(args, files)
    if args.plan_out:
        from aceval.calibrate.plan import calibration_plan

        plan = json.dumps(
            calibration_plan(dataset, tables["recordings_out"], args.retest_k), indent=1
        )
        files.write(args.plan_out, lambda tmp: Path(tmp).write_text(plan + "\n"))


def _write_angles(args, files) -> None:
    """Kong's Obj 3-5 angles (--angles-out) and every method's test-retest units (--retest-out)
    of this job's subjects, from its calibrations as a reader of ``args.out`` sees them (what the
    results jobs computed from before): the only tables that need the calibrations from subsets
    of repetitions, so the results jobs read only those from all repetitions.
    """
    from aceval.evaluation.methods_comparison import retest_units
    from aceval.evaluation.objectives import all_angles
    from aceval.report.results import read_tables

    calibrations = read_tables([files.staged[Path(args.out)]])
    if args.angles_out:
        table = all_angles(calibrations, args.retest_k)
        files.write(args.angles_out, lambda tmp: table.to_csv(tmp, index=False))
    if args.retest_out:
        table = retest_units(calibrations, args.retest_k)
        files.write(args.retest_out, lambda tmp: table.to_csv(tmp, index=False))


def _concat_tables(parts: list) -> pd.DataFrame:
    import pandas as pd

    non_empty = [p for p in parts if len(p)]
    return (
        pd.concat(non_empty, ignore_index=True)
        if non_empty
        else (parts[0] if parts else pd.DataFrame())
    )


def _findings_table(report) -> pd.DataFrame:
    """The file findings of a pass as a table (level, where, cause)."""
    import pandas as pd

    return pd.DataFrame(
        [(f.level, f.where, f.cause) for f in report.findings], columns=["level", "where", "cause"]
    )


def _add_table_inputs(command) -> None:
    """The tidy tables a table, figure or results folder is built from."""
    command.add_argument("--calibrations", nargs="*", default=[], help="CSVs of `aceval calibrate`")
    command.add_argument("--axes", nargs="*", default=[], help="axes CSVs (calibrate --axes-out)")
    command.add_argument(
        "--correlations", nargs="*", default=[], help="CSVs of calibrate --correlations-out"
    )
    command.add_argument(
        "--paper-names", default="{}", help="JSON map of this dataset's test names to the paper's"
    )


def _add_trim_options(command) -> None:
    """The movement trimmer's parameters (Kong Fig. 5) as options."""
    command.add_argument(
        "--trim-threshold", type=float, default=0.1, help="Kong Fig. 5 threshold (0.1)"
    )
    command.add_argument(
        "--closing-s", type=float, default=1.0, help="morphological closing length, s (1.0)"
    )
    command.add_argument("--window-s", type=float, default=0.5, help="moving-SD window, s (0.5)")
    command.add_argument(
        "--min-peak-deg-s",
        type=float,
        default=20.0,
        help="a 'motion' whose peak |gyro| is below this (deg/s) is refused (20)",
    )


def _trim(args):
    import numpy as np

    from aceval.signals.segmentation import TrimParams

    return TrimParams(
        threshold=args.trim_threshold,
        closing_s=args.closing_s,
        window_s=args.window_s,
        min_peak_rad_s=np.radians(args.min_peak_deg_s),
    )


def _apply(args) -> int:
    from aceval.apply import (
        ApplyError,
        apply_calibrations,
        check_rotations,
        chosen_calibrations,
        read_calibrations,
    )
    from aceval.data.dataset import DatasetError, load_dataset
    from aceval.data.safety import check_writable

    try:
        check_writable([Path(args.out).parent])  # before any work
    except UnsafeOutputError as exc:
        print(f"aceval apply: {exc}", file=sys.stderr)
        return 2
    try:
        dataset = load_dataset(args.dataset)
    except DatasetError as exc:
        print(f"aceval apply: {args.dataset} is not a valid dataset:\n{exc}", file=sys.stderr)
        return 1
    try:
        calibrations = read_calibrations(args.calibrations)
        chosen = chosen_calibrations(dataset, calibrations, args.method, args.test)
        if chosen.empty:
            raise ApplyError(
                f"{args.calibrations} has no valid {args.method} calibration"
                + (f" from test {args.test}" if args.test else "")
                + ": nothing to apply"
            )
        check_rotations(chosen, args.calibrations)
    except ApplyError as exc:
        print(f"aceval apply: {exc}", file=sys.stderr)
        return 1
    source = None if args.other_dataset else args.calibrations

    def write(folder):
        for line in apply_calibrations(
            dataset, calibrations, folder, args.method, args.test, _progress, source
        ):
            print(
                line if line.startswith("aceval") else f"aceval apply: warning: {line}",
                file=sys.stderr,
            )

    try:
        return _staged(Path(args.out), args.force, "apply", write)
    except ApplyError as exc:  # nothing was put in place
        print(f"aceval apply: nothing written:\n{exc}", file=sys.stderr)
        return 1


def _angles(args) -> int:
    from aceval.evaluation.objectives import all_angles

    _write_csv(args.out, all_angles(_read_csvs(args.calibrations), args.test_retest_k))
    return 0


def _single_output(args, kind: str) -> int:
    """``aceval table|figure NAME``: one output of the registry, from the given tidy tables."""
    import json

    from aceval.report.outputs import find
    from aceval.report.results import build_data, read_tables, write_figure, write_table

    try:
        output = find(kind, args.name)
    except ValueError as exc:
        print(f"aceval {kind}: {exc}", file=sys.stderr)
        return 2
    data = build_data(
        args.dataset,
        read_tables(args.calibrations),
        read_tables(args.axes),
        read_tables(args.correlations),
        read_tables([args.angles] if args.angles else []),
        json.loads(args.paper_names),
    )
    missing = [k for k in output.inputs if data.get(k) is None]
    if missing:
        print(
            f"aceval {kind} {output.name}: needs {', '.join('--' + k for k in missing)} "
            f"({output.paper})",
            file=sys.stderr,
        )
        return 2
    if kind == "table":
        write_table(output, data, Path(args.csv), Path(args.md))
    else:
        write_figure(output, data, Path(args.out))
    return 0


def _table(args) -> int:
    return _single_output(args, "table")


def _figure(args) -> int:
    return _single_output(args, "figure")


def _outputs(args) -> int:
    """``aceval outputs``: a dataset's whole results folder (the workflow's job per dataset)."""
    import json

    from aceval.calibrate.table import full_set_rows
    from aceval.data.dataset import Finding, ValidationReport
    from aceval.evaluation.objectives import in_angle_order
    from aceval.report.results import build_data, dataset_meta, read_tables

    try:  # the results folder writable before the work; its files put in place together
        files = FileSet([], folders=[args.results])
    except UnsafeOutputError as exc:
        print(f"aceval outputs: {exc}", file=sys.stderr)
        return 2
    # the per-subject angles and test-retest units hold all the subsets are needed for: with
    # them, only the calibrations from all repetitions are held (7 % of Kong's rows)
    precomputed = bool(args.angles and args.retest_units)
    data = build_data(
        args.dataset,
        read_tables(args.calibrations, full_set_rows if precomputed else None),
        read_tables(args.axes),
        read_tables(args.correlations),
        in_angle_order(read_tables(args.angles)) if args.angles else None,
        paper_names=json.loads(args.paper_names),
        peers=read_tables(args.peers),
        test_retest_k=args.test_retest_k,
        retest_units=read_tables(args.retest_units) if args.retest_units else None,
    )
    print("aceval outputs: read the inputs", file=sys.stderr)
    validation = None
    if args.findings:
        report = ValidationReport(str(dataset_meta(args.dataset).get("name", args.dataset)))
        for path in args.findings:
            table = _read_findings(path)
            report.findings += [Finding(*row) for row in table.itertuples(index=False)]
        validation = report.format() + "\n"
    with files:
        _write_results(args, data, validation, files)
    return 0


def _write_results(args, data, validation, files) -> None:
    from aceval.report.results import write_results

    write_results(
        Path(args.results),
        args.dataset,
        args.analyses,
        data,
        args.test_retest_k,
        args.note,
        validation,
        lambda what: print(f"aceval outputs: wrote {what}", file=sys.stderr),
        tuple(args.kinds),
        files,
    )


def _read_findings(path):
    import pandas as pd

    return pd.read_csv(path, sep="\t", dtype=str, keep_default_na=False)


def main(argv: list[str] | None = None) -> int:
    """Run ``aceval <command>``; returns the exit code (0 ok, 1 bad input, 2 refused)."""
    parser = argparse.ArgumentParser(prog="aceval", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    simulate = commands.add_parser(
        "simulate", help="write a SIMULATED dataset in the contract, with ground truth"
    )
    simulate.add_argument("protocol", choices=["kong", "ricci", "box"])
    simulate.add_argument("--out", required=True, help="output folder (created)")
    simulate.add_argument("--seed", type=int, default=0)
    simulate.add_argument("--subjects", type=int, help="number of subjects (default: the paper's)")
    simulate.add_argument(
        "--repetitions", type=int, default=5, help="repetitions of each motion test (5; Kong, box)"
    )
    simulate.add_argument(
        "--no-noise", action="store_true", help="ideal sensors: no noise, bias or saturation"
    )
    simulate.add_argument("--no-offplane", action="store_true", help="pure sagittal-plane motion")
    simulate.add_argument("--no-wobble", action="store_true", help="no soft-tissue wobble")
    simulate.add_argument(
        "--jobs", type=int, default=1, help="subjects simulated side by side (same output; 1)"
    )
    simulate.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    simulate.set_defaults(run=_simulate)

    importer = commands.add_parser(
        "import",
        help="convert recordings in a foreign format into a dataset folder "
        "(with import_report.tsv: what was imported, flagged or left out, and why)",
    )
    importer.add_argument("format", choices=["hugadb", "xsens", "qmt", "gaitmap"])
    importer.add_argument(
        "src", help="hugadb: the folder of HuGaDB_*.txt; xsens: the folder of MT Manager exports"
    )
    importer.add_argument("--out", required=True, help="output dataset folder (created)")
    importer.add_argument(
        "--sensors",
        help="xsens: sensor sheet (sensor_id imu sensor_set segment side region right_axis)",
    )
    importer.add_argument("--subject", default="S01", help="xsens: subject name (S01)")
    importer.add_argument(
        "--vicon", help="xsens: Vicon .mat of the same trial: writes ground_truth.tsv (see docs)"
    )
    importer.add_argument("--name", help="dataset name (default: the format)")
    importer.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    importer.set_defaults(run=_import)

    validate = commands.add_parser("validate", help="check a dataset folder against the contract")
    validate.add_argument("dataset")
    validate.add_argument(
        "--out", help="write the report here when the dataset is valid (nothing when not)"
    )
    validate.add_argument(
        "--findings-out",
        help="write the findings here as a table (level, where, cause) when the dataset is valid",
    )
    validate.add_argument(
        "--sheets-only",
        action="store_true",
        help="the sheets, and of each recording file only that it exists and its header (the "
        "workflow's first gate: the files' contents are checked in the pass that reads them)",
    )
    validate.set_defaults(run=_validate)

    calibrate = commands.add_parser(
        "calibrate",
        help="calibrate a dataset: Kong (every subset of repetitions) and the axis methods "
        "(Ricci LM, align_vectors, TRIAD); Ricci's functional design when functional_axes.tsv exists",
    )
    calibrate.add_argument("dataset")
    calibrate.add_argument("--subject", nargs="+", help="only these subjects (default: all)")
    calibrate.add_argument("--out", required=True, help="calibrations CSV")
    calibrate.add_argument(
        "--recordings-out", help="per-recording summary CSV (what was kept or left out, and why)"
    )
    calibrate.add_argument(
        "--axes-out", help="functional axes CSV: axis and rho per subject, IMU and test"
    )
    calibrate.add_argument(
        "--method",
        choices=list(METHODS),
        default="all",
        help="kong (every subset of repetitions), ricci (rho-weighted LM), align_vectors, triad "
        "(the axis methods: all repetitions), combined (Kong's plane and the gyroscope axis "
        "weighted by their conditioning), step_harmonic (walking: the anterior-posterior axis "
        "from the acceleration at the step frequency), or all (default)",
    )
    calibrate.add_argument(
        "--tests", nargs="+", help="only these motion tests (default: all; static tests always)"
    )
    calibrate.add_argument(
        "--subsets",
        choices=["all", "full"],
        default="all",
        help="Kong: every subset of repetitions (all, default) or all of them together (full)",
    )
    calibrate.add_argument(
        "--allow-empty",
        action="store_true",
        help="write a table with no rows (and exit 0) when nothing can be calibrated (the workflow)",
    )
    calibrate.add_argument(
        "--correlations-out",
        help="Kong Obj 1-2 correlations of the calibrated recording pairs (from the pair moments)",
    )
    calibrate.add_argument(
        "--pairs-out", help="the moments of every time-aligned Obj 1-2 recording pair (CSV)"
    )
    calibrate.add_argument("--findings-out", help="file warnings of the pass (tab-separated)")
    calibrate.add_argument(
        "--angles-out", help="Kong's Obj 3-5 angles of these subjects (as `aceval angles`, CSV)"
    )
    calibrate.add_argument(
        "--retest-out",
        help="every method's Obj 4 test-retest per subject x set x IMU x test (CSV; "
        "`aceval outputs --retest-units`)",
    )
    calibrate.add_argument(
        "--plan-out",
        help="what a peer tool calibrates (JSON for workflow/peers/: files, right axes, subsets)",
    )
    calibrate.add_argument(
        "--retest-k",
        type=int,
        default=3,
        help="the axis methods (and the plan) also from every subset of this many repetitions "
        "(Obj 4's test-retest for every method; 0: none) (3)",
    )
    calibrate.add_argument(
        "--mode",
        choices=["concatenated", "per_axis", "per_axis_moving"],
        default="concatenated",
        help="correlation of two 3-axis signals (config objectives.correlation)",
    )
    calibrate.add_argument(
        "--max-lag-s",
        type=float,
        default=0.5,
        help="the two recordings of a pair are aligned by the lag, within this (s), that best "
        "correlates their acceleration magnitudes (Kong Sec. 2.3) (0.5)",
    )
    calibrate.add_argument(
        "--pairs",
        default="{}",
        help='Obj 2 segment pairs as JSON: {"name": {"segments": [a, b], "t_ap": [...]}}',
    )
    _add_trim_options(calibrate)
    calibrate.set_defaults(run=_calibrate)

    apply = commands.add_parser(
        "apply", help="write body-frame copies of a dataset's recordings into a new folder"
    )
    apply.add_argument("dataset")
    apply.add_argument("--calibrations", required=True, help="CSV of `aceval calibrate`")
    apply.add_argument("--out", required=True, help="new folder (never the dataset itself)")
    apply.add_argument("--method", default="kong", help="method whose calibrations to apply (kong)")
    apply.add_argument(
        "--test",
        help="calibration test (default: per IMU, the first test of calibrates.tsv "
        "with a valid all-repetitions calibration)",
    )
    apply.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    apply.add_argument(
        "--other-dataset",
        action="store_true",
        help="apply calibrations made from other recordings than this dataset's (refused otherwise)",
    )
    apply.set_defaults(run=_apply)

    angles = commands.add_parser("angles", help="Kong Obj 3-5 error angles from calibration tables")
    angles.add_argument("--calibrations", nargs="+", required=True)
    angles.add_argument("--out", required=True)
    angles.add_argument("--test-retest-k", type=int, default=3)
    angles.set_defaults(run=_angles)

    for name, helper in (
        (
            "table",
            "one table, CSV and Markdown, the published values beside (aceval.report.outputs)",
        ),
        ("figure", "one figure as PNG (aceval.report.outputs)"),
    ):
        command = commands.add_parser(name, help=helper)
        command.add_argument(
            "name",
            help=f"the {name}'s name in aceval.report.outputs (Kong's also by number: 3 = {name}3)",
        )
        command.add_argument(
            "--dataset", required=True, help="dataset folder (for its name and sensor sets)"
        )
        _add_table_inputs(command)
        command.add_argument("--angles", help="angles CSV of `aceval angles`")
        if name == "table":
            command.add_argument("--csv", required=True)
            command.add_argument("--md", required=True)
            command.set_defaults(run=_table)
        else:
            command.add_argument("--out", required=True)
            command.set_defaults(run=_figure)

    outputs = commands.add_parser(
        "outputs",
        help="a dataset's results folder in one process: angles, every table and figure of its "
        "analyses, SUMMARY.md and validation.txt",
    )
    outputs.add_argument("--dataset", required=True, help="dataset folder")
    outputs.add_argument("--results", required=True, help="the dataset's results folder")
    outputs.add_argument(
        "--analyses",
        nargs="+",
        required=True,
        help="kong, box, ricci, methods, truth, loose_reference",
    )
    _add_table_inputs(outputs)
    outputs.add_argument(
        "--findings", nargs="*", default=[],
        help="findings of the validation (tab-separated: level, where, cause): validation.txt",
    )  # fmt: skip
    outputs.add_argument(
        "--kinds",
        nargs="+",
        choices=["table", "figure"],
        default=["table", "figure"],
        help="what to write: tables (with angles.csv, SUMMARY.md, validation.txt), figures, or both",
    )
    outputs.add_argument("--test-retest-k", type=int, default=3, help="Obj 4: k of k-of-n (3)")
    outputs.add_argument(
        "--peers", nargs="*", default=[], help="peer tools' calibrations (workflow/peers/, CSV)"
    )
    outputs.add_argument(
        "--angles", nargs="*", default=[],
        help="Obj 3-5 angles of every subject (calibrate --angles-out; default: computed here); "
        "with --retest-units too, only the calibrations from all repetitions are read",
    )  # fmt: skip
    outputs.add_argument(
        "--retest-units",
        nargs="*",
        default=[],
        help="every method's test-retest units, CSVs of calibrate --retest-out (default: computed "
        "here)",
    )
    outputs.add_argument(
        "--note", action="append", default=[], help="a line for SUMMARY.md under the counts"
    )
    outputs.set_defaults(run=_outputs)

    args = parser.parse_args(argv)
    from aceval.data.safety import UnsafeOutputError, check_outputs, exit_cleanly_on_sigterm, fail

    if argv is None:  # a command-line run (not a call from Python): SIGTERM cleans up
        exit_cleanly_on_sigterm()
    try:
        check_outputs(*_outputs_and_inputs(args))
    except UnsafeOutputError as exc:
        return fail(args.command, exc)
    return args.run(args)


#: options that name what a command writes, and what it reads (``check_outputs`` keeps them apart)
OUTPUT_OPTIONS = {
    "out": "--out",
    "csv": "--csv",
    "md": "--md",
    "results": "--results",
    "recordings_out": "--recordings-out",
    "axes_out": "--axes-out",
    "correlations_out": "--correlations-out",
    "pairs_out": "--pairs-out",
    "findings_out": "--findings-out",
    "angles_out": "--angles-out",
    "retest_out": "--retest-out",
    "plan_out": "--plan-out",
}
INPUT_OPTIONS = {
    "dataset": "dataset",
    "src": "source",
    "sensors": "--sensors",
    "vicon": "--vicon",
    "calibrations": "--calibrations",
    "correlations": "--correlations",
    "axes": "--axes",
    "angles": "--angles",
    "retest_units": "--retest-units",
    "findings": "--findings",
    "peers": "--peers",
}
#: commands whose --out is a folder written as a whole
FOLDER_COMMANDS = {"simulate", "import", "apply"}


def _outputs_and_inputs(args) -> tuple[dict, dict, tuple]:
    outputs = {
        flag: getattr(args, name)
        for name, flag in OUTPUT_OPTIONS.items()
        if getattr(args, name, None)
    }
    inputs = {}
    for name, label in INPUT_OPTIONS.items():
        value = getattr(args, name, None)
        for k, path in enumerate(value if isinstance(value, list) else [value] if value else []):
            inputs[f"{label}[{k}]" if isinstance(value, list) else label] = path
    if args.command == "outputs":  # a results folder, written file by file: it holds its own
        # intermediates (calibrations/, correlations/), and must not hold or sit in the dataset
        return outputs, {"dataset": args.dataset}, ("--results",)
    return outputs, inputs, ("--out",) if args.command in FOLDER_COMMANDS else ()


if __name__ == "__main__":
    sys.exit(main())
