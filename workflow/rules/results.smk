# Stage 3: per dataset, two jobs write its results folder (`aceval outputs`), each in one process:
# the tables (Kong's Obj 3-5 angles, every table of its analyses as the registry aceval.report.outputs
# declares them, SUMMARY.md with each claim of Kong et al. 2016 and Ricci et al. 2014: holds / does
# not hold / not testable, and validation.txt with the sheets' and every file's findings) and the
# figures, side by side. Not one process per output: start-up (pandas, SciPy, statsmodels, seaborn)
# costs more than most outputs. Rules per dataset, because each dataset's outputs differ (Snakemake
# evaluates a rule's shell late: everything dataset-specific reaches it through input, output and
# params).

for _dataset in DATASETS:
    for _kind in ("table", "figure"):
        if not results_outputs(_dataset, _kind):
            continue

        rule:
            name:
                f"{_kind}s_{_dataset}"
            input:
                unpack(results_inputs(_dataset)),
            output:
                **results_outputs(_dataset, _kind),
            log:
                f"logs/{_dataset}/{_kind}s.log",
            benchmark:
                f"logs/{_dataset}/benchmarks/{_kind}s.tsv"
            conda:
                "../envs/aceval.yaml"
            params:
                root=dataset_dir(_dataset),
                results=lambda w, output: results_folder(output),
                kind=_kind,
                inputs=results_options,
                analyses=analyses(_dataset),
                names=json.dumps(DATASETS[_dataset].get("paper_names", {})),
                note=DATASETS[_dataset].get("note", ""),
                peers_note=peers_note(_dataset),
                k=config["objectives"]["test_retest_k"],
                data_label=simulated_label(_dataset),
            shell:
                "python -m aceval outputs --kinds {params.kind:q} --dataset {params.root:q} "
                "--results {params.results:q} --analyses {params.analyses:q} {params.inputs:q} "
                "--paper-names {params.names:q} --note={params.note:q} --note={params.peers_note:q} "
                "--test-retest-k {params.k:q} "
                "2> {log:q}"
