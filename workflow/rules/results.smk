# Stage 3: per dataset, one job writes its results folder (`aceval outputs`) in one process: Kong's
# Obj 3-5 angles, every table and figure of its analyses as the registry aceval.report.outputs
# declares them, SUMMARY.md with each claim of Kong et al. 2016 and Ricci et al. 2014 (holds / does
# not hold / inconclusive / not testable), and validation.txt with the sheets' and every file's
# findings. One process per dataset, not one per output: start-up (pandas, SciPy, statsmodels,
# Matplotlib) costs more than most outputs; and one job per dataset, not one for the run, so that
# a dataset's change reruns its results only and two datasets' results run side by side. A
# dataset's analyses decide which tables and figures it has, so the job's outputs are its tables/
# and figures/ folders (each file in the report).


rule results:
    input:
        unpack(results_inputs),
    output:
        summary=report(
            "results/{dataset}/SUMMARY.md",
            caption="../report/summary.rst",
            category="{dataset}",
            subcategory="Summary",
            labels={"dataset": "{dataset}", "file": "SUMMARY.md"},
        ),
        validation="results/{dataset}/validation.txt",
        angles="results/{dataset}/angles.csv",
        tables=report(
            directory("results/{dataset}/tables"),
            patterns=["{name}.csv"],
            caption="../report/table.rst",
            category="{dataset}",
            subcategory="Tables",
            labels={"dataset": "{dataset}", "table": "{name}"},
        ),
        figures=report(
            directory("results/{dataset}/figures"),
            patterns=["{name}.png"],
            caption="../report/figure.rst",
            category="{dataset}",
            subcategory="Figures",
            labels={"dataset": "{dataset}", "figure": "{name}"},
        ),
    log:
        "logs/{dataset}/results.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: PLAN.dataset_dir(w.dataset),
        results="results/{dataset}",
        inputs=input_options,
        options=lambda w: PLAN.results_options(w.dataset),
        data_label=lambda w: PLAN.data_label(w.dataset),
        code=CODE,
    shell:
        "python -m aceval outputs --dataset {params.root:q} --results {params.results:q} "
        "{params.options:q} {params.inputs:q} 2> {log:q}"
