# Stage 3: Kong Objectives 3-5 (error angles), then one job per table and per figure (Kong's,
# Ricci's, reliability, methods against the ground truth).


def calibration_files(wildcards):
    return [f"results/{wildcards.dataset}/calibrations/{u}.csv" for u in calibration_units(wildcards.dataset)]


def axes_files(wildcards):
    return [f"results/{wildcards.dataset}/calibrations/{u}_axes.csv" for u in calibration_units(wildcards.dataset)]


def correlation_files(wildcards):
    return [f"results/{wildcards.dataset}/correlations/{s}.csv" for s in subjects(wildcards.dataset)]


def output_inputs(wildcards):
    """The inputs of a table or figure (INPUTS in common.smk), by kind."""
    files = {"correlations": correlation_files, "calibrations": calibration_files, "axes": axes_files,
             "angles": lambda w: f"results/{w.dataset}/angles.csv"}
    name = wildcards.table if "table" in wildcards.keys() else wildcards.figure
    return {kind: files[kind](wildcards) for kind in INPUTS[name]}


def source_options(inputs):
    """--correlations/--calibrations/--axes/--angles options of `aceval table|figure`."""
    return " ".join(f"--{kind} " + " ".join(inputs[kind] if kind != "angles" else [inputs[kind]])
                    for kind in ("correlations", "calibrations", "axes", "angles") if kind in inputs.keys())


def kong_number(name):
    """`aceval table|figure` takes Kong's tables and figures by number, the others by name."""
    return name[5:] if name.startswith("table") else name[6:] if name.startswith("figure") else name


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
        unpack(output_inputs),
    output:
        csv=report(
            "results/{dataset}/tables/{table}.csv",
            caption="../report/table.rst",
            category="{dataset}",
            subcategory="Tables",
            labels={"dataset": "{dataset}", "table": "{table}"},
        ),
        md="results/{dataset}/tables/{table}.md",
    params:
        root=lambda w: dataset_dir(w.dataset),
        sources=lambda w, input: source_options(input),
        names=lambda w: paper_names(w.dataset),
        which=lambda w: kong_number(w.table),
        data_label=lambda w: simulated_label(w.dataset),
    log:
        "logs/{dataset}/{table}.log",
    shell:
        "python -m aceval table {params.which} --dataset {params.root} {params.sources} "
        "--paper-names '{params.names}' --csv {output.csv} --md {output.md} 2> {log}"


rule figure:
    input:
        unpack(output_inputs),
    output:
        report(
            "results/{dataset}/figures/{figure}.png",
            caption="../report/figure.rst",
            category="{dataset}",
            subcategory="Figures",
            labels={"dataset": "{dataset}", "figure": "{figure}"},
        ),
    params:
        root=lambda w: dataset_dir(w.dataset),
        sources=lambda w, input: source_options(input),
        names=lambda w: paper_names(w.dataset),
        which=lambda w: kong_number(w.figure),
        data_label=lambda w: simulated_label(w.dataset),
    log:
        "logs/{dataset}/{figure}_figure.log",
    shell:
        "python -m aceval figure {params.which} --dataset {params.root} {params.sources} "
        "--paper-names '{params.names}' --out {output} 2> {log}"
