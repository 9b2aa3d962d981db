# aceval: reproduce Kong et al. 2016 (Objectives 1-5, rigid box) on every configured dataset.
#   snakemake --cores 2                              # default config: simulated kong, box, ricci
#   snakemake --cores 2 --report results/report.html # HTML report of every table and figure
# Keys of the config: config/README.md. Rules are thin calls of `python -m aceval ...`.
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


validate(config, os.path.join(workflow.basedir, "workflow", "schemas", "config.schema.yaml"))


include: "workflow/rules/common.smk"
include: "workflow/rules/datasets.smk"
include: "workflow/rules/calibration.smk"
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
