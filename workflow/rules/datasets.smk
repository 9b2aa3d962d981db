# Stage 1: the datasets. Simulated ones are generated from a seed, real recordings imported; every
# dataset is validated against the contract, its recording files included, before anything else
# runs (a failed validation stops the workflow; a file changed after a good run validates again).


rule simulate:
    wildcard_constraints:
        dataset=only(SIMULATED),
    output:
        directory("resources/{dataset}"),
    params:
        protocol=lambda w: DATASETS[w.dataset]["simulate"]["protocol"],
        seed=lambda w: DATASETS[w.dataset]["simulate"].get("seed", 0),
        options=lambda w: [
            f"--{key}={DATASETS[w.dataset]['simulate'][key]}"
            for key in ("subjects", "repetitions")
            if key in DATASETS[w.dataset]["simulate"]
        ],
    log:
        "logs/{dataset}/simulate.log",
    shell:
        "python -m aceval simulate {params.protocol:q} --out {output:q} --seed {params.seed:q} {params.options:q} "
        "--force 2> {log:q}"


rule import_dataset:
    wildcard_constraints:
        dataset=only(IMPORTED),
    input:
        import_inputs,
    output:
        directory("resources/{dataset}"),
    params:
        format=lambda w: DATASETS[w.dataset]["import"]["format"],
        options=import_options,
        source=lambda w: import_source(w.dataset),
    log:
        "logs/{dataset}/import.log",
    shell:
        "python -m aceval import {params.format:q} {params.source:q} --out {output:q} {params.options:q} "
        "--force 2> {log:q}"


checkpoint validate:
    input:
        dataset_input,
    output:
        "results/{dataset}/validation.txt",
    params:
        root=lambda w: dataset_dir(w.dataset),
    log:
        "logs/{dataset}/validate.log",
    shell:
        "python -m aceval validate {params.root:q} --out {output:q} > {log:q} 2>&1 || (cat {log:q} >&2; exit 1)"
