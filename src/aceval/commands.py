"""The work of each ``aceval`` command once its arguments are parsed (:mod:`aceval.cli` parses
them and checks where they write): simulate, import, validate, calibrate, apply, angles, table,
figure, outputs. Each returns the exit code (0 ok, 1 bad input, 2 refused).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from aceval.data.safety import FileSet, UnsafeOutputError
from aceval.jobs import findings_table, progress, trim_params

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


def simulate(args) -> int:
    """`aceval simulate`: a simulated dataset in the contract."""
    from aceval.simulate import GENERATORS, SimOptions

    options = SimOptions(
        noise=not args.no_noise,
        offplane=0.0 if args.no_offplane else 1.0,
        wobble=0.0 if args.no_wobble else 1.0,
        variability="assumed" if args.assumed_variability else "measured",
        repetitions=args.repetitions,
        jobs=args.jobs,
        file_format=args.format,
    )
    kwargs = {"options": options}
    if args.subjects is not None:
        kwargs["n_subjects"] = args.subjects
    if args.name:
        kwargs["name"] = args.name
    return _staged(
        Path(args.out),
        args.force,
        "simulate",
        lambda folder: GENERATORS[args.protocol](folder, args.seed, **kwargs),
    )


def import_dataset(args) -> int:
    """`aceval import`: foreign recordings converted into the contract."""
    from aceval.data.errors import CalibrationError
    from aceval.importers import FormatError
    from aceval.importers.run import run_import

    def write(folder):
        report = run_import(folder, vars(args))
        for note in report.notes:
            print(f"aceval import {args.format}: {note}", file=sys.stderr)
        print(report.summary(), file=sys.stderr)

    try:
        return _staged(Path(args.out), args.force, "import", write)
    except (FormatError, CalibrationError, OSError) as exc:
        print(f"aceval import {args.format}: {exc}; nothing written", file=sys.stderr)
        return 1


def validate(args) -> int:
    """`aceval validate`: every problem of a dataset's sheets and files."""
    from aceval.data.dataset import validate

    _, report = validate(args.dataset, check_files="headers" if args.sheets_only else "all")
    saved = (args.out or args.findings_out) if report.ok else None
    print(report.grouped(saved, args.dataset), file=sys.stdout if report.ok else sys.stderr)
    if report.ok and (args.out or args.findings_out):
        with FileSet([args.out, args.findings_out]) as files:
            if args.out:
                files.write(args.out, lambda tmp: Path(tmp).write_text(report.format() + "\n"))
            if args.findings_out:
                table = findings_table(report)
                files.write(args.findings_out, lambda tmp: table.to_csv(tmp, sep="\t", index=False))
    return 0 if report.ok else 1


def right_axis(args) -> int:
    """`aceval right-axis`: each IMU's right axis as its recordings propose it, beside the declared
    one and the imus.tsv cell that holds it.
    """
    import pandas as pd

    from aceval.data.contract import DatasetError
    from aceval.data.dataset import load_dataset
    from aceval.signals.right_axis import dataset_right_axes

    try:
        dataset = load_dataset(args.dataset)
    except DatasetError as exc:
        print(f"aceval right-axis: {args.dataset} is not a valid dataset:\n{exc}", file=sys.stderr)
        return 1
    table = pd.DataFrame(dataset_right_axes(dataset, trim_params(args)))
    columns = ["sensor_set", "imu", "segment", "side", "declared", "proposed", "verdict"]
    columns += ["agrees", "sign_from", "cell", "evidence"]
    table = table[columns] if len(table) else pd.DataFrame(columns=columns)
    print(table[columns[:-2]].to_string(index=False))
    for row in table.itertuples():
        print(f"{row.sensor_set} {row.imu}: {row.evidence}; {row.cell}")
    differs = table[table["agrees"].str.startswith("no")]
    for row in differs.itertuples():
        print(
            f"aceval right-axis: {row.sensor_set} {row.imu} is declared {row.declared} but its "
            f"recordings point to {row.proposed} ({row.verdict}): check {row.cell}",
            file=sys.stderr,
        )
    if args.out:
        _write_text(args.out, table.to_csv(sep="\t", index=False))
    return 0


def _atomic(path: str | Path, write) -> None:
    from aceval.data.safety import atomic_file

    atomic_file(path, write)


def _write_csv(path, table) -> None:
    _atomic(path, lambda tmp: table.to_csv(tmp, index=False))


def _write_text(path, text: str) -> None:
    _atomic(path, lambda tmp: Path(tmp).write_text(text))


def _read_calibrations(paths, keep=None) -> pd.DataFrame:
    """Calibrations tables (of `aceval calibrate`, or a peer's), each checked for its columns."""
    from aceval.report.results import CALIBRATION_TABLE_COLUMNS, read_tables

    return read_tables(paths, keep, required=CALIBRATION_TABLE_COLUMNS)


def method_choices() -> dict[str, str]:
    """``--method`` of ``aceval calibrate``: each of aceval's own methods in the registry
    (:mod:`aceval.methods.registry`) with its one-line summary, and ``all``.
    """
    from aceval.methods import registry

    own = {name: registry.method(name).summary for name in registry.own()}
    return own | {"all": "every method (default)"}


def calibrate(args) -> int:
    """`aceval calibrate`: every calibration of a dataset, with the pass's other tables on request."""
    from aceval.data.contract import DatasetError
    from aceval.data.dataset import load_dataset
    from aceval.jobs import CalibrationRequest, calibrate_unit

    try:  # the sheets here; each recording file is checked in the pass that reads it
        dataset = load_dataset(args.dataset)
    except DatasetError as exc:
        print(f"aceval calibrate: {args.dataset}: no file written:\n{exc}", file=sys.stderr)
        return 1
    if args.subject is not None:  # '01' is subject '1' (dataset.subject_key)
        args.subject = [dataset.subject_label(s) for s in args.subject]
    unknown = [s for s in args.subject or [] if s not in dataset.subjects.index]
    if unknown:
        print(
            f"aceval calibrate: subject(s) {', '.join(map(repr, unknown))} not in "
            f"{args.dataset}/subjects.tsv",
            file=sys.stderr,
        )
        return 2
    twice = sorted({s for s in args.subject or [] if args.subject.count(s) > 1})
    if twice:
        print(
            f"aceval calibrate: --subject names {', '.join(map(repr, twice))} twice: each "
            "subject's recordings are read once; give each subject once",
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
    request = CalibrationRequest.of(args)
    try:  # every folder writable before the work; all outputs put in place together, or none
        files = FileSet(list(request.outputs.values()))
    except UnsafeOutputError as exc:
        print(f"aceval calibrate: {exc}", file=sys.stderr)
        return 2
    with files:
        return calibrate_unit(request, dataset, files)


def batches(args) -> int:
    """`aceval batches`: the workflow's job per dataset (:func:`aceval.jobs.dataset_job`)."""
    from aceval.jobs import dataset_job

    return dataset_job(args)


def apply(args) -> int:
    """`aceval apply`: body-frame copies of a dataset's recordings (each IMU's calibration from
    the decision, ``--decision``, or one method's from a calibrations file).
    """
    from aceval.apply import ApplyError, apply_calibrations, check_not_applied, choose
    from aceval.data.contract import DatasetError
    from aceval.data.dataset import load_dataset
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
    source = args.decision or args.calibrations
    try:
        chosen, said = choose(dataset, args)
        check_not_applied(dataset, chosen, args.other_dataset, source)
    except ApplyError as exc:
        print(f"aceval apply: {exc}", file=sys.stderr)
        return 1

    def write(folder):
        checked = None if args.other_dataset else source
        for line in said + apply_calibrations(
            dataset, chosen, folder, args.method, progress, checked
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


def angles(args) -> int:
    """`aceval angles`: Kong's Obj 3-5 angles of a calibrations table."""
    from aceval.evaluation.objectives import all_angles

    _write_csv(args.out, all_angles(_read_calibrations(args.calibrations), args.test_retest_k))
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
        _read_calibrations(args.calibrations),
        read_tables(args.axes),
        read_tables(args.correlations),
        read_tables([args.angles] if args.angles else []),
        json.loads(args.paper_names),
        tolerance_deg=args.tolerance_deg,
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


def table(args) -> int:
    """`aceval table`: one output table of the registry."""
    return _single_output(args, "table")


def figure(args) -> int:
    """`aceval figure`: one figure of the registry."""
    return _single_output(args, "figure")


def outputs(args) -> int:
    """``aceval outputs``: a dataset's whole results folder (the workflow's job per dataset)."""
    import json

    from aceval.calibrate.table import full_set_rows
    from aceval.data.contract import Finding, ValidationReport
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
        _read_calibrations(args.calibrations, full_set_rows if precomputed else None),
        read_tables(args.axes),
        read_tables(args.correlations),
        in_angle_order(read_tables(args.angles)) if args.angles else None,
        paper_names=json.loads(args.paper_names),
        peers=_read_calibrations(args.peers),
        test_retest_k=args.test_retest_k,
        retest_units=read_tables(args.retest_units) if args.retest_units else None,
        recordings=read_tables(args.recordings, _direction_columns) if args.peers else None,
        tolerance_deg=args.tolerance_deg,
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


def _direction_columns(summaries):
    """The one pass's summaries' columns the peers' direction vote reads, and no more."""
    from aceval.methods.moments import PHASE_COLUMNS
    from aceval.signals.checks import THIRD_MOMENT_COLUMNS

    keep = ["subject", "sensor_set", "imu", "test", "rep", "kind", "flag"]
    keep += PHASE_COLUMNS + THIRD_MOMENT_COLUMNS
    return summaries[[c for c in keep if c in summaries]]


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
