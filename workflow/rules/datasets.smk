# Stage 1: the datasets. Simulated ones are generated from a seed, real recordings imported; every dataset is validated
# against the contract before anything else runs (a failed validation stops the workflow).


def only(names):
    """A wildcard constraint matching exactly these datasets (nothing when there are none)."""
    return "|".join(map(re.escape, names)) or "(?!)"


rule simulate:
    wildcard_constraints:
        dataset=only(SIMULATED),
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


rule import_dataset:
    wildcard_constraints:
        dataset=only(IMPORTED),
    input:
        lambda w: [p for p in (import_source(w.dataset), import_source(w.dataset, "sensors"),
                               import_source(w.dataset, "vicon")) if p],
    output:
        directory("resources/{dataset}"),
    params:
        format=lambda w: DATASETS[w.dataset]["import"]["format"],
        options=lambda w: " ".join(
            [f"--name {w.dataset}"]
            + [f"--{key} {import_source(w.dataset, key)}" for key in ("sensors", "vicon") if key in DATASETS[w.dataset]["import"]]
            + [f"--subject {DATASETS[w.dataset]['import']['subject']}" for _ in [0] if "subject" in DATASETS[w.dataset]["import"]]
        ),
        source=lambda w: import_source(w.dataset),
    log:
        "logs/{dataset}/import.log",
    shell:
        "python -m aceval import {params.format} {params.source} --out {output} {params.options} --force 2> {log}"


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
