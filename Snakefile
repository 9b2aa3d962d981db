# aceval: reproduce Kong et al. 2016 (Objectives 1-5, rigid box) on every configured dataset.
#   snakemake --cores 2                              # default config: simulated kong, box, ricci
#   snakemake --cores 2 --report results/report.html # HTML report of every table and figure
# Keys of the config: config/README.md. Rules are thin calls of `python -m aceval ...`.
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


validate(config, os.path.join(workflow.basedir, "workflow", "schemas", "config.schema.yaml"))

# Where the workflow writes (results/, resources/, logs/, .snakemake/): config `directory`, or
# Snakemake's --directory; default the folder snakemake starts in. Relative paths of the config are
# that folder's, in the jobs too (config/README.md, "Where the outputs go").
LAUNCH_DIR = os.environ.setdefault("ACEVAL_LAUNCH_DIR", os.getcwd())
for _spec in config["datasets"].values():
    if "path" in _spec:
        _spec["path"] = os.path.join(LAUNCH_DIR, _spec["path"])
_default_root = os.path.join(workflow.basedir, "..", "shared", "data")  # beside the project
config["data_root"] = os.path.join(LAUNCH_DIR, config.get("data_root", _default_root))
if "peers_root" in config:
    config["peers_root"] = os.path.join(LAUNCH_DIR, config["peers_root"])
if config.get("directory") and workflow.is_main_process:
    workflow.workdir(os.path.join(LAUNCH_DIR, config["directory"]))


include: "workflow/rules/common.smk"
include: "workflow/rules/datasets.smk"
include: "workflow/rules/peers.smk"
include: "workflow/rules/results.smk"


onstart:
    PLAN.hashes.save()


onsuccess:
    PLAN.hashes.save()


onerror:
    PLAN.hashes.save()


rule all:
    default_target: True
    input:
        all_outputs,
