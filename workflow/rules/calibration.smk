# Stage 2: one pass per subject (or per batch of subjects, `subjects_per_job`): each recording file read
# once, checked (every problem named with its file and line; an error stops the workflow), and reduced
# to the statistics every analysis needs; from them every calibration (Kong for every subset of
# repetitions, the axis methods, or Ricci's functional design), the correlations of Kong's Obj 1-2
# (from the moments of each time-aligned recording pair), and what needs the calibrations from
# subsets of repetitions: Kong's Obj 3-5 angles and every method's test-retest units. Every parameter
# reaches the shell quoted ({...:q}): dataset folders may hold spaces, quotes or any letters.


rule calibrate:
    input:
        validation="results/{dataset}/validation/sheets.tsv",
    output:
        calibrations="results/{dataset}/calibrations/{subject}.csv",
        recordings="results/{dataset}/calibrations/{subject}_recordings.csv",
        axes="results/{dataset}/calibrations/{subject}_axes.csv",
        findings="results/{dataset}/calibrations/{subject}_findings.tsv",
        correlations="results/{dataset}/correlations/{subject}.csv",
        angles="results/{dataset}/calibrations/{subject}_angles.csv",
        retest="results/{dataset}/calibrations/{subject}_retest.csv",
        plan="results/{dataset}/calibrations/{subject}_plan.json",
    log:
        "logs/{dataset}/calibrate_{subject}.log",
    benchmark:
        "logs/{dataset}/benchmarks/calibrate_{subject}.tsv"
    conda:
        "../envs/aceval.yaml"
    params:
        root=lambda w: PLAN.dataset_dir(w.dataset),
        subject=lambda w: ["--subject", *subject_batches(w.dataset)[w.subject]],
        files=lambda w: PLAN.recording_files_digest(
            w.dataset, subject_batches(w.dataset)[w.subject]
        ),
        options=PLAN.calibrate_options(),
    shell:
        "python -m aceval calibrate {params.root:q} {params.subject:q} --allow-empty "
        "--out {output.calibrations:q} --recordings-out {output.recordings:q} --axes-out {output.axes:q} "
        "--findings-out {output.findings:q} "
        "--correlations-out {output.correlations:q} --angles-out {output.angles:q} "
        "--retest-out {output.retest:q} --plan-out {output.plan:q} {params.options:q} 2> {log:q}"
