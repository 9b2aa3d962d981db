# Glue between the configuration and the rules: the workflow's plan of the configuration is the
# package's (aceval.workflow_plan: which datasets, where each lives, analyses, peers, subjects per
# job, options); here only what needs Snakemake itself (wildcards, checkpoints, inputs known once
# the sheets are validated).
import os

from aceval.workflow_plan import Configuration, duplicate_keys, read_sheet, tree_digest
from snakemake.logging import logger

for _problem in (p for f in workflow.configfiles for p in duplicate_keys(str(f))):
    raise WorkflowError(f"aceval: a configuration file: {_problem}")
PLAN = Configuration(config, workflow.basedir)
DATASETS = PLAN.datasets
#: aceval's source, a param of every rule: an edit of the code reruns the jobs (not a stale result)
CODE = PLAN.code_digest()
PEERS_DIR = os.path.join(workflow.basedir, "workflow", "peers")
PEERS_CODE = tree_digest(PEERS_DIR)
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
    """Subjects of a dataset, known once its job has made and validated it (checkpoint)."""
    job = "simulate" if dataset in PLAN.simulated else "import_dataset"
    getattr(checkpoints, job if dataset in PLAN.generated else "calibrate").get(dataset=dataset)
    sheet = os.path.join(PLAN.dataset_dir(dataset), "subjects.tsv")
    return [row["subject"] for row in read_sheet(sheet)]


def subject_batches(dataset):
    """The subjects of each batch of the dataset's job (config ``subjects_per_job``)."""
    return PLAN.subject_batches(dataset, subjects(dataset))


def unit_files(dataset, pattern):
    """``pattern`` (e.g. '{unit}_axes.csv') of each batch of the dataset's job, in its
    calibrations folder (known once the job has run: checkpoint)."""
    folder = f"results/{dataset}/calibrations"
    return [f"{folder}/{pattern.format(unit=u)}" for u in subject_batches(dataset)]


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
    """The dataset job's calibrations folder and in it each batch's tables, findings and
    recordings' summaries (the peers' direction vote reads them; known once the job has run:
    checkpoint), its validation findings, the peers' calibrations and the dataset itself (its
    ground truth and reference sheets: a re-import that changes only them reruns the results)."""
    dataset = wildcards.dataset
    units = {kind: unit_files(dataset, pattern) for kind, pattern in UNIT_INPUTS.items()}
    return {
        "dataset": PLAN.dataset_files(dataset),
        "sheets": f"results/{dataset}/validation/sheets.tsv",
        "folder": f"results/{dataset}/calibrations",
        **units,
        "findings": unit_files(dataset, "{unit}_findings.tsv"),
        "peers": [
            f"results/{dataset}/peers/{peer}/{unit}.csv"
            for peer in PLAN.peers_of(dataset)
            for unit in subject_batches(dataset)
        ],
    }


#: the tables `aceval outputs` reads of each batch: its option's name -> the file
UNIT_INPUTS = {
    "calibrations": "{unit}.csv",
    "axes": "{unit}_axes.csv",
    "correlations": "{unit}_correlations.csv",
    "angles": "{unit}_angles.csv",
    "retest_units": "{unit}_retest.csv",
    "recordings": "{unit}_recordings.csv",
}


def input_options(wildcards, input):
    """The inputs as options of `aceval outputs` (--calibrations, ..., --findings), of the inputs
    known so far (before the dataset's job has run, only its validation's findings)."""
    kinds = [*UNIT_INPUTS, "peers"]
    known = [kind for kind in kinds if kind in input.keys() and len(input[kind])]
    options = [item for kind in known for item in (f"--{kind.replace('_', '-')}", *input[kind])]
    findings = [input[k] for k in ("sheets",) if k in input.keys()]
    findings += list(input.findings) if "findings" in input.keys() else []
    return options + ["--findings", *findings]
