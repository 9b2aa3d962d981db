# Stages 1-2: one job per dataset (`aceval batches`). Simulated datasets are generated from a seed,
# real recordings imported, a lab's dataset read where it lies; the dataset is validated (its
# sheets, and of each recording file that it exists and its header; a failed validation stops
# the workflow before any calibration; a file changed after a good run validates again: the
# files' fingerprint is a param), then its subjects are calibrated in batches (config
# `subjects_per_job`), each batch in a worker process forked from the job (its imports paid once),
# a simulated batch from the recordings its worker has just simulated, in memory (the files are
# written all the same: users and the peers read them). Each batch reads each recording once,
# checks it (every problem named with its file and line; an error stops the workflow) and reduces
# it to the statistics the dataset's methods read; from them every calibration (Kong for every
# subset of repetitions, the axis methods, or Ricci's functional design), the correlations of
# Kong's Obj 1-2, Kong's Obj 3-5 angles and every method's test-retest units. The job's outputs
# are put in place together, or none. Every parameter reaches the shell quoted ({...:q}):
# dataset folders may hold spaces, quotes or any letters.


checkpoint simulate:
    output:
        dataset=directory("resources/{dataset}"),
        calibrations=directory("results/{dataset}/calibrations"),
        sheets="results/{dataset}/validation/sheets.tsv",
    log:
        "logs/{dataset}/simulate.log",
    wildcard_constraints:
        dataset=only(PLAN.simulated),
    priority: 10
    conda:
        "../envs/aceval.yaml"
    threads: lambda w: PLAN.dataset_threads(w.dataset, workflow.cores)
    params:
        source=lambda w: PLAN.simulate_options(w.dataset),
        batches=lambda w: PLAN.batch_options(w.dataset),
        results="results/{dataset}",
        code=CODE,
    shell:
        "python -m aceval batches {output.dataset:q} {params.source:q} {params.batches:q} "
        "--results {params.results:q} --jobs {threads} --force > {log:q} 2>&1 "
        "|| (cat {log:q} >&2; exit 1)"


checkpoint import_dataset:
    input:
        lambda w: PLAN.import_inputs(w.dataset),
    output:
        dataset=directory("resources/{dataset}"),
        calibrations=directory("results/{dataset}/calibrations"),
        sheets="results/{dataset}/validation/sheets.tsv",
    log:
        "logs/{dataset}/import.log",
    wildcard_constraints:
        dataset=only(PLAN.imported),
    conda:
        "../envs/aceval.yaml"
    threads: lambda w: PLAN.dataset_threads(w.dataset, workflow.cores)
    params:
        source=lambda w: PLAN.import_options(w.dataset),
        batches=lambda w: PLAN.batch_options(w.dataset),
        results="results/{dataset}",
        code=CODE,
    shell:
        "python -m aceval batches {output.dataset:q} {params.source:q} {params.batches:q} "
        "--results {params.results:q} --jobs {threads} --force > {log:q} 2>&1 "
        "|| (cat {log:q} >&2; exit 1)"


checkpoint calibrate:
    input:
        lambda w: PLAN.dataset_files(w.dataset),
    output:
        calibrations=directory("results/{dataset}/calibrations"),
        sheets="results/{dataset}/validation/sheets.tsv",
    log:
        "logs/{dataset}/calibrate.log",
    wildcard_constraints:
        dataset=only(PLAN.on_disk),
    conda:
        "../envs/aceval.yaml"
    threads: lambda w: PLAN.dataset_threads(w.dataset, workflow.cores)
    params:
        root=lambda w: PLAN.dataset_dir(w.dataset),
        files=lambda w: PLAN.recording_files_digest(w.dataset),
        batches=lambda w: PLAN.batch_options(w.dataset),
        results="results/{dataset}",
        code=CODE,
    shell:
        "python -m aceval batches {params.root:q} {params.batches:q} "
        "--results {params.results:q} --jobs {threads} --force > {log:q} 2>&1 "
        "|| (cat {log:q} >&2; exit 1)"
