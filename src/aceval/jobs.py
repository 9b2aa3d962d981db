"""The work of a calibration job: a unit's subjects read once (or taken from memory), checked,
calibrated, and every table of the pass written (:func:`calibrate_unit`: ``aceval calibrate``);
and the workflow's job per dataset (:func:`dataset_job`: ``aceval batches``), which makes the
dataset (simulates or imports it) or reads it where it lies, validates it and calibrates its
subjects in batches, each batch in a worker process forked from the job (its imports paid
once), a simulated batch from the recordings its worker has just simulated, in memory (the
files are written all the same: users and the peers read them). The job's outputs are put in
place together when everything is done, or none of them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from aceval.data.safety import FileSet

if TYPE_CHECKING:  # imported where used: `aceval --help` needs none of them
    import pandas as pd

    from aceval.signals.segmentation import TrimParams

#: a unit's files in a dataset job's calibrations folder: option of `aceval calibrate` -> name
UNIT_FILES = {
    "out": "{unit}.csv",
    "recordings_out": "{unit}_recordings.csv",
    "axes_out": "{unit}_axes.csv",
    "findings_out": "{unit}_findings.tsv",
    "correlations_out": "{unit}_correlations.csv",
    "angles_out": "{unit}_angles.csv",
    "retest_out": "{unit}_retest.csv",
    "plan_out": "{unit}_plan.json",
}


#: every table `aceval calibrate` can write, by the option that names its file
OUTPUTS = (
    "out",
    "recordings_out",
    "axes_out",
    "pairs_out",
    "correlations_out",
    "findings_out",
    "angles_out",
    "retest_out",
    "plan_out",
)


@dataclasses.dataclass(frozen=True)
class CalibrationRequest:
    """What a calibration job is asked (:func:`calibrate_unit`): the ``dataset`` as named (its
    messages), the ``subjects`` (None: all) and motion ``tests`` (None: all) to read, the
    trimmer's parameters ``trim`` and the Obj 1-2 ``segment_pairs``, ``max_lag_s`` and ``mode``
    of the correlations, the ``subsets`` and ``retest_k`` of the calibrations and the ``method``
    kept (``--method``), ``allow_empty`` (no calibration is no error) and ``outputs``: option of
    :data:`OUTPUTS` -> the file to write (None: not asked for).
    """

    dataset: str
    subjects: list[str] | None
    tests: list[str] | None
    trim: TrimParams
    segment_pairs: dict
    max_lag_s: float
    mode: str
    subsets: str
    retest_k: int | None
    method: str
    allow_empty: bool
    outputs: dict

    @classmethod
    def of(cls, args) -> CalibrationRequest:
        """The request of `aceval calibrate`'s arguments, or of `aceval batches`' (which has no
        choice of subjects, tests, subsets or methods, nor files of its own: all of them).
        """
        return cls(
            dataset=str(args.dataset),
            subjects=getattr(args, "subject", None),
            tests=getattr(args, "tests", None),
            trim=trim_params(args),
            segment_pairs=json.loads(args.pairs),
            max_lag_s=args.max_lag_s,
            mode=args.mode,
            subsets=getattr(args, "subsets", "all"),
            retest_k=args.retest_k,
            method=getattr(args, "method", "all"),
            allow_empty=getattr(args, "allow_empty", True),
            outputs={option: getattr(args, option, None) for option in OUTPUTS},
        )


def progress(done: int, total: int, what: str) -> None:
    """A one-line progress bar on stderr (only on a terminal: logs stay clean)."""
    if sys.stderr.isatty():
        filled = int(30 * done / total)
        print(
            f"\r[{'#' * filled}{'.' * (30 - filled)}] {done}/{total} {what}",
            end="" if done < total else "\n",
            file=sys.stderr,
            flush=True,
        )


def trim_params(args):
    """The movement trimmer's parameters (Kong Fig. 5) of a command's options."""
    import numpy as np

    from aceval.signals.segmentation import TrimParams

    return TrimParams(
        threshold=args.trim_threshold,
        closing_s=args.closing_s,
        window_s=args.window_s,
        min_peak_rad_s=np.radians(args.min_peak_deg_s),
    )


def findings_table(report) -> pd.DataFrame:
    """The file findings of a pass as a table (level, where, cause)."""
    import pandas as pd

    return pd.DataFrame(
        [(f.level, f.where, f.cause) for f in report.findings], columns=["level", "where", "cause"]
    )


def chosen_methods(choice: str) -> list[str]:
    """The ``method`` values of the calibrations table that ``--method choice`` keeps."""
    from aceval.methods import registry

    return registry.own() if choice == "all" else [choice]


# --- one unit: `aceval calibrate` -----------------------------------------------------------


def calibrate_unit(
    request: CalibrationRequest, dataset, files, memory: dict | None = None, root=None
) -> int:
    """`aceval calibrate`'s work once its inputs and outputs are checked: the subjects of the
    ``request`` of ``dataset`` read once (``memory``: recordings.tsv path -> values held already,
    :func:`aceval.signals.reduction.reduce_recordings`), checked and calibrated, and the tables
    it asks for written through ``files`` (:class:`aceval.data.safety.FileSet`, or anything
    with its ``write``);
    ``root``: the dataset's folder as the peers' plan names it (default: where it is read).
    """
    import pandas as pd

    from aceval.calibrate.pipeline import calibrate
    from aceval.calibrate.plan import imu_checks
    from aceval.calibrate.table import AXES_COLUMNS, CALIBRATION_COLUMNS
    from aceval.evaluation.correlations import correlations
    from aceval.report.summary import calibration_screen

    summaries, pairs, report = _read_subjects(request, dataset, memory)
    if not report.ok:
        print(
            f"aceval calibrate: {request.dataset}: recording files that cannot be used; no file "
            f"written:\n{report.format()}",
            file=sys.stderr,
        )
        return 1
    unusable = summaries[summaries["flag"] != ""] if len(summaries) else summaries
    for message in unusable.get("message", []):
        print(f"aceval calibrate: left out {message}", file=sys.stderr)
    sensors = imu_checks(dataset, summaries, pairs) if len(summaries) else {}
    calibrations, axes = (
        calibrate(dataset, summaries, request.subsets, request.retest_k, sensors=sensors)
        if len(summaries)
        else (pd.DataFrame(columns=CALIBRATION_COLUMNS), pd.DataFrame(columns=AXES_COLUMNS))
    )
    calibrations = _for_the_user(calibrations, dataset, request.method)
    if calibrations.empty and not request.allow_empty:
        print(
            f"aceval calibrate: nothing to calibrate in {request.dataset}: "
            f"{_why_nothing(unusable, summaries)}; no file written",
            file=sys.stderr,
        )
        return 1
    tables = {"out": calibrations, "recordings_out": summaries, "axes_out": axes}
    tables["pairs_out"] = pairs
    if request.outputs["correlations_out"]:
        tables["correlations_out"] = correlations(
            dataset, calibrations, pairs, request.mode, request.segment_pairs
        )
    _write_tables(request, files, tables, report, dataset, root or dataset.root)
    _say_findings(report, sensors)
    out = request.outputs["out"]
    screen = calibration_screen(calibrations, len(unusable), out, dataset.ground_truth)
    print(screen, file=sys.stderr)
    return 0


def _read_subjects(request: CalibrationRequest, dataset, memory: dict | None):
    """The one pass over the chosen subjects' recordings: ``(summaries, pairs, report)``."""
    from aceval.data.contract import ValidationReport
    from aceval.signals.reduction import reduce_recordings

    r = request
    subjects = r.subjects if r.subjects is not None else list(dataset.subjects.index)
    summaries, pairs, report = [], [], ValidationReport(dataset.name)
    for done, subject in enumerate(subjects, start=1):
        reduced = reduce_recordings(
            dataset, subject, r.trim, r.tests, r.segment_pairs, r.max_lag_s, memory
        )
        summaries.append(reduced.summaries)
        pairs.append(reduced.pairs)
        report.findings += reduced.report.findings
        progress(done, len(subjects), "subjects read")
    return _concat_tables(summaries), _concat_tables(pairs), report


def _for_the_user(calibrations, dataset, method: str):
    """The calibrations of the chosen ``--method``, each with its error to the dataset's ground
    truth (evaluation's join: the command reports both) and the fingerprint of the recordings it
    was made from (what ``aceval apply`` checks).
    """
    if not len(calibrations):
        return calibrations
    from aceval.apply import FINGERPRINT, recordings_fingerprint
    from aceval.evaluation.methods_comparison import with_truth

    calibrations = with_truth(calibrations, dataset.ground_truth)
    calibrations = calibrations[calibrations["method"].isin(chosen_methods(method))]
    calibrations = calibrations.reset_index(drop=True)
    fingerprints = {s: recordings_fingerprint(dataset, s) for s in calibrations["subject"].unique()}
    calibrations[FINGERPRINT] = calibrations["subject"].map(fingerprints)
    return calibrations


def _why_nothing(unusable, summaries) -> str:
    """Why a dataset gave no calibration."""
    if len(unusable):
        return f"{len(unusable)} recording(s) were left out (listed above) and none remained"
    if len(summaries):
        return (
            "no subject has a static test and a motion test that calibrates one of its IMUs "
            "(calibrates.tsv)"
        )
    return "no recording of a test that calibrates an IMU"


def _say_findings(report, sensors: dict) -> None:
    """The files' warnings and what the checks found about each sensor (``sensors``:
    :func:`aceval.calibrate.plan.imu_checks`; its calibrations are flagged), on stderr.
    """
    if report.warnings:
        print(f"aceval calibrate: {len(report.warnings)} file warning(s):", file=sys.stderr)
        print("\n".join(map(str, report.warnings)), file=sys.stderr)
    for verdict in sensors.values():
        if verdict["message"]:
            print(f"aceval calibrate: flagged {verdict['message']}", file=sys.stderr)


def _write_tables(request: CalibrationRequest, files, tables: dict, report, dataset, root) -> None:
    """Stage every output of the ``request`` in ``files``: the ``tables`` (by the option that
    names each file), the findings, the Obj 3-5 angles and test-retest units, and the peers'
    plan (naming the dataset's folder ``root``).
    """
    outputs = request.outputs
    for option, table in tables.items():
        if outputs[option]:
            files.write(outputs[option], lambda tmp, t=table: t.to_csv(tmp, index=False))
    if outputs["findings_out"]:
        findings = findings_table(report)
        files.write(
            outputs["findings_out"], lambda tmp: findings.to_csv(tmp, sep="\t", index=False)
        )
    if outputs["angles_out"] or outputs["retest_out"]:
        _write_angles(outputs, request.retest_k, files, tables["out"])
    if outputs["plan_out"]:
        from aceval.calibrate.peer_plan import calibration_plan

        plan = calibration_plan(dataset, tables["recordings_out"], request.retest_k, Path(root))
        text = json.dumps(plan, indent=1)
        files.write(outputs["plan_out"], lambda tmp: Path(tmp).write_text(text + "\n"))


def _write_angles(outputs: dict, retest_k: int | None, files, calibrations) -> None:
    """Kong's Obj 3-5 angles (--angles-out) and every method's test-retest units (--retest-out)
    of this job's subjects, from its ``calibrations``: the only tables that need the calibrations
    from subsets of repetitions, so the results jobs read only those from all repetitions.
    """
    from aceval.evaluation.methods_comparison import retest_units
    from aceval.evaluation.objectives import all_angles

    if outputs["angles_out"]:
        table = all_angles(calibrations, retest_k)
        files.write(outputs["angles_out"], lambda tmp: table.to_csv(tmp, index=False))
    if outputs["retest_out"]:
        table = retest_units(calibrations, retest_k)
        files.write(outputs["retest_out"], lambda tmp: table.to_csv(tmp, index=False))


def _concat_tables(parts: list) -> pd.DataFrame:
    import pandas as pd

    non_empty = [p for p in parts if len(p)]
    return (
        pd.concat(non_empty, ignore_index=True)
        if non_empty
        else (parts[0] if parts else pd.DataFrame())
    )


# --- the workflow's job per dataset: `aceval batches` ---------------------------------------


class _JobFailed(Exception):
    """A dataset job stopped on bad input (``code``; its message is said): nothing is put in
    place.
    """

    def __init__(self, code: int):
        super().__init__(code)
        self.code = code


class _Direct:
    """Writes each file at its own path: a unit's files go into a staging folder that is put in
    place as a whole.
    """

    @staticmethod
    def write(path, write) -> None:
        write(path)


#: what the workers of :func:`dataset_job` read (set before they fork)
_JOB: dict = {}


def dataset_job(args) -> int:
    """``aceval batches``: the dataset ``args.dataset`` made (``--simulate``, ``--import``) or
    read, validated, and its subjects calibrated in batches of ``args.subjects_per_job`` by
    ``args.jobs`` workers; into ``args.results``: ``calibrations/`` (each batch's tables,
    :data:`UNIT_FILES`) and ``validation/sheets.tsv`` (the validation's findings).
    """
    results, generated = Path(args.results), bool(args.simulate or args.import_format)
    sheets = results / "validation" / "sheets.tsv"
    try:
        with FileSet([sheets]) as files:
            folder = files.folder(results / "calibrations", args.force)
            root = files.folder(args.dataset, args.force) if generated else Path(args.dataset)
            table = findings_table(_make_and_calibrate(args, root, folder))
            files.write(sheets, lambda tmp: table.to_csv(tmp, sep="\t", index=False))
    except _JobFailed as failed:  # nothing was put in place
        return failed.code
    print(f"aceval batches: wrote {results}" + (f" and {args.dataset}" if generated else ""))
    return 0


def _make_and_calibrate(args, root: Path, folder: Path):
    """The dataset made at ``root`` (or read there), validated and calibrated into ``folder``:
    the validation's report (:func:`dataset_job`); _JobFailed on bad input.
    """
    from aceval.data.units import subject_batches

    simulation = writer = dataset = report = None
    if args.simulate:
        simulation, writer = _simulation(args, root)
        subjects = simulation.subjects
    else:
        if args.import_format:
            _import(args, root)
        dataset, report = _validated(root, "headers")
        subjects = list(dataset.subjects.index)
    units = subject_batches(subjects, args.subjects_per_job)
    request = CalibrationRequest.of(args)
    _JOB.update(request=request, units=units, root=root, folder=folder, dataset=dataset)
    _JOB.update(simulation=simulation)
    try:
        for code, text, rows, truth in _each_unit(list(units), args.jobs):
            print(text, end="", file=sys.stderr)
            if code:
                raise _JobFailed(code)
            if writer is not None:
                writer.append(rows, truth)
    finally:
        _JOB.clear()
    if writer is None:
        return report
    writer.close()
    return _validated(root, False)[1]


def _validated(root: Path, check_files):
    """The dataset at ``root`` and its validation report (``check_files``:
    :func:`aceval.data.dataset.validate`), said as ``aceval validate`` says it; _JobFailed when
    it has errors.
    """
    from aceval.data.dataset import validate

    dataset, report = validate(root, check_files=check_files)
    print(report.format(), file=sys.stdout if report.ok else sys.stderr)
    if not report.ok:
        raise _JobFailed(1)
    return dataset, report


def _simulation(args, root: Path):
    """The simulated dataset of ``args.simulate`` (its sheets written at ``root``; its subjects
    are simulated by the workers) and the writer that gathers their sheet rows.
    """
    from aceval.data.writer import DatasetWriter
    from aceval.simulate import SIMULATIONS, SimOptions

    options = SimOptions(repetitions=args.repetitions, file_format="parquet")
    kwargs = {"n_subjects": args.subjects} if args.subjects is not None else {}
    kwargs |= {"name": args.name} if args.name else {}
    simulation = SIMULATIONS[args.simulate](args.seed, options=options, **kwargs)
    writer = DatasetWriter(root, simulation.meta, file_format=options.file_format)
    simulation.sheets(writer)
    return simulation, writer


def _import(args, root: Path) -> None:
    """The foreign recordings of ``args.import_format`` imported into ``root`` (as ``aceval
    import`` does); _JobFailed naming the cause when they cannot be.
    """
    from aceval.data.errors import CalibrationError
    from aceval.importers import FormatError
    from aceval.importers.run import run_import

    what = args.import_format
    options = dict(
        format=what,
        src=args.source,
        sensors=args.sensors,
        name=args.name,
        subject=args.import_subject,
        vicon=args.vicon,
    )
    try:
        report = run_import(root, options)
    except (FormatError, CalibrationError, OSError) as exc:
        print(f"aceval import {what}: {exc}; nothing written", file=sys.stderr)
        raise _JobFailed(1) from None
    for note in report.notes:
        print(f"aceval import {what}: {note}", file=sys.stderr)
    print(report.summary(), file=sys.stderr)


def _each_unit(names: list[str], jobs: int):
    """:func:`_unit` of each unit, in order, by ``jobs`` worker processes forked from this one
    (their imports paid here once; in this process for one worker or one unit).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    workers = min(jobs, len(names))
    if workers <= 1:
        yield from map(_unit, names)
        return
    _preload()
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"))
    try:
        yield from pool.map(_unit, names)
    finally:  # on an error or SIGTERM: no worker may still write once the caller cleans up
        pool.shutdown(wait=True, cancel_futures=True)


def _preload() -> None:
    """Import what every unit's calibration imports, once, before the workers fork."""
    import aceval.apply  # noqa: F401
    import aceval.calibrate.peer_plan  # noqa: F401
    import aceval.calibrate.pipeline  # noqa: F401
    import aceval.evaluation.correlations  # noqa: F401
    import aceval.evaluation.methods_comparison  # noqa: F401
    import aceval.evaluation.objectives  # noqa: F401
    import aceval.report.summary  # noqa: F401
    import aceval.signals.reduction  # noqa: F401
    from aceval.methods import registry

    registry.classes()  # every method's module
    import pyarrow.parquet  # noqa: F401  (the recordings read, or simulated and written)
    import scipy.signal  # noqa: F401  (the walking tests' band-pass filter)


def _unit(name: str) -> tuple[int, str, str, list]:
    """One unit of :func:`dataset_job`: its subjects simulated (their files written, their
    values kept) when the dataset is, then calibrated into the job's folder:
    ``(exit code, what it said on stderr, its recordings.tsv rows, its ground-truth rows)``.
    """
    request, subjects = _JOB["request"], _JOB["units"][name]
    dataset, memory, rows, truth = _JOB["dataset"], None, "", []
    said = io.StringIO()
    with contextlib.redirect_stderr(said):
        if _JOB["simulation"] is not None:
            dataset, memory, rows, truth = _simulated_unit(_JOB["simulation"], subjects)
        files = {
            option: str(_JOB["folder"] / p.format(unit=name)) for option, p in UNIT_FILES.items()
        }
        unit = dataclasses.replace(
            request,
            subjects=subjects,
            tests=None,
            subsets="all",
            method="all",
            allow_empty=True,
            outputs=request.outputs | files | {"pairs_out": None},
        )
        code = calibrate_unit(unit, dataset, _Direct(), memory, root=Path(request.dataset))
    return code, said.getvalue(), rows, truth


def _simulated_unit(simulation, subjects: list[str]):
    """``subjects`` of ``simulation`` written into the job's dataset folder:
    ``(the dataset of their recordings, their values as the files read back, the rows of
    recordings.tsv, those of ground_truth.tsv)``.
    """
    from aceval.data.dataset import read_sheets
    from aceval.data.writer import DatasetWriter, sheet_texts

    root = _JOB["root"]
    writer = DatasetWriter(root, simulation.meta, sheets=False, file_format="parquet", keep=True)
    for subject in subjects:
        simulation.subject(simulation.subjects.index(subject), writer)
    rows, truth = writer.collected()
    dataset, report = read_sheets(root, texts=sheet_texts(rows, truth))
    if not report.ok:  # the simulator's own sheets: never, unless it has a bug
        raise RuntimeError(f"the simulated sheets do not validate:\n{report.format()}")
    return dataset, writer.kept, rows, truth
