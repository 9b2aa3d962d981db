# Helpers shared by the rules (functions only; the rules are in the other .smk files): where each
# dataset lives, which subjects, tables and figures it has, and the command-line options of each job.
import json
import os

import pandas as pd

from aceval.safety import path_problem

#: the datasets this run covers: ``run`` names them (default: every dataset of the config)
DATASETS = {name: config["datasets"][name] for name in config.get("run", config["datasets"])}
SIMULATED = [name for name, spec in DATASETS.items() if "simulate" in spec]
IMPORTED = [name for name, spec in DATASETS.items() if "import" in spec]
GENERATED = SIMULATED + IMPORTED  # written by the workflow into resources/{dataset}
DATA_ROOT = config.get("data_root", "../shared/data")


def import_source(dataset, key="source"):
    """A path of an imported dataset's ``import`` spec, under ``data_root`` (the repository's
    own sheets, e.g. config/real/*.tsv, stay relative to the project)."""
    path = DATASETS[dataset]["import"].get(key)
    if path is None:
        return None
    return (
        os.path.join(workflow.basedir, path)
        if path.startswith("config/")
        else os.path.join(DATA_ROOT, path)
    )


for _name in IMPORTED:
    if not os.path.exists(import_source(_name)):
        raise WorkflowError(
            f"dataset {_name}: the real recordings are not at {import_source(_name)}. They are public data "
            f"this project does not ship (../shared/data/README.md says where each comes from: HuGaDB from "
            f"github.com/romanchereshnev/HuGaDB, the NeuRA trial from the NeuRA gait toolbox repository, "
            f"the full-body example from the qmt toolbox, the feet from gaitmap's example data). "
            f"Put them there or pass --config data_root=/path/to/data."
        )


def import_inputs(wildcards):
    return [
        p
        for p in (import_source(wildcards.dataset, key) for key in ("source", "sensors", "vicon"))
        if p
    ]


def import_options(wildcards):
    """--name, --sensors, --vicon and --subject of `aceval import`, as a list (quoted by the rule)."""
    spec = DATASETS[wildcards.dataset]["import"]
    options = ["--name", wildcards.dataset]
    options += [
        item
        for key in ("sensors", "vicon")
        if key in spec
        for item in (f"--{key}", import_source(wildcards.dataset, key))
    ]
    return options + (["--subject", spec["subject"]] if "subject" in spec else [])


#: what each analysis produces: Kong et al. 2016 tables and figures (tableN, figureN), the Ricci
#: et al. 2014 reproduction, the reliability of Kong's tests; "methods" joins every dataset with
#: ground truth
ANALYSES = {
    "kong": {
        "tables": [
            "table3",
            "table6",
            "table7",
            "table8",
            "table9",
            "table10",
            "table11",
            "correlation_factors",
            "obj1_sensitivity",
            "reliability",
            "reliability_retest",
            "conditioning",
        ],
        "figures": ["figure6", "figure8", "figure9", "figure10", "obj1_sensitivity", "reliability"],
    },
    "box": {"tables": ["table4", "table5"], "figures": []},
    "ricci": {
        "tables": ["ricci_table1", "ricci_ttest", "ricci_lm", "ricci_residuals"],
        "figures": ["ricci_figure4", "ricci_figure5"],
    },
    "methods": {"tables": ["methods", "methods_best"], "figures": ["methods"]},
    "truth": {"tables": ["truth_errors"], "figures": []},
    "loose_reference": {"tables": ["loose_reference"], "figures": []},
}
#: the inputs of each table and figure (Kong's by number: correlations or error angles)
INPUTS = {
    **{f"table{n}": ["correlations"] for n in (3, 4, 5, 6, 7)},
    **{f"table{n}": ["angles"] for n in (8, 9, 10, 11)},
    "correlation_factors": ["correlations"],
    "obj1_sensitivity": ["correlations"],
    "figure6": ["correlations"],
    "figure8": ["correlations"],
    "figure9": ["angles"],
    "figure10": ["angles"],
    "ricci_table1": ["axes"],
    "ricci_ttest": ["axes"],
    "ricci_lm": ["calibrations"],
    "ricci_residuals": ["axes"],
    "ricci_figure4": ["axes"],
    "ricci_figure5": ["axes"],
    "reliability": ["axes", "calibrations", "angles"],
    "reliability_retest": ["axes", "calibrations", "angles"],
    "methods": ["calibrations"],
    "methods_best": ["calibrations"],
    "truth_errors": ["calibrations"],
    "conditioning": ["calibrations"],
    "loose_reference": ["calibrations"],
}
ALL_UNITS = "_all"  # the calibration "unit" of a dataset calibrated in one job


wildcard_constraints:
    dataset="|".join(map(re.escape, DATASETS)),
    subject=r"[^/]+",
    table="|".join(sorted({t for a in ANALYSES.values() for t in a["tables"]})),
    figure="|".join(sorted({f for a in ANALYSES.values() for f in a["figures"]})),


def only(names):
    """A wildcard constraint matching exactly these datasets (nothing when there are none)."""
    return "|".join(map(re.escape, names)) or "(?!)"


def dataset_dir(dataset):
    spec = DATASETS[dataset]
    return f"resources/{dataset}" if dataset in GENERATED else spec["path"]


def _recording_paths(root, table):
    """The recording files of a lab dataset's recordings.tsv rows (paths that would leave the
    folder are not followed: the validation reports them)."""
    return [os.path.join(root, p) for p in table["path"].str.strip() if not path_problem(p)]


def dataset_input(wildcards):
    """The dataset as an input: the generated folder, or a lab dataset's sheets and every recording
    file (so that the validation is redone when a file changes)."""
    root = dataset_dir(wildcards.dataset)
    if wildcards.dataset in GENERATED:
        return root
    sheets = [
        os.path.join(root, name)
        for name in (
            "dataset.yaml",
            "imus.tsv",
            "tests.tsv",
            "calibrates.tsv",
            "subjects.tsv",
            "recordings.tsv",
        )
    ]
    sheets += [p for p in [os.path.join(root, "ground_truth.tsv")] if os.path.exists(p)]
    try:
        table = pd.read_csv(
            os.path.join(root, "recordings.tsv"), sep="\t", dtype=str, keep_default_na=False
        )
        files = [
            p for p in _recording_paths(root, table) if os.path.exists(p)
        ]  # missing ones: reported
    except (OSError, ValueError, KeyError):  # no or unreadable sheet: the validation reports it
        files = []
    return sheets + files


def subjects(dataset):
    """Subjects of a dataset, known once it is validated (checkpoint)."""
    checkpoints.validate.get(dataset=dataset)
    table = pd.read_csv(os.path.join(dataset_dir(dataset), "subjects.tsv"), sep="\t", dtype=str)
    return list(table["subject"].str.strip())


def calibration_units(dataset):
    """What one calibration job covers: each subject, or the whole dataset (``calibration_jobs: one``)."""
    if DATASETS[dataset].get("calibration_jobs", "per_subject") == "one":
        return [ALL_UNITS]
    return subjects(dataset)


def subject_recordings(wildcards):
    """A lab dataset's recording files of one subject (so that editing them reruns only that subject)."""
    if wildcards.dataset in GENERATED:
        return []
    root = dataset_dir(wildcards.dataset)
    table = pd.read_csv(os.path.join(root, "recordings.tsv"), sep="\t", dtype=str)
    chosen = (
        table
        if wildcards.subject == ALL_UNITS
        else table[table["subject"].str.strip() == wildcards.subject]
    )
    return _recording_paths(root, chosen)


def has_truth_method(dataset):
    """An imported dataset whose ground truth comes from markers (ground_truth_method.tsv)."""
    spec = DATASETS[dataset].get("import", {})
    return "vicon" in spec or spec.get("format") == "gaitmap"


def has_loose_reference(dataset):
    """An imported dataset with a hand-set reference (loose_reference.tsv, not a truth)."""
    return DATASETS[dataset].get("import", {}).get("format") == "qmt"


def has_ground_truth(dataset):
    if dataset in IMPORTED:
        return has_truth_method(dataset)
    return dataset in SIMULATED or os.path.exists(
        os.path.join(dataset_dir(dataset), "ground_truth.tsv")
    )


def analyses(dataset):
    extra = ["methods"] if has_ground_truth(dataset) else []
    return (
        DATASETS[dataset].get("analyses", [])
        + extra
        + (["truth"] if has_truth_method(dataset) else [])
        + (["loose_reference"] if has_loose_reference(dataset) else [])
    )


def tables_of(dataset):
    return sorted({n for a in analyses(dataset) for n in ANALYSES[a]["tables"]})


def figures_of(dataset):
    return sorted({n for a in analyses(dataset) for n in ANALYSES[a]["figures"]})


def trim_options():
    """The trimmer's parameters (config ``calibration.trim``) as options of calibrate/correlate."""
    trim = config["calibration"]["trim"]
    return [
        f"--trim-threshold={trim['threshold']}",
        f"--closing-s={trim['closing_s']}",
        f"--window-s={trim['window_s']}",
        f"--min-peak-deg-s={trim['min_peak_deg_s']}",
    ]


def paper_names(dataset):
    return json.dumps(DATASETS[dataset].get("paper_names", {}))


def simulated_label(dataset):
    """What the report's captions say about the data."""
    return (
        "SIMULATED data (generated by aceval, not the paper's recordings)"
        if dataset in SIMULATED
        else "recorded data"
    )


def all_outputs(wildcards):
    out = []
    for dataset in DATASETS:
        out.append(f"results/{dataset}/SUMMARY.md")
        out += [f"results/{dataset}/tables/{name}.md" for name in tables_of(dataset)]
        out += [f"results/{dataset}/figures/{name}.png" for name in figures_of(dataset)]
    return out


# --- inputs and options of the tables, figures and summaries ------------------------------------


def calibration_files(wildcards):
    return [
        f"results/{wildcards.dataset}/calibrations/{u}.csv"
        for u in calibration_units(wildcards.dataset)
    ]


def axes_files(wildcards):
    return [
        f"results/{wildcards.dataset}/calibrations/{u}_axes.csv"
        for u in calibration_units(wildcards.dataset)
    ]


def correlation_files(wildcards):
    return [
        f"results/{wildcards.dataset}/correlations/{s}.csv" for s in subjects(wildcards.dataset)
    ]


def output_inputs(wildcards):
    """The inputs of a table or figure (INPUTS), by kind."""
    files = {
        "correlations": correlation_files,
        "calibrations": calibration_files,
        "axes": axes_files,
        "angles": lambda w: [f"results/{w.dataset}/angles.csv"],
    }
    name = wildcards.table if "table" in wildcards.keys() else wildcards.figure
    return {kind: files[kind](wildcards) for kind in INPUTS[name]}


def source_options(wildcards, input):
    """--correlations/--calibrations/--axes/--angles options of `aceval table|figure`, as a list."""
    options = []
    for kind in ("correlations", "calibrations", "axes", "angles"):
        if kind in input.keys():
            options += [f"--{kind}", *input[kind]]
    return options


def kong_number(name):
    """`aceval table|figure` takes Kong's tables and figures by number, the others by name."""
    return name[5:] if name.startswith("table") else name[6:] if name.startswith("figure") else name


def summary_inputs(wildcards):
    dataset = wildcards.dataset
    inputs = {
        "validation": f"results/{dataset}/validation.txt",
        "tables": [f"results/{dataset}/tables/{name}.csv" for name in tables_of(dataset)],
    }
    if "kong" in analyses(dataset):
        inputs["angles"] = f"results/{dataset}/angles.csv"
        inputs["calibrations"] = calibration_files(wildcards)
    return inputs
