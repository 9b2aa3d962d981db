# Stage 2: per subject (or per dataset, `calibration_jobs: one`), every calibration: Kong for every
# subset of repetitions and the axis methods (Ricci LM, align_vectors, TRIAD), or Ricci's functional
# design when the dataset has functional_axes.tsv; then (datasets with two sensor sets or segment
# pairs) the correlations of calibrated signals (Kong Obj 1-2). Every parameter reaches the shell
# quoted ({...:q}): dataset folders may hold spaces, quotes or any letters.


rule calibrate:
    input:
        validation="results/{dataset}/validation.txt",
        recordings=subject_recordings,
    output:
        calibrations="results/{dataset}/calibrations/{subject}.csv",
        recordings="results/{dataset}/calibrations/{subject}_recordings.csv",
        axes="results/{dataset}/calibrations/{subject}_axes.csv",
    log:
        "logs/{dataset}/calibrate_{subject}.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: dataset_dir(w.dataset),
        subject=lambda w: [] if w.subject == ALL_UNITS else ["--subject", w.subject],
        trim=trim_options(),
    shell:
        "python -m aceval calibrate {params.root:q} {params.subject:q} --validated --allow-empty "
        "--out {output.calibrations:q} --recordings-out {output.recordings:q} --axes-out {output.axes:q} "
        "{params.trim:q} 2> {log:q}"


rule correlate:
    input:
        calibrations="results/{dataset}/calibrations/{subject}.csv",
        recordings=subject_recordings,
    output:
        "results/{dataset}/correlations/{subject}.csv",
    log:
        "logs/{dataset}/correlate_{subject}.log",
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: dataset_dir(w.dataset),
        mode=config["objectives"]["correlation"],
        max_lag=config["objectives"]["max_lag_s"],
        pairs=json.dumps(config["objectives"]["segment_pairs"]),
        trim=trim_options(),
    shell:
        "python -m aceval correlate {params.root:q} --calibrations {input.calibrations:q} --out {output:q} "
        "--mode {params.mode:q} --max-lag-s {params.max_lag:q} --pairs {params.pairs:q} {params.trim:q} "
        "2> {log:q}"
