# Stage 1: the datasets. Simulated ones are generated from a seed, real recordings imported; every
# dataset's sheets are validated against the contract, and each recording file's presence and
# header, before anything else runs (a failed validation stops the workflow; a file changed after a
# good run validates again: the files' fingerprint is a param). The files' contents are checked in
# the pass that reads them (stage 2).


rule simulate:
    output:
        directory("resources/{dataset}"),
    log:
        "logs/{dataset}/simulate.log",
    benchmark:
        "logs/{dataset}/benchmarks/simulate.tsv"
    wildcard_constraints:
        dataset=only(PLAN.simulated),
    priority: 10
    conda:
        "../envs/aceval.yaml"
    threads: 2
    params:
        protocol=lambda w: DATASETS[w.dataset]["simulate"]["protocol"],
        seed=lambda w: DATASETS[w.dataset]["simulate"].get("seed", 0),
        options=lambda w: PLAN.simulate_options(w.dataset),
    shell:
        "python -m aceval simulate {params.protocol:q} --out {output:q} --seed {params.seed:q} {params.options:q} "
        "--jobs {threads} --force 2> {log:q}"


rule import_dataset:
    input:
        lambda w: PLAN.import_inputs(w.dataset),
    output:
        directory("resources/{dataset}"),
    log:
        "logs/{dataset}/import.log",
    benchmark:
        "logs/{dataset}/benchmarks/import.tsv"
    wildcard_constraints:
        dataset=only(PLAN.imported),
    conda:
        "../envs/aceval.yaml"
    params:
        format=lambda w: DATASETS[w.dataset]["import"]["format"],
        options=lambda w: PLAN.import_options(w.dataset),
        source=lambda w: PLAN.import_source(w.dataset),
    shell:
        "python -m aceval import {params.format:q} {params.source:q} --out {output:q} {params.options:q} "
        "--force 2> {log:q}"


checkpoint validate:
    input:
        lambda w: PLAN.dataset_files(w.dataset),
    output:
        "results/{dataset}/validation/sheets.tsv",
    log:
        "logs/{dataset}/validate.log",
    benchmark:
        "logs/{dataset}/benchmarks/validate.tsv"
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: PLAN.dataset_dir(w.dataset),
        files=lambda w: PLAN.recording_files_digest(w.dataset),
    shell:
        "python -m aceval validate {params.root:q} --sheets-only --findings-out {output:q} > {log:q} 2>&1 "
        "|| (cat {log:q} >&2; exit 1)"
