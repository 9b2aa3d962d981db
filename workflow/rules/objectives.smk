# Stage 3: Kong Objectives 3-5 (error angles), then one job per table and per figure.


def calibration_files(wildcards):
    return [f"results/{wildcards.dataset}/calibrations/{s}.csv" for s in subjects(wildcards.dataset)]


def correlation_files(wildcards):
    return [f"results/{wildcards.dataset}/correlations/{s}.csv" for s in subjects(wildcards.dataset)]


def table_inputs(wildcards):
    number = int(wildcards.number)
    if number in CORRELATION_TABLES:
        return {"correlations": correlation_files(wildcards)}
    return {"angles": f"results/{wildcards.dataset}/angles.csv"}


def figure_inputs(wildcards):
    if int(wildcards.number) in (6, 8):
        return {"correlations": correlation_files(wildcards)}
    return {"angles": f"results/{wildcards.dataset}/angles.csv"}


def source_options(inputs):
    """--correlations/--angles options of `aceval table|figure` from the named inputs."""
    options = []
    if "correlations" in inputs.keys():
        options.append("--correlations " + " ".join(inputs.correlations))
    if "angles" in inputs.keys():
        options.append(f"--angles {inputs.angles}")
    return " ".join(options)


rule angles:
    input:
        calibration_files,
    output:
        "results/{dataset}/angles.csv",
    params:
        k=config["objectives"]["test_retest_k"],
    log:
        "logs/{dataset}/angles.log",
    shell:
        "python -m aceval angles --calibrations {input} --out {output} --test-retest-k {params.k} 2> {log}"


rule table:
    input:
        unpack(table_inputs),
    output:
        csv=report(
            "results/{dataset}/tables/table{number}.csv",
            caption="../report/table.rst",
            category="{dataset}",
            subcategory="Tables",
            labels={"dataset": "{dataset}", "Kong table": "{number}"},
        ),
        md="results/{dataset}/tables/table{number}.md",
    params:
        root=lambda w: dataset_dir(w.dataset),
        sources=lambda w, input: source_options(input),
        names=lambda w: paper_names(w.dataset),
        data_label=lambda w: simulated_label(w.dataset),
    log:
        "logs/{dataset}/table{number}.log",
    shell:
        "python -m aceval table {wildcards.number} --dataset {params.root} {params.sources} "
        "--paper-names '{params.names}' --csv {output.csv} --md {output.md} 2> {log}"


rule figure:
    input:
        unpack(figure_inputs),
    output:
        report(
            "results/{dataset}/figures/figure{number}.png",
            caption="../report/figure.rst",
            category="{dataset}",
            subcategory="Figures",
            labels={"dataset": "{dataset}", "Kong figure": "{number}"},
        ),
    params:
        root=lambda w: dataset_dir(w.dataset),
        sources=lambda w, input: source_options(input),
        names=lambda w: paper_names(w.dataset),
        data_label=lambda w: simulated_label(w.dataset),
    log:
        "logs/{dataset}/figure{number}.log",
    shell:
        "python -m aceval figure {wildcards.number} --dataset {params.root} {params.sources} "
        "--paper-names '{params.names}' --out {output} 2> {log}"
