# Glue between the configuration and the rules: the workflow's plan of the configuration is the
# package's (aceval.workflow_plan: which datasets, where each lives, analyses, peers, subjects per
# job, options); here only what needs Snakemake itself (wildcards, checkpoints, inputs known once
# the sheets are validated).
import os

from aceval.workflow_plan import Configuration, duplicate_keys, read_sheet
from snakemake.logging import logger

for _problem in (p for f in workflow.configfiles for p in duplicate_keys(str(f))):
    raise WorkflowError(f"aceval: a configuration file: {_problem}")
PLAN = Configuration(config, workflow.basedir)
DATASETS = PLAN.datasets
PEERS_DIR = os.path.join(workflow.basedir, "workflow", "peers")
if PLAN.peers_absent:
    logger.warning(
        f"aceval: peers left out by the configuration (peers): {', '.join(PLAN.peers_absent)}. "
        "The methods tables and summaries of Kong's datasets will differ from the committed "
        "results of config/config.yaml and config/real.yaml, which list all three."
    )
for _name in PLAN.missing_sources():
    raise WorkflowError(
        f"dataset {_name}: the real recordings are not at {PLAN.import_source(_name)}. They are "
        f"public data this project does not ship (../shared/data/README.md says where each comes "
        f"from: HuGaDB from github.com/romanchereshnev/HuGaDB, the NeuRA trial from the NeuRA gait "
        f"toolbox repository, the full-body example from the qmt toolbox, the feet from gaitmap's "
        f"example data). Put them there or pass --config data_root=/path/to/data."
    )


wildcard_constraints:
    dataset="|".join(map(re.escape, DATASETS)),
    subject=r"[^/]+",


def only(names):
    """A wildcard constraint matching exactly these datasets (nothing when there are none)."""
    return "|".join(map(re.escape, names)) or "(?!)"


def subjects(dataset):
    """Subjects of a dataset, known once its sheets are validated (checkpoint)."""
    checkpoints.validate.get(dataset=dataset)
    sheet = os.path.join(PLAN.dataset_dir(dataset), "subjects.tsv")
    return [row["subject"] for row in read_sheet(sheet)]


def subject_batches(dataset):
    """The subjects of each calibration job of the dataset (config ``subjects_per_job``)."""
    return PLAN.subject_batches(dataset, subjects(dataset))


def unit_files(dataset, pattern):
    """``pattern`` (e.g. 'calibrations/{unit}_axes.csv') for each calibration job of the dataset."""
    return [f"results/{dataset}/{pattern.format(unit=u)}" for u in subject_batches(dataset)]


def all_outputs(wildcards):
    # the gate's report is not committed: on a fresh clone, asking for it reruns the whole chain
    # (simulate or import, validate, calibrate, results), so `snakemake` there regenerates the
    # committed results instead of finding them up to date
    return [
        f"results/{dataset}/{name}"
        for dataset in DATASETS
        for name in ("validation/sheets.tsv", "SUMMARY.md", "validation.txt", "tables", "figures")
    ]


# --- a dataset's results job -------------------------------------------------------------------


def results_inputs(wildcards):
    """Every calibration job's tables, findings and recordings' summaries (the peers' direction
    vote reads them), the sheets gate's findings, the peers' calibrations and the dataset itself (its ground truth and reference sheets: a re-import that
    changes only them reruns the results)."""
    dataset = wildcards.dataset
    return {
        "dataset": PLAN.dataset_files(dataset),
        "sheets": f"results/{dataset}/validation/sheets.tsv",
        "calibrations": unit_files(dataset, "calibrations/{unit}.csv"),
        "axes": unit_files(dataset, "calibrations/{unit}_axes.csv"),
        "correlations": unit_files(dataset, "correlations/{unit}.csv"),
        "angles": unit_files(dataset, "calibrations/{unit}_angles.csv"),
        "retest_units": unit_files(dataset, "calibrations/{unit}_retest.csv"),
        "findings": unit_files(dataset, "calibrations/{unit}_findings.tsv"),
        "recordings": unit_files(dataset, "calibrations/{unit}_recordings.csv"),
        "peers": [
            f"results/{dataset}/peers/{peer}/{unit}.csv"
            for peer in PLAN.peers_of(dataset)
            for unit in subject_batches(dataset)
        ],
    }


def input_options(wildcards, input):
    """The inputs as options of `aceval outputs` (--calibrations, ..., --findings), of the inputs
    known so far (before the checkpoint has run, only the sheets gate's)."""
    kinds = (
        "calibrations",
        "axes",
        "correlations",
        "angles",
        "retest_units",
        "peers",
        "recordings",
    )
    known = [kind for kind in kinds if kind in input.keys() and len(input[kind])]
    options = [item for kind in known for item in (f"--{kind.replace('_', '-')}", *input[kind])]
    findings = [input[k] for k in ("sheets",) if k in input.keys()]
    findings += list(input.findings) if "findings" in input.keys() else []
    return options + ["--findings", *findings]
