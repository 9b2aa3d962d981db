"""Command line: ``aceval simulate|import|validate|right-axis|calibrate|batches|apply|angles|table|
figure|outputs``
(also ``python -m aceval``). The workflow's rules are thin calls of these commands.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from aceval import commands as work
from aceval.methods import registry
from aceval.report.outputs import ANALYSES


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
    command.add_argument(
        "--tolerance-deg",
        type=float,
        help="the heading accuracy (deg) the decision's verdicts are judged against (default 5: "
        "aceval.evaluation.decision_rules)",
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


def _add_simulate(commands) -> None:
    """The ``simulate`` command's arguments."""
    simulate = commands.add_parser(
        "simulate", help="write a SIMULATED dataset in the contract, with ground truth"
    )
    simulate.add_argument("protocol", choices=["kong", "ricci", "box"])
    simulate.add_argument("--out", required=True, help="output folder (created)")
    simulate.add_argument("--seed", type=int, default=0)
    simulate.add_argument(
        "--name", help="the dataset's name in dataset.yaml (default: kong_sim, ricci_sim, box_sim)"
    )
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
        "--assumed-variability",
        action="store_true",
        help="Kong: the walk's lower leg as assumed before its variability was measured on real "
        "recordings (sagittal, the same heading every repetition: docs/simulation.md), to compare",
    )
    simulate.add_argument(
        "--jobs", type=int, default=1, help="subjects simulated side by side (same output; 1)"
    )
    simulate.add_argument(
        "--format",
        choices=["parquet", "csv"],
        default="parquet",
        help="the recordings' files: Parquet (signals in float32: half the bytes, written and "
        "read faster) or CSV with 6 significant digits, as a lab's export (parquet)",
    )
    simulate.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    simulate.set_defaults(run=work.simulate)


def _add_importer(commands) -> None:
    """The ``importer`` command's arguments."""
    importer = commands.add_parser(
        "import",
        help="convert recordings in a foreign format into a dataset folder "
        "(with import_report.tsv: what was imported, flagged or left out, and why)",
    )
    importer.add_argument("format", choices=["hugadb", "xsens", "table", "qmt", "gaitmap"])
    importer.add_argument(
        "src",
        help="hugadb: the folder of HuGaDB_*.txt; xsens: the folder of MT Manager exports; table: "
        "the folder of any vendor's delimited-text exports",
    )
    importer.add_argument(
        "--mapping",
        help="table: the mapping file (YAML) that says how the exports are laid out: columns, "
        "units, rate, header lines, sensor from file name or columns (docs/your_data.md)",
    )
    importer.add_argument("--out", required=True, help="output dataset folder (created)")
    importer.add_argument(
        "--sensors",
        help="xsens, table: sensor sheet (sensor_id segment side, and imu sensor_set region "
        "right_axis: all required for one trial without --trials); xsens --trials without it: "
        "the sheet the exports' sensorspec files propose is written and the import stops",
    )
    importer.add_argument(
        "--trials",
        help="xsens, table: a lab's sheet of trials (subject, trial, test, [rep, static, "
        "first_phase, calibrates, start_s, end_s]): every subject and trial in one import "
        "(docs/your_data.md)",
    )
    importer.add_argument(
        "--rate",
        type=float,
        help="xsens, table: samples per second, for exports that do not say it (checked against "
        "what they say, and a rate given only by hand against the recordings' gyroscopes and "
        "accelerometers)",
    )
    importer.add_argument(
        "--trim-to-shared",
        action="store_true",
        help="xsens, table: cut the sensors of a trial to the samples they all share "
        "(PacketCounter, time); without it a trial whose sensors differ is refused",
    )
    importer.add_argument("--subject", default="S01", help="xsens, one trial: subject name (S01)")
    importer.add_argument(
        "--vicon", help="xsens: Vicon .mat of the same trial: writes ground_truth.tsv (see docs)"
    )
    importer.add_argument("--name", help="dataset name (default: the format)")
    importer.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    importer.set_defaults(run=work.import_dataset)


def _add_validate(commands) -> None:
    """The ``validate`` command's arguments."""
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
    validate.set_defaults(run=work.validate)


def _add_right_axis(commands) -> None:
    """The ``right-axis`` command's arguments."""
    right_axis = commands.add_parser(
        "right-axis",
        help="propose each IMU's right_axis from its recordings (how sure, what gave its sign or "
        "that the data cannot tell it, and which imus.tsv cell holds it)",
    )
    right_axis.add_argument("dataset")
    right_axis.add_argument("--out", help="write the proposals here as a tab-separated table")
    _add_trim_options(right_axis)
    right_axis.set_defaults(run=work.right_axis)


def _add_calibrate(commands) -> None:
    """The ``calibrate`` command's arguments."""
    calibrate = commands.add_parser(
        "calibrate",
        help="calibrate a dataset: Kong (every subset of repetitions) and the axis methods "
        "(Ricci LM, align_vectors, TRIAD); Ricci's functional design when functional_axes.tsv exists",
    )
    calibrate.add_argument("dataset")
    calibrate.add_argument("--subject", nargs="+", help="only these subjects (default: all)")
    calibrate.add_argument("--out", required=True, help="calibrations CSV")
    calibrate.add_argument(
        "--method",
        choices=list(work.method_choices()),
        default="all",
        help="; ".join(f"{name}: {text}" for name, text in work.method_choices().items()),
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
        "--retest-k",
        type=int,
        default=3,
        help="the axis methods (and the plan) also from every subset of this many repetitions "
        "(Obj 4's test-retest for every method; 0: none) (3)",
    )
    calibrate.add_argument(
        "--allow-empty",
        action="store_true",
        help="write a table with no rows (and exit 0) when nothing can be calibrated (the workflow)",
    )
    _add_calibrate_outputs(calibrate)
    _add_pair_options(calibrate)
    _add_trim_options(calibrate)
    calibrate.set_defaults(run=work.calibrate)


def _add_calibrate_outputs(calibrate) -> None:
    """The tables of the calibrate pass beside the calibrations, each on request."""
    outputs = {
        "--recordings-out": "per-recording summary CSV (what was kept or left out, and why)",
        "--axes-out": "functional axes CSV: axis and rho per subject, IMU and test",
        "--correlations-out": "Kong Obj 1-2 correlations of the calibrated recording pairs (from "
        "the pair moments)",
        "--pairs-out": "the moments of every time-aligned Obj 1-2 recording pair (CSV)",
        "--findings-out": "file warnings of the pass (tab-separated)",
        "--angles-out": "Kong's Obj 3-5 angles of these subjects (as `aceval angles`, CSV)",
        "--retest-out": "every method's Obj 4 test-retest per subject x set x IMU x test (CSV; "
        "`aceval outputs --retest-units`)",
        "--plan-out": "what a peer tool calibrates (JSON for workflow/peers/: files, right axes, "
        "subsets)",
    }
    for option, text in outputs.items():
        calibrate.add_argument(option, help=text)


def _add_pair_options(calibrate) -> None:
    """How Kong's Obj 1-2 pairs are aligned and correlated."""
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


def _add_batches(commands) -> None:
    """The ``batches`` command's arguments (the workflow's job per dataset)."""
    batches = commands.add_parser(
        "batches",
        help="the workflow's job per dataset: simulate or import it (or read it where it lies), "
        "validate it and calibrate its subjects in batches, each in a worker process, into a "
        "results folder's calibrations/ and validation/sheets.tsv",
    )
    batches.add_argument(
        "dataset", help="the dataset folder: read, or written (with --simulate or --import)"
    )
    batches.add_argument("--results", required=True, help="the dataset's results folder")
    made = batches.add_mutually_exclusive_group()
    made.add_argument("--simulate", choices=["kong", "ricci", "box"], help="simulate it first")
    made.add_argument(
        "--import",
        dest="import_format",
        choices=["hugadb", "xsens", "qmt", "gaitmap"],
        help="import it first from --source (as `aceval import`)",
    )
    batches.add_argument("--seed", type=int, default=0, help="--simulate: the seed (0)")
    batches.add_argument("--subjects", type=int, help="--simulate: subjects (the paper's)")
    batches.add_argument(
        "--repetitions", type=int, default=5, help="--simulate: repetitions of each motion test"
    )
    batches.add_argument("--name", help="--simulate, --import: the dataset's name")
    batches.add_argument("--source", help="--import: the foreign recordings")
    batches.add_argument("--sensors", help="--import: sensor sheet (as `aceval import`)")
    batches.add_argument("--vicon", help="--import xsens: Vicon .mat of the same trial")
    batches.add_argument(
        "--import-subject", default="S01", help="--import xsens, one trial: subject name (S01)"
    )
    batches.add_argument(
        "--subjects-per-job", type=int, default=1, help="subjects per batch (1: one per subject)"
    )
    batches.add_argument("--jobs", type=int, default=1, help="batches calibrated side by side (1)")
    batches.add_argument(
        "--retest-k",
        type=int,
        default=3,
        help="the axis methods (and the plan) also from every subset of this many repetitions",
    )
    batches.add_argument(
        "--force", action="store_true", help="replace output folders aceval wrote before"
    )
    _add_pair_options(batches)
    _add_trim_options(batches)
    batches.set_defaults(run=work.batches)


def _add_apply(commands) -> None:
    """The ``apply`` command's arguments."""
    apply = commands.add_parser(
        "apply", help="write body-frame copies of a dataset's recordings into a new folder"
    )
    apply.add_argument("dataset")
    source = apply.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--decision",
        help="the workflow's decision (results/<dataset>/tables/decision.csv): each IMU's "
        "chosen calibration; 'no trustworthy calibration' is not applied, 'not within "
        "tolerance' is, with a warning",
    )
    source.add_argument("--calibrations", help="CSV of `aceval calibrate`: one method's")
    apply.add_argument("--out", required=True, help="new folder (never the dataset itself)")
    apply.add_argument(
        "--include-untrusted",
        action="store_true",
        help="with --decision: also apply the calibration it names for an IMU it calls 'no "
        "trustworthy calibration' (said per IMU)",
    )
    kong = registry.paper_method("kong2016")
    apply.add_argument(
        "--method", help=f"with --calibrations: method whose calibrations to apply ({kong})"
    )
    apply.add_argument(
        "--test",
        help="with --calibrations: calibration test (default: per IMU, the first test of "
        "calibrates.tsv with a valid calibration from all its repetitions)",
    )
    apply.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    apply.add_argument(
        "--allow-subset",
        action="store_true",
        help="with --calibrations: where no calibration from all of an IMU's repetitions is "
        "valid, apply its largest unflagged subset (said per IMU; without it such an IMU is left "
        "out and named)",
    )
    apply.add_argument(
        "--other-dataset",
        action="store_true",
        help="apply calibrations made from other recordings than this dataset's (refused otherwise)",
    )
    apply.set_defaults(run=work.apply)


def _add_angles(commands) -> None:
    """The ``angles`` command's arguments."""
    angles = commands.add_parser("angles", help="Kong Obj 3-5 error angles from calibration tables")
    angles.add_argument("--calibrations", nargs="+", required=True)
    angles.add_argument("--out", required=True)
    angles.add_argument("--test-retest-k", type=int, default=3)
    angles.set_defaults(run=work.angles)


def _add_table_and_figure(commands) -> None:
    """The ``table and figure`` command's arguments."""
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
            command.set_defaults(run=work.table)
        else:
            command.add_argument("--out", required=True)
            command.set_defaults(run=work.figure)


def _add_outputs(commands) -> None:
    """The ``outputs`` command's arguments."""
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
        choices=ANALYSES,
        help=", ".join(ANALYSES),
    )
    _add_table_inputs(outputs)
    outputs.add_argument(
        "--findings",
        nargs="*",
        default=[],
        help="findings of the validation (tab-separated: level, where, cause): validation.txt",
    )
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
        "--recordings",
        nargs="*",
        default=[],
        help="the one pass's summaries (calibrate --recordings-out): the peers' direction vote",
    )
    outputs.add_argument(
        "--angles",
        nargs="*",
        default=[],
        help="Obj 3-5 angles of every subject (calibrate --angles-out; default: computed here); "
        "with --retest-units too, only the calibrations from all repetitions are read",
    )
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
    outputs.set_defaults(run=work.outputs)


def main(argv: list[str] | None = None) -> int:
    """Run ``aceval <command>``; returns the exit code (0 ok, 1 bad input, 2 refused)."""
    parser = argparse.ArgumentParser(prog="aceval", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    _add_simulate(commands)
    _add_importer(commands)
    _add_validate(commands)
    _add_right_axis(commands)
    _add_calibrate(commands)
    _add_batches(commands)
    _add_apply(commands)
    _add_angles(commands)
    _add_table_and_figure(commands)
    _add_outputs(commands)

    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # a usage error (2, said on stderr) or --help (0)
        return exc.code
    from aceval.data.safety import exit_cleanly_on_sigterm

    if argv is None:  # a command-line run (not a call from Python): SIGTERM cleans up
        exit_cleanly_on_sigterm()
    try:
        return _run(args)
    except KeyboardInterrupt:  # Ctrl-C: every output staged so far is gone with the stack
        print(f"aceval {args.command}: interrupted (Ctrl-C); no output written", file=sys.stderr)
        return 128 + signal.SIGINT


def _run(args) -> int:
    """The command, its outputs checked first; a fault of the input or the environment (a file
    that cannot be read or written, a full disk, a closed pipe) ends it with one line naming the
    file and the cause, and exit 1 (2: an output refused), never a traceback.
    """
    from aceval.data.errors import InputError, describe_os_error
    from aceval.data.safety import (
        UnsafeOutputError,
        check_distinct,
        check_folder_output,
        check_outputs,
        check_recordings,
        fail,
    )

    try:
        outputs, inputs, folders = _outputs_and_inputs(args)
        check_distinct(outputs, folders)
        check_outputs(outputs, inputs, folders)
        if getattr(args, "dataset", None):
            check_recordings(outputs, args.dataset, folders)
        if args.command in FOLDER_COMMANDS:  # before any work: a link, a file, a full folder
            check_folder_output(Path(args.out), args.force)
        return args.run(args)
    except UnsafeOutputError as exc:
        return fail(args.command, exc)
    except InputError as exc:
        return fail(args.command, exc, 1)
    except BrokenPipeError:  # the reader went away (`aceval validate ... | head`): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return fail(args.command, "its output was closed early (broken pipe)", 1)
    except OSError as exc:
        return fail(args.command, describe_os_error(exc), 1)


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
    "source": "--source",
    "sensors": "--sensors",
    "trials": "--trials",
    "vicon": "--vicon",
    "calibrations": "--calibrations",
    "correlations": "--correlations",
    "axes": "--axes",
    "angles": "--angles",
    "retest_units": "--retest-units",
    "findings": "--findings",
    "peers": "--peers",
    "recordings": "--recordings",
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
    if args.command == "batches":  # a results folder; the dataset an input, or an output folder
        made = args.simulate or args.import_format
        inputs = {k: v for k, v in inputs.items() if not (made and k == "dataset")}
        outputs |= {"dataset": args.dataset} if made else {}
        return outputs, inputs, ("--results", "dataset") if made else ("--results",)
    if args.command == "outputs":  # a results folder, written file by file: it holds its own
        # intermediates (calibrations/, correlations/), and must not hold or sit in the dataset
        return outputs, {"dataset": args.dataset}, ("--results",)
    return outputs, inputs, ("--out",) if args.command in FOLDER_COMMANDS else ()


if __name__ == "__main__":
    sys.exit(main())
