# Stage 4: per dataset, each claim of Kong et al. 2016 and Ricci et al. 2014 with holds / does not hold /
# not testable, and which test to use for which segment (datasets with ground truth).


rule summary:
    input:
        unpack(summary_inputs),
    output:
        report(
            "results/{dataset}/SUMMARY.md",
            caption="../report/summary.rst",
            category="{dataset}",
            subcategory="Summary",
            labels={"dataset": "{dataset}", "file": "SUMMARY.md"},
        ),
    log:
        "logs/{dataset}/summary.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: dataset_dir(w.dataset),
        note=lambda w: DATASETS[w.dataset].get("note", ""),
        data_label=lambda w: simulated_label(w.dataset),
    shell:
        "python -m aceval summary --dataset {params.root:q} --note={params.note:q} --out {output:q} {input:q} 2> {log:q}"
