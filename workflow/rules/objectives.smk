# Stage 3: Kong Objectives 3-5 (error angles), then one job per table and per figure (Kong's,
# Ricci's, reliability, methods against the ground truth).


rule angles:
    input:
        calibration_files,
    output:
        "results/{dataset}/angles.csv",
    log:
        "logs/{dataset}/angles.log",
    conda:
        "../envs/aceval.yaml"
    params:
        k=config["objectives"]["test_retest_k"],
    shell:
        "python -m aceval angles --calibrations {input:q} --out {output:q} --test-retest-k {params.k:q} 2> {log:q}"


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
    log:
        "logs/{dataset}/{table}.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: dataset_dir(w.dataset),
        data_label=lambda w: simulated_label(w.dataset),
        sources=source_options,
        names=lambda w: paper_names(w.dataset),
        which=lambda w: kong_number(w.table),
    shell:
        "python -m aceval table {params.which:q} --dataset {params.root:q} {params.sources:q} "
        "--paper-names {params.names:q} --csv {output.csv:q} --md {output.md:q} 2> {log:q}"


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
    log:
        "logs/{dataset}/{figure}_figure.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: dataset_dir(w.dataset),
        data_label=lambda w: simulated_label(w.dataset),
        sources=source_options,
        names=lambda w: paper_names(w.dataset),
        which=lambda w: kong_number(w.figure),
    shell:
        "python -m aceval figure {params.which:q} --dataset {params.root:q} {params.sources:q} "
        "--paper-names {params.names:q} --out {output:q} 2> {log:q}"
