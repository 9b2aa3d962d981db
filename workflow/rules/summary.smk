# Stage 4: per dataset, each claim of Kong et al. 2016 and Ricci et al. 2014 with holds / does not hold /
# not testable, and which test to use for which segment (datasets with ground truth).


def summary_inputs(wildcards):
    dataset = wildcards.dataset
    inputs = {"validation": f"results/{dataset}/validation.txt",
              "tables": [f"results/{dataset}/tables/{name}.csv" for name in tables_of(dataset)]}
    if "kong" in analyses(dataset):
        inputs["angles"] = f"results/{dataset}/angles.csv"
        inputs["calibrations"] = calibration_files(wildcards)
    return inputs


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
    params:
        root=lambda w: dataset_dir(w.dataset),
        note=lambda w: DATASETS[w.dataset].get("note", "").replace("'", "’"),
        data_label=lambda w: simulated_label(w.dataset),
    log:
        "logs/{dataset}/summary.log",
    shell:
        "python -m aceval summary --dataset {params.root} --note '{params.note}' --out {output} {input} 2> {log}"
