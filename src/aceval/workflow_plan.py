"""What the workflow asks of its configuration: which datasets, where each lives, which analyses,
peers, subjects per job, files and options each job gets (workflow/rules/*.smk call this; they
hold no logic of their own).

Read at every Snakemake start, so it imports no pandas, SciPy or NumPy (the registries it reads,
:mod:`aceval.methods.registry` and :mod:`aceval.report.outputs`, import none either): a dataset's
sheets are read here as aceval's reader reads them (:func:`read_sheet`), the recording files'
contents are fingerprinted through a cache of their hashes (:class:`HashCache`).
"""

from __future__ import annotations

import csv
import functools
import hashlib
import json
import os
from dataclasses import dataclass, field

from aceval.data.safety import path_problem
from aceval.data.units import SIMULATED_SUBJECTS, subject_batches
from aceval.methods import registry
from aceval.report.outputs import Output, outputs_of

#: the analyses a dataset runs with Kong's protocol (the peers and every method's test-retest
#: belong to them)
KONG_PROTOCOL = ("kong", "box")
#: a lab dataset's sheets (the optional ones only when present)
SHEETS = ["dataset.yaml", "imus.tsv", "tests.tsv", "calibrates.tsv", "subjects.tsv"]
OPTIONAL_SHEETS = ["recordings.tsv", "ground_truth.tsv", "functional_axes.tsv"]


@functools.cache
def _sheet(path: str, size: int, mtime_ns: int) -> list[dict]:
    with open(path, newline="", encoding="utf-8-sig") as handle:
        lines = [line for line in csv.reader(handle, delimiter="\t") if line]
    header = [name.strip() for name in lines[0]] if lines else []
    return [  # a short line's missing cells are empty, as in aceval's reading
        dict(zip(header, [value.strip() for value in line] + [""] * (len(header) - len(line))))
        for line in lines[1:]
    ]


def read_sheet(path: str) -> list[dict]:
    """A tab-separated sheet's rows as dicts of stripped strings, read as
    :mod:`aceval.data.dataset` reads its sheets (names and header stripped, no missing-value
    parsing: the validation rejects names such as 'NA'; they never reach a job's wildcards as
    'nan'), without its pandas. Cached per size and modification time: subjects.tsv is asked for
    once per job, a sheet a job rewrites is read again.
    """
    stat = os.stat(path)
    return _sheet(path, stat.st_size, stat.st_mtime_ns)


def duplicate_keys(path: str) -> list[str]:
    """Each key given twice in one mapping of the YAML (or JSON) file ``path``, as 'file line N:
    key K is given twice (first at line M) ...': a YAML reader, Snakemake's too, keeps the last
    one silently (two ``my_lab:`` blocks: one of them is never run). [] for a file it cannot
    parse (Snakemake reports that itself).
    """
    import yaml

    try:
        with open(path, encoding="utf-8-sig") as handle:
            root = yaml.compose(handle, Loader=yaml.SafeLoader)
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return []
    found, stack = [], [(root, "")] if root is not None else []
    while stack:
        node, where = stack.pop()
        if isinstance(node, yaml.SequenceNode):
            stack += [(item, f"{where}[{k}]") for k, item in enumerate(node.value)]
        if not isinstance(node, yaml.MappingNode):
            continue
        first: dict[str, int] = {}
        for key, value in node.value:
            name = f"{where}.{key.value}" if where else str(key.value)
            line = key.start_mark.line + 1
            if key.value in first:
                found.append(
                    f"{path} line {line}: key {name!r} is given twice (first at line "
                    f"{first[key.value]}): YAML keeps the last one without a word, so the first is "
                    "never used; remove or rename one"
                )
            first.setdefault(key.value, line)
            stack.append((value, name))
    return sorted(found)


def tree_digest(folder: str) -> str:
    """SHA-1 of the relative paths and bytes of every file under ``folder`` (compiled caches
    left out), in path order.
    """
    digest = hashlib.sha1()
    for base, folders, files in os.walk(folder):
        folders[:] = sorted(f for f in folders if f != "__pycache__")
        for name in sorted(files):
            if not name.endswith((".pyc", ".pyo")):
                path = os.path.join(base, name)
                digest.update(os.path.relpath(path, folder).encode() + b"\0")
                with open(path, "rb") as handle:
                    digest.update(handle.read())
    return digest.hexdigest()


@dataclass
class HashCache:
    """Each recording's content hash, cached per file identity (size, mtime, ctime, inode: ctime
    changes with any write and cannot be set back, so an edit with its mtime restored is hashed
    again), kept in ``path`` between runs.
    """

    path: str
    entries: dict = field(default_factory=dict)
    changed: bool = False

    @classmethod
    def load(cls, path: str) -> HashCache:
        """The cache at ``path`` (empty when absent or unreadable)."""
        try:
            with open(path) as handle:
                return cls(path, json.load(handle))
        except (OSError, ValueError):
            return cls(path)

    def content_hash(self, path: str) -> str:
        """SHA-1 of a file's bytes, from the cache while the file is the same one; 'missing' for
        a file that is not there.
        """
        try:
            stat = os.stat(path)
        except OSError:
            return "missing"
        identity = f"{stat.st_size}:{stat.st_mtime_ns}:{stat.st_ctime_ns}:{stat.st_ino}"
        known = self.entries.get(path)
        if known and known[0] == identity:
            return known[1]
        digest = hashlib.sha1()
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
        self.entries[path] = [identity, digest.hexdigest()]
        self.changed = True
        return digest.hexdigest()

    def save(self) -> None:
        """Write the cache (when it changed; atomically: jobs on a cluster read it too)."""
        if self.changed and os.path.isdir(os.path.dirname(self.path) or "."):
            tmp = f"{self.path}.{os.getpid()}"
            with open(tmp, "w") as handle:
                json.dump(self.entries, handle)
            os.replace(tmp, self.path)
            self.changed = False


@dataclass
class Configuration:
    """The workflow's configuration (``config``, validated against its schema), read once per
    Snakemake start: ``basedir`` the Snakefile's folder (the repository's own sheets,
    config/real/*.tsv, and the peers' files are relative to it).
    """

    config: dict
    basedir: str
    hashes: HashCache = field(
        default_factory=lambda: HashCache.load(
            os.path.join(".snakemake", "aceval_recording_hashes.json")
        )
    )

    def __post_init__(self):
        chosen = self.config.get("run", self.config["datasets"])
        self.datasets = {name: self.config["datasets"][name] for name in chosen}
        self.simulated = [n for n, spec in self.datasets.items() if "simulate" in spec]
        self.imported = [n for n, spec in self.datasets.items() if "import" in spec]
        #: written by the workflow into resources/{dataset}; the others are read where they lie
        self.generated = self.simulated + self.imported
        self.on_disk = [n for n in self.datasets if n not in self.generated]
        self.data_root = self.config.get("data_root", "../shared/data")
        self.peers = registry.peers()
        asked = self.config.get("peers", list(self.peers))
        #: the configured peers, and the others (left out: said on screen and in the summaries)
        self.peers_run = [m for m in self.peers if m in asked]
        self.peers_absent = [m for m in self.peers if m not in self.peers_run]
        self.peers_root = os.path.abspath(
            self.config.get("peers_root", os.path.join(self.basedir, ".venv-peers"))
        )

    # --- where things are ---------------------------------------------------------------------

    def dataset_dir(self, dataset: str) -> str:
        """The dataset's folder: resources/<name> when the workflow writes it, else its path."""
        return (
            f"resources/{dataset}" if dataset in self.generated else self.datasets[dataset]["path"]
        )

    def import_source(self, dataset: str, key: str = "source") -> str | None:
        """A path of an imported dataset's ``import`` spec, under ``data_root`` (the repository's
        own sheets, config/real/*.tsv, stay relative to the project).
        """
        path = self.datasets[dataset]["import"].get(key)
        if path is None:
            return None
        root = self.basedir if path.startswith("config/") else self.data_root
        return os.path.join(root, path)

    def missing_sources(self) -> list[str]:
        """The imported datasets whose recordings are not where the configuration says."""
        return [n for n in self.imported if not os.path.exists(self.import_source(n))]

    def import_inputs(self, dataset: str) -> list[str]:
        """The files an import reads (its source, sensor sheet and Vicon file)."""
        found = (self.import_source(dataset, key) for key in ("source", "sensors", "vicon"))
        return [p for p in found if p]

    def import_options(self, dataset: str) -> list[str]:
        """--import, --source, --name, --sensors, --vicon and --import-subject of `aceval
        batches` (quoted by the rule).
        """
        spec = self.datasets[dataset]["import"]
        options = ["--import", spec["format"], "--source", self.import_source(dataset)]
        options += ["--name", dataset]
        for key in ("sensors", "vicon"):
            if key in spec:
                options += [f"--{key}", self.import_source(dataset, key)]
        return options + (["--import-subject", spec["subject"]] if "subject" in spec else [])

    def simulate_options(self, dataset: str) -> list[str]:
        """--simulate, --seed, --name (the dataset's key: its SUMMARY.md and tables are titled by
        it), and --subjects and --repetitions where the configuration sets them, of `aceval
        batches`.
        """
        spec = self.datasets[dataset]["simulate"]
        counts = [f"--{key}={spec[key]}" for key in ("subjects", "repetitions") if key in spec]
        options = ["--simulate", spec["protocol"], f"--seed={spec.get('seed', 0)}"]
        return [*options, f"--name={dataset}", *counts]

    def dataset_threads(self, dataset: str, cores: int) -> int:
        """The workers of a dataset's job: one per batch of subjects (known before the job for a
        simulated dataset and one on disk; all ``cores`` for an imported one), at most ``cores``.
        """
        size = self.datasets[dataset].get("subjects_per_job", 1)
        if dataset in self.simulated:
            spec = self.datasets[dataset]["simulate"]
            count = spec.get("subjects", SIMULATED_SUBJECTS[spec["protocol"]])
        elif dataset in self.imported:
            count = 1 if "subject" in self.datasets[dataset]["import"] else cores * size
        else:
            try:
                count = len(read_sheet(os.path.join(self.dataset_dir(dataset), "subjects.tsv")))
            except (OSError, UnicodeDecodeError, csv.Error):
                count = 1  # the validation says why
        return max(1, min(cores, -(-count // size)))

    def dataset_files(self, dataset: str) -> str | list[str]:
        """The dataset as a job's input: the generated folder, or a lab dataset's sheets (its
        recording files enter through :meth:`recording_files_digest`).
        """
        root = self.dataset_dir(dataset)
        if dataset in self.generated:
            return root
        present = [n for n in OPTIONAL_SHEETS if os.path.exists(os.path.join(root, n))]
        names = SHEETS + ["recordings.tsv"] + [n for n in present if n != "recordings.tsv"]
        return [os.path.join(root, n) for n in names]

    def recording_files_digest(self, dataset: str, chosen=None) -> str:
        """A digest of the path and content hash of a lab dataset's recording files (of the
        ``chosen`` subjects; all when None), a param of the jobs that read them: a file whose
        content changed after a good run reruns its jobs (Snakemake's params rerun trigger),
        even with its size and mtime restored, without a hundred thousand files in the DAG. ''
        for a generated dataset (its folder is the input). Paths that would leave the folder are
        not followed: the validation reports them.
        """
        if dataset in self.generated:
            return ""
        try:
            rows = read_sheet(os.path.join(self.dataset_dir(dataset), "recordings.tsv"))
        except (OSError, UnicodeDecodeError, csv.Error):
            return ""  # the validation reports it
        if not rows or "path" not in rows[0] or "subject" not in rows[0]:
            return ""
        chosen = None if chosen is None else set(chosen)
        digest = hashlib.sha1()
        for row in rows:
            if (chosen is None or row["subject"] in chosen) and not path_problem(row["path"]):
                path = os.path.join(self.dataset_dir(dataset), row["path"])
                digest.update(f"{path}\0{self.hashes.content_hash(path)}\n".encode())
        return digest.hexdigest()

    def code_digest(self) -> str:
        """A digest of aceval's own source (every file of the package the jobs run): a param of
        every rule, so that an edit of the code reruns the jobs it may change (Snakemake's params
        rerun trigger) instead of leaving their results stale.
        """
        return tree_digest(os.path.dirname(os.path.abspath(__file__)))

    # --- what each dataset gets ---------------------------------------------------------------

    def subject_batches(self, dataset: str, subjects: list[str]) -> dict[str, list[str]]:
        """``{unit: [subject, ...]}``: the subjects of each calibration job (config
        ``subjects_per_job``, in subjects.tsv order); a job of one subject is named after it.
        """
        return subject_batches(subjects, self.datasets[dataset].get("subjects_per_job", 1))

    def has_truth_method(self, dataset: str) -> bool:
        """An imported dataset whose ground truth comes from markers (ground_truth_method.tsv)."""
        spec = self.datasets[dataset].get("import", {})
        return "vicon" in spec or spec.get("format") == "gaitmap"

    def has_loose_reference(self, dataset: str) -> bool:
        """An imported dataset with a hand-set reference (loose_reference.tsv, not a truth)."""
        return self.datasets[dataset].get("import", {}).get("format") == "qmt"

    def has_ground_truth(self, dataset: str) -> bool:
        """Simulated, imported with a marker truth, or a lab dataset with ground_truth.tsv."""
        if dataset in self.imported:
            return self.has_truth_method(dataset)
        truth = os.path.join(self.dataset_dir(dataset), "ground_truth.tsv")
        return dataset in self.simulated or os.path.exists(truth)

    def kong_protocol(self, dataset: str) -> bool:
        """The dataset runs Kong's analyses (or the box's), with the peers and the test-retest."""
        return bool(set(KONG_PROTOCOL) & set(self.datasets[dataset].get("analyses", [])))

    def analyses(self, dataset: str) -> list[str]:
        """The configured analyses, then those aceval adds: which calibration to use for
        each IMU (``decision``), every method against a ground truth (``methods``), every
        method's test-retest (Kong's protocol), the marker truth's own and the loose
        reference's tables.
        """
        extra = ["decision"] + (["methods"] if self.has_ground_truth(dataset) else [])
        extra += ["retest"] if self.kong_protocol(dataset) else []
        extra += ["truth"] if self.has_truth_method(dataset) else []
        extra += ["loose_reference"] if self.has_loose_reference(dataset) else []
        return self.datasets[dataset].get("analyses", []) + extra

    def outputs(self, dataset: str) -> list[Output]:
        """The registry's outputs (:mod:`aceval.report.outputs`) of the dataset's analyses."""
        return outputs_of(self.analyses(dataset))

    def peers_of(self, dataset: str) -> list[str]:
        """The peers run on a dataset: the configured ones, on Kong's sagittal design (Ricci's
        functional design has no calibration they make).
        """
        return self.peers_run if self.kong_protocol(dataset) else []

    def peer_python(self, peer: str) -> str:
        """The interpreter of a peer's own environment."""
        return os.path.join(self.peers_root, self.peers[peer].environment, "bin", "python")

    def peer_env_stamp(self, environment: str) -> str:
        """The last file rule peer_env writes into an environment it built (the pins it
        installed): each peer job's input, so the environment is built once, before the first
        job that needs it.
        """
        return os.path.join(self.peers_root, environment, "aceval-pins.txt")

    def peers_note(self, dataset: str) -> str:
        """What SUMMARY.md says about peers that were not run."""
        if "ricci" in self.datasets[dataset].get("analyses", []):
            return (
                "The peer tools (gaitmap, qmt, OpenSense) are not run on Ricci's functional "
                "design: each calibrates from a vertical and one movement axis, which this design "
                'does not have per calibration (README, "The peers side by side").'
            )
        if not self.peers_absent or not self.kong_protocol(dataset):
            return ""
        return (
            f"Peers left out by the configuration (`peers`): {', '.join(self.peers_absent)} (the "
            f"committed results of config/config.yaml and config/real.yaml list all three; the "
            f"workflow builds each one's environment under .venv-peers/ the first time it runs it)."
        )

    def data_note(self, dataset: str) -> str:
        """What SUMMARY.md says about which data the dataset's results come from: the folder
        of a lab's dataset, or how the workflow made it (its configuration entry).
        """
        spec = self.datasets[dataset]
        if dataset in self.simulated:
            made = ", ".join(f"{k} {v}" for k, v in spec["simulate"].items())
            return (
                f"Data: simulated by the workflow (config `datasets.{dataset}.simulate`: {made})."
            )
        if dataset in self.imported:
            made = ", ".join(f"{k} {v}" for k, v in spec["import"].items() if k != "source")
            return (
                f"Data: imported by the workflow from `{spec['import']['source']}` under data_root "
                f"(config `datasets.{dataset}.import`: {made})."
            )
        return f"Data: the dataset folder {spec['path']} (config `datasets.{dataset}.path`)."

    def data_label(self, dataset: str) -> str:
        """What the report's captions say about the data."""
        if dataset in self.simulated:
            return "SIMULATED data (generated by aceval, not the paper's recordings)"
        return "recorded data"

    # --- options of the jobs ------------------------------------------------------------------

    def batch_options(self, dataset: str) -> list[str]:
        """--subjects-per-job of `aceval batches` (config ``subjects_per_job``), the trimmer's
        parameters (config ``calibration.trim``), Obj 1-2's options and Obj 4's k (config
        ``objectives``).
        """
        trim, objectives = self.config["calibration"]["trim"], self.config["objectives"]
        return [
            f"--subjects-per-job={self.datasets[dataset].get('subjects_per_job', 1)}",
            f"--trim-threshold={trim['threshold']}",
            f"--closing-s={trim['closing_s']}",
            f"--window-s={trim['window_s']}",
            f"--min-peak-deg-s={trim['min_peak_deg_s']}",
            f"--mode={objectives['correlation']}",
            f"--max-lag-s={objectives['max_lag_s']}",
            f"--pairs={json.dumps(objectives['segment_pairs'])}",
            f"--retest-k={objectives['test_retest_k']}",
        ]

    def results_options(self, dataset: str) -> list[str]:
        """--analyses, --paper-names, --note (three times), --test-retest-k and --tolerance-deg (the
        dataset's ``tolerance_deg``, else the run's) of `aceval outputs`.
        """
        spec = self.datasets[dataset]
        tolerance = spec.get("tolerance_deg", self.config.get("tolerance_deg"))
        return [
            "--analyses",
            *self.analyses(dataset),
            f"--paper-names={json.dumps(spec.get('paper_names', {}))}",
            f"--note={spec.get('note', '')}",
            f"--note={self.peers_note(dataset)}",
            f"--note={self.data_note(dataset)}",
            f"--test-retest-k={self.config['objectives']['test_retest_k']}",
        ] + ([f"--tolerance-deg={tolerance}"] if tolerance is not None else [])
