# Stage 1: the datasets. Simulated ones are generated from a seed; every dataset is validated
# against the contract before anything else runs (a failed validation stops the workflow).


rule simulate:
    output:
        directory("resources/{dataset}"),
    params:
        protocol=lambda w: DATASETS[w.dataset]["simulate"]["protocol"],
        seed=lambda w: DATASETS[w.dataset]["simulate"].get("seed", 0),
        options=lambda w: " ".join(
            f"--{key} {DATASETS[w.dataset]['simulate'][key]}"
            for key in ("subjects", "repetitions")
            if key in DATASETS[w.dataset]["simulate"]
        ),
    log:
        "logs/{dataset}/simulate.log",
    shell:
        "python -m aceval simulate {params.protocol} --out {output} --seed {params.seed} {params.options} --force 2> {log}"


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
        "python -m aceval validate {params.root} --out {output} > {log} 2>&1 || (cat {log} >&2; exit 1)"
