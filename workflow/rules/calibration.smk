# Stage 2: per subject (or per dataset, `calibration_jobs: one`), every calibration: Kong for every
# subset of repetitions and the axis methods (Ricci LM, align_vectors, TRIAD), or Ricci's functional
# design when the dataset has functional_axes.tsv; then (datasets with two sensor sets or segment
# pairs) the correlations of calibrated signals (Kong Obj 1-2).


rule calibrate:
    input:
        validation="results/{dataset}/validation.txt",
        recordings=subject_recordings,
    output:
        calibrations="results/{dataset}/calibrations/{subject}.csv",
        recordings="results/{dataset}/calibrations/{subject}_recordings.csv",
        axes="results/{dataset}/calibrations/{subject}_axes.csv",
    params:
        root=lambda w: dataset_dir(w.dataset),
        subject=lambda w: "" if w.subject == ALL_UNITS else f"--subject {w.subject}",
        trim=config["calibration"]["trim"],
    log:
        "logs/{dataset}/calibrate_{subject}.log",
    shell:
        "python -m aceval calibrate {params.root} {params.subject} --validated "
        "--out {output.calibrations} --recordings-out {output.recordings} --axes-out {output.axes} "
        "--trim-threshold {params.trim[threshold]} --closing-s {params.trim[closing_s]} "
        "--window-s {params.trim[window_s]} --min-peak-deg-s {params.trim[min_peak_deg_s]} 2> {log}"


rule correlate:
    input:
        calibrations="results/{dataset}/calibrations/{subject}.csv",
        recordings=subject_recordings,
    output:
        "results/{dataset}/correlations/{subject}.csv",
    params:
        root=lambda w: dataset_dir(w.dataset),
        mode=config["objectives"]["correlation"],
        pairs=json.dumps(config["objectives"]["segment_pairs"]),
    log:
        "logs/{dataset}/correlate_{subject}.log",
    shell:
        "python -m aceval correlate {params.root} --calibrations {input.calibrations} --out {output} "
        "--mode {params.mode} --pairs '{params.pairs}' 2> {log}"
