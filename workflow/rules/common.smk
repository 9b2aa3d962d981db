# Helpers shared by the rules (functions only; the rules are in the other .smk files): where each
# dataset lives, which subjects, tables and figures it has, and the command-line options of each job.
import csv
import functools
import hashlib
import json
import os

from aceval.methods import registry
from aceval.report.outputs import outputs_of
from snakemake.logging import logger
from aceval.data.safety import path_problem

#: the datasets this run covers: ``run`` names them (default: every dataset of the config)
DATASETS = {name: config["datasets"][name] for name in config.get("run", config["datasets"])}
SIMULATED = [name for name, spec in DATASETS.items() if "simulate" in spec]
IMPORTED = [name for name, spec in DATASETS.items() if "import" in spec]
GENERATED = SIMULATED + IMPORTED  # written by the workflow into resources/{dataset}
DATA_ROOT = config.get("data_root", "../shared/data")
#: the peer tools (workflow/peers/), from aceval's registry of methods: method -> its environment
#: and adapter (aceval.methods.registry.Peer); each environment is built by the workflow itself
#: (rule peer_env) the first time a peer job needs it, from the pinned
#: workflow/peers/<environment>.txt, never in aceval's own
PEER_METHODS = registry.peers()
PEERS_DIR = os.path.join(workflow.basedir, "workflow", "peers")
PEERS_ROOT = os.path.abspath(
    config.get("peers_root", os.path.join(workflow.basedir, ".venv-peers"))
)


def peer_python(method):
    """The interpreter of a peer's own environment."""
    return os.path.join(PEERS_ROOT, PEER_METHODS[method].environment, "bin", "python")


def peer_env_stamp(env):
    """The last file that rule peer_env writes into an environment it built (the pins it installed);
    each peer job's input, so the environment is built once, before the first job that needs it."""
    return os.path.join(PEERS_ROOT, env, "aceval-pins.txt")


#: the configured peers (run), and the others (left out: said on screen and in the summaries,
#: since the committed results list all three)
PEERS_RUN = [m for m in PEER_METHODS if m in config.get("peers", list(PEER_METHODS))]
PEERS_ABSENT = [m for m in PEER_METHODS if m not in PEERS_RUN]
if PEERS_ABSENT:
    logger.warning(
        f"aceval: peers left out by the configuration (peers): {', '.join(PEERS_ABSENT)}. The "
        "methods tables and summaries of Kong's datasets will differ from the committed results, "
        "which list all three."
    )


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


wildcard_constraints:
    dataset="|".join(map(re.escape, DATASETS)),
    subject=r"[^/]+",


def only(names):
    """A wildcard constraint matching exactly these datasets (nothing when there are none)."""
    return "|".join(map(re.escape, names)) or "(?!)"


def dataset_dir(dataset):
    spec = DATASETS[dataset]
    return f"resources/{dataset}" if dataset in GENERATED else spec["path"]


@functools.cache
def _sheet(path, size, mtime_ns):
    """A tab-separated sheet's rows as dicts of stripped strings, read as aceval.data.dataset reads its
    sheets: names and header stripped, no missing-value parsing (the validation rejects names such
    as 'NA'; they never reach a job's wildcards as 'nan'). Not aceval.data.dataset's reader itself:
    importing it (SciPy, pandas) would cost every Snakemake start about 0.6 s. Cached per size and
    modification time: subjects.tsv is asked for once per job, a sheet a job rewrites is read again.
    """
    with open(path, newline="", encoding="utf-8-sig") as handle:
        lines = [line for line in csv.reader(handle, delimiter="\t") if line]
    header = [name.strip() for name in lines[0]] if lines else []
    return [  # a short line's missing cells are empty, as in aceval's reading
        dict(zip(header, [value.strip() for value in line] + [""] * (len(header) - len(line))))
        for line in lines[1:]
    ]


def read_sheet(path):
    """:func:`_sheet` of the file at ``path`` as it is now."""
    stat = os.stat(path)
    return _sheet(path, stat.st_size, stat.st_mtime_ns)


def _recordings_sheet(dataset):
    """A lab dataset's recordings.tsv rows (None when absent or unreadable: the validation
    reports it)."""
    try:
        return read_sheet(os.path.join(dataset_dir(dataset), "recordings.tsv"))
    except (OSError, UnicodeDecodeError, csv.Error):
        return None


def dataset_input(wildcards):
    """The dataset as an input: the generated folder, or a lab dataset's sheets (its recording
    files enter through :func:`recordings_fingerprint`)."""
    return dataset_files(wildcards.dataset)


def dataset_files(dataset):
    """:func:`dataset_input` of the dataset named ``dataset``."""
    root = dataset_dir(dataset)
    if dataset in GENERATED:
        return root
    names = ["dataset.yaml", "imus.tsv", "tests.tsv", "calibrates.tsv", "subjects.tsv"]
    names += ["recordings.tsv", "ground_truth.tsv", "functional_axes.tsv"]
    return [
        os.path.join(root, n)
        for n in names
        if n not in ("ground_truth.tsv", "functional_axes.tsv")
        or os.path.exists(os.path.join(root, n))
    ]


#: each recording's content hash, cached per file identity (size, mtime, ctime, inode: ctime changes
#: with any write and cannot be set back, so an edit with its mtime restored is hashed again)
HASH_CACHE = os.path.join(".snakemake", "aceval_recording_hashes.json")


@functools.cache
def _hashes():
    try:
        with open(HASH_CACHE) as handle:
            return {"entries": json.load(handle), "changed": False}
    except (OSError, ValueError):
        return {"entries": {}, "changed": False}


def content_hash(path):
    """SHA-1 of a file's bytes, from the cache while the file is the same one (:data:`HASH_CACHE`);
    'missing' for a file that is not there."""
    try:
        stat = os.stat(path)
    except OSError:
        return "missing"
    identity = f"{stat.st_size}:{stat.st_mtime_ns}:{stat.st_ctime_ns}:{stat.st_ino}"
    cache = _hashes()
    known = cache["entries"].get(path)
    if known and known[0] == identity:
        return known[1]
    digest = hashlib.sha1()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    cache["entries"][path] = [identity, digest.hexdigest()]
    cache["changed"] = True
    return digest.hexdigest()


def save_hashes():
    """Write the hash cache (once per run, when it changed; atomically: jobs on a cluster parse
    this file too)."""
    cache = _hashes()
    if cache["changed"] and os.path.isdir(".snakemake"):
        tmp = f"{HASH_CACHE}.{os.getpid()}"
        with open(tmp, "w") as handle:
            json.dump(cache["entries"], handle)
        os.replace(tmp, HASH_CACHE)
        cache["changed"] = False


def recordings_fingerprint(dataset, chosen=None):
    """A digest of the path and content hash (:func:`content_hash`) of a lab dataset's recording
    files (of the ``chosen`` subjects; all when None), a param of the jobs that read them: a file
    whose content changed after a good run reruns its jobs (Snakemake's params rerun trigger),
    even with its size and mtime restored, without a hundred thousand files in the DAG. '' for a
    generated dataset (its folder is the input)."""
    rows = None if dataset in GENERATED else _recordings_sheet(dataset)
    if not rows or "path" not in rows[0] or "subject" not in rows[0]:
        return ""
    chosen = None if chosen is None else set(chosen)
    paths = [
        os.path.join(dataset_dir(dataset), row["path"])
        for row in rows
        if (chosen is None or row["subject"] in chosen) and not path_problem(row["path"])
    ]  # paths that would leave the folder are not followed: the validation reports them
    digest = hashlib.sha1()
    for path in paths:
        digest.update(f"{path}\0{content_hash(path)}\n".encode())
    return digest.hexdigest()


def subjects(dataset):
    """Subjects of a dataset, known once it is validated (checkpoint)."""
    checkpoints.validate.get(dataset=dataset)
    return [
        row["subject"] for row in read_sheet(os.path.join(dataset_dir(dataset), "subjects.tsv"))
    ]


def subject_batches(dataset):
    """``{unit: [subject, ...]}``: the subjects of each calibration job (config
    ``subjects_per_job``, in subjects.tsv order); a job of one subject is named after it."""
    names = subjects(dataset)
    size = DATASETS[dataset].get("subjects_per_job", 1)
    if size == 1:
        return {name: [name] for name in names}
    chunks = [names[k : k + size] for k in range(0, len(names), size)]
    width = len(str(len(chunks)))
    return {f"_batch{k:0{width}d}": chunk for k, chunk in enumerate(chunks, start=1)}


def calibration_units(dataset):
    """The calibration jobs of a dataset (:func:`subject_batches`)."""
    return list(subject_batches(dataset))


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
    if {"kong", "box"} & set(DATASETS[dataset].get("analyses", [])):
        extra.append("retest")  # every method's test-retest, with or without a truth
    return (
        DATASETS[dataset].get("analyses", [])
        + extra
        + (["truth"] if has_truth_method(dataset) else [])
        + (["loose_reference"] if has_loose_reference(dataset) else [])
    )


def peers_of(dataset):
    """The peers run on a dataset: those with an environment, on Kong's sagittal design (Ricci's
    functional design has no calibration they make)."""
    return PEERS_RUN if {"kong", "box"} & set(DATASETS[dataset].get("analyses", [])) else []


def peer_files(dataset):
    return [
        f"results/{dataset}/peers/{method}/{unit}.csv"
        for method in peers_of(dataset)
        for unit in calibration_units(dataset)
    ]


def peers_note(dataset):
    """What SUMMARY.md says about peers that were not run."""
    if "ricci" in DATASETS[dataset].get("analyses", []):
        return (
            "The peer tools (gaitmap, qmt, OpenSense) are not run on Ricci's functional design: "
            "each calibrates from a vertical and one movement axis, which this design does not "
            'have per calibration (README, "The peers side by side").'
        )
    if not PEERS_ABSENT or not {"kong", "box"} & set(DATASETS[dataset].get("analyses", [])):
        return ""
    return (
        f"Peers left out by the configuration (`peers`): {', '.join(PEERS_ABSENT)} (the "
        f"committed results list all three; the workflow builds each one's environment under "
        f".venv-peers/ the first time it runs it)."
    )


def dataset_outputs(dataset):
    """The registry's outputs (aceval.report.outputs) of this dataset's analyses."""
    return outputs_of(analyses(dataset))


def trim_options():
    """The trimmer's parameters (config ``calibration.trim``) as options of `aceval calibrate`."""
    trim = config["calibration"]["trim"]
    return [
        f"--trim-threshold={trim['threshold']}",
        f"--closing-s={trim['closing_s']}",
        f"--window-s={trim['window_s']}",
        f"--min-peak-deg-s={trim['min_peak_deg_s']}",
    ]


def correlation_options():
    """Obj 1-2 options of `aceval calibrate` (config ``objectives``)."""
    objectives = config["objectives"]
    return [
        f"--mode={objectives['correlation']}",
        f"--max-lag-s={objectives['max_lag_s']}",
        f"--pairs={json.dumps(objectives['segment_pairs'])}",
    ]


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
        # the gate's report is not committed: on a fresh clone, asking for it reruns the whole
        # chain (simulate or import, validate, calibrate, tables, figures), so `snakemake` there
        # regenerates the committed results instead of finding them up to date
        out += [f"results/{dataset}/validation/sheets.tsv"]
        out += [f"results/{dataset}/SUMMARY.md", f"results/{dataset}/validation.txt"]
        out += [f"results/{dataset}/{o.path}" for o in dataset_outputs(dataset)]
    return out


# --- inputs and outputs of a dataset's results job ----------------------------------------------


def unit_files(dataset, pattern):
    """``pattern`` (e.g. 'calibrations/{unit}_axes.csv') for each calibration job of the dataset."""
    return [f"results/{dataset}/{pattern.format(unit=u)}" for u in calibration_units(dataset)]


def results_inputs(dataset):
    """What the results jobs of ``dataset`` read: every calibration job's tables and findings,
    the sheets gate's findings, and the dataset itself (its ground truth and reference sheets: a
    re-import that changes only them reruns the results)."""

    def inputs(wildcards):
        return {
            "dataset": dataset_files(dataset),
            "sheets": f"results/{dataset}/validation/sheets.tsv",
            "calibrations": unit_files(dataset, "calibrations/{unit}.csv"),
            "axes": unit_files(dataset, "calibrations/{unit}_axes.csv"),
            "correlations": unit_files(dataset, "correlations/{unit}.csv"),
            "angles": unit_files(dataset, "calibrations/{unit}_angles.csv"),
            "retest_units": unit_files(dataset, "calibrations/{unit}_retest.csv"),
            "findings": unit_files(dataset, "calibrations/{unit}_findings.tsv"),
            "peers": peer_files(dataset),
        }

    return inputs


def results_folder(output):
    """A dataset's results folder, from a results job's outputs (all under it)."""
    folder = os.path.commonpath([os.path.dirname(path) for path in output])
    return os.path.dirname(folder) if os.path.basename(folder) == "figures" else folder


def results_options(wildcards, input):
    """--calibrations/--axes/--correlations/--angles/--retest-units/--peers/--findings of `aceval
    outputs`, as a list, from the inputs known so far (before the checkpoint has run, only the
    sheets gate's)."""
    options = []
    for kind in ("calibrations", "axes", "correlations", "angles", "retest_units", "peers"):
        if kind in input.keys() and len(input[kind]):
            options += [f"--{kind.replace('_', '-')}", *input[kind]]
    findings = [input[k] for k in ("sheets",) if k in input.keys()]
    findings += list(input.findings) if "findings" in input.keys() else []
    return options + ["--findings", *findings]


def results_outputs(dataset, kind):
    """Every file a results job of ``dataset`` writes (``kind`` 'table': the tables, angles.csv,
    SUMMARY.md and validation.txt; 'figure': the figures), by name, tables and figures marked for
    the report with their registry entry's paper item and title."""
    folder = f"results/{dataset}"
    files = {}
    if kind == "table":
        files["summary"] = report(
            f"{folder}/SUMMARY.md",
            caption="../report/summary.rst",
            category=dataset,
            subcategory="Summary",
            labels={"dataset": dataset, "file": "SUMMARY.md"},
        )
        files["validation"] = f"{folder}/validation.txt"
        if "kong" in analyses(dataset):
            files["angles"] = f"{folder}/angles.csv"
    for o in [o for o in dataset_outputs(dataset) if o.kind == kind]:
        files[o.name] = report(
            f"{folder}/{o.path}",
            caption=f"../report/{o.kind}.rst",
            category=dataset,
            subcategory=f"{o.kind.capitalize()}s",
            labels={"dataset": dataset, o.kind: o.name, "reproduces": o.paper, "title": o.title},
        )
        if o.kind == "table":
            files[f"{o.name}_md"] = f"{folder}/tables/{o.name}.md"
    return files
