# The peer tools beside aceval's methods (issue: the peers side by side): gaitmap's PcaAlignment,
# qmt's hinge joint axis, OpenSim's OpenSense IMUPlacer. None can share aceval's environment (nor
# each other's), so each runs in its own (.venv-peers/<environment>, from the pinned
# workflow/peers/<environment>.txt) behind a file interface: each calibration job's plan (which
# recordings, right axes, subsets) in, rotations in aceval's convention out (peer_io.py).
# `snakemake --cores 2 peer_envs` builds the environments (from the package index; aceval's own
# environment is never touched); a peer without one is not run.


rule peer_envs:
    input:
        [os.path.join(PEERS_ROOT, env) for env, _ in PEER_METHODS.values()],


rule peer_env:
    input:
        os.path.join(PEERS_DIR, "{env}.txt"),
    output:
        directory(os.path.join(PEERS_ROOT, "{env}")),
    log:
        "logs/peers/{env}_env.log",
    wildcard_constraints:
        env="|".join(env for env, _ in PEER_METHODS.values()),
    conda:
        "../envs/aceval.yaml"
    shell:
        "python3 -m venv {output:q} > {log:q} 2>&1 && "
        "{output:q}/bin/python -m pip install --quiet -r {input:q} >> {log:q} 2>&1"


rule peer_calibrate:
    input:
        plan="results/{dataset}/calibrations/{subject}_plan.json",
    output:
        "results/{dataset}/peers/{peer}/{subject}.csv",
    log:
        "logs/{dataset}/{peer}_{subject}.log",
    benchmark:
        "logs/{dataset}/benchmarks/peer_{peer}_{subject}.tsv"
    wildcard_constraints:
        peer="|".join(PEER_METHODS),
    conda:
        lambda w: f"../envs/peer_{PEER_METHODS[w.peer][0]}.yaml"
    params:
        python=lambda w: peer_python(w.peer),
        adapter=lambda w: os.path.join(PEERS_DIR, PEER_METHODS[w.peer][1]),
    shell:
        "{params.python:q} {params.adapter:q} {input.plan:q} {output:q} > {log:q} 2>&1"
