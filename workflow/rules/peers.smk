# The peer tools beside aceval's methods (issue: the peers side by side): gaitmap's PcaAlignment,
# qmt's hinge joint axis, OpenSim's OpenSense IMUPlacer. None can share aceval's environment (nor
# each other's), so each runs in its own (.venv-peers/<environment>, from the pinned
# workflow/peers/<environment>.txt) behind a file interface: each calibration job's plan (which
# recordings, right axes, subsets) in, rotations in aceval's convention out (peer_io.py). The
# adapters' own source (workflow/peers/) is a param: an edit reruns their jobs.
# The workflow builds each environment (from the package index; aceval's own environment is never
# touched) the first time a peer job needs it, beside the simulations; later runs reuse it, and a
# change of the pins rebuilds it. `--config peers=[]` leaves the peers out (said on screen).


rule peer_envs:
    input:
        [PLAN.peer_env_stamp(peer.environment) for peer in PLAN.peers.values()],


rule peer_env:
    input:
        os.path.join(PEERS_DIR, "{env}.txt"),
    output:
        os.path.join(PLAN.peers_root, "{env}", "aceval-pins.txt"),
    log:
        "logs/peers/{env}_env.log",
    wildcard_constraints:
        env="|".join(peer.environment for peer in PLAN.peers.values()),
    conda:
        "../envs/aceval.yaml"
    params:
        env=lambda w: os.path.join(PLAN.peers_root, w.env),
    shell:
        "python3 -m venv --clear {params.env:q} > {log:q} 2>&1 && "
        "{params.env:q}/bin/python -m pip install --quiet -r {input:q} >> {log:q} 2>&1 && "
        "cp {input:q} {output:q}"


rule peer_calibrate:
    input:
        calibrations="results/{dataset}/calibrations",
        env=lambda w: PLAN.peer_env_stamp(PLAN.peers[w.peer].environment),
    output:
        "results/{dataset}/peers/{peer}/{subject}.csv",
    log:
        "logs/{dataset}/{peer}_{subject}.log",
    wildcard_constraints:
        peer="|".join(PLAN.peers),
    conda:
        lambda w: f"../envs/peer_{PLAN.peers[w.peer].environment}.yaml"
    params:
        python=lambda w: PLAN.peer_python(w.peer),
        adapter=lambda w: os.path.join(PEERS_DIR, PLAN.peers[w.peer].adapter),
        plan="results/{dataset}/calibrations/{subject}_plan.json",
        code=PEERS_CODE,
    shell:
        "{params.python:q} {params.adapter:q} {params.plan:q} {output:q} > {log:q} 2>&1"
