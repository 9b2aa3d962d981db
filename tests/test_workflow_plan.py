"""The workflow's plan of its configuration (aceval.workflow_plan): what each dataset gets, which
peers, which jobs, and a recording whose bytes change is seen even with its size and mtime kept."""

import os

import yaml

from aceval.methods import registry
from aceval.workflow_plan import Configuration, HashCache, read_sheet, tree_digest

from .runner import REPO


def _plan(tmp_path, datasets, **extra) -> Configuration:
    config = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    config = {**config, "datasets": datasets, "run": list(datasets), **extra}
    return Configuration(config, str(REPO), HashCache(str(tmp_path / "hashes.json")))


def test_each_dataset_gets_the_analyses_its_truth_and_protocol_allow(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    plan = _plan(
        tmp_path,
        {
            "sim": {"simulate": {"protocol": "kong"}, "analyses": ["kong"]},
            "children": {"simulate": {"protocol": "ricci"}, "analyses": ["ricci"]},
            "lab": {"path": str(lab), "analyses": ["kong"]},
            "neura": {
                "import": {"format": "xsens", "source": "x", "vicon": "v"},
                "analyses": ["kong"],
            },
            "qmt": {"import": {"format": "qmt", "source": "q"}, "analyses": ["kong"]},
        },
    )
    assert plan.analyses("sim") == ["kong", "decision", "methods", "retest"]
    assert plan.analyses("children") == ["ricci", "decision", "methods"]
    assert plan.analyses("lab") == ["kong", "decision", "retest"]  # no ground truth: no methods
    (lab / "ground_truth.tsv").write_text("subject\n")
    assert plan.analyses("lab") == ["kong", "decision", "methods", "retest"]
    assert plan.analyses("neura") == ["kong", "decision", "methods", "retest", "truth"]
    assert plan.analyses("qmt") == ["kong", "decision", "retest", "loose_reference"]
    assert plan.peers_of("sim") == list(registry.peers())
    assert plan.peers_of("children") == [] and "not run" in plan.peers_note("children")
    assert plan.dataset_dir("sim") == "resources/sim" and plan.dataset_dir("lab") == str(lab)
    assert (
        plan.data_label("sim").startswith("SIMULATED") and plan.data_label("lab") == "recorded data"
    )


def test_peers_left_out_are_said_and_the_rest_come_from_the_registry(tmp_path):
    plan = _plan(
        tmp_path,
        {"sim": {"simulate": {"protocol": "kong"}, "analyses": ["kong"]}},
        peers=["qmt_hinge"],
    )
    assert plan.peers_run == ["qmt_hinge"]
    assert plan.peers_absent == [m for m in registry.peers() if m != "qmt_hinge"]
    assert "gaitmap_pca" in plan.peers_note("sim")
    assert plan.peer_python("qmt_hinge").endswith(os.path.join("qmt", "bin", "python"))


def test_subjects_are_batched_in_sheet_order_and_a_single_subject_job_is_named_after_it(tmp_path):
    plan = _plan(
        tmp_path,
        {
            "one": {"simulate": {"protocol": "kong"}},
            "three": {"simulate": {"protocol": "kong"}, "subjects_per_job": 3},
        },
    )
    names = [f"S{k}" for k in range(1, 8)]
    assert plan.subject_batches("one", names[:2]) == {"S1": ["S1"], "S2": ["S2"]}
    batches = plan.subject_batches("three", names)
    assert list(batches) == ["_batch1", "_batch2", "_batch3"]
    assert sum(batches.values(), []) == names


def test_a_recording_changed_in_place_changes_the_digest_and_paths_out_of_the_folder_are_not_followed(
    tmp_path,
):
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "a.csv").write_text("t\n0\n")
    (lab / "recordings.tsv").write_text(
        "subject\tpath\nS1\ta.csv\nS2\t../outside.csv\n", encoding="utf-8-sig"
    )
    (tmp_path / "outside.csv").write_text("secret\n")
    plan = _plan(tmp_path, {"lab": {"path": str(lab), "analyses": ["kong"]}})
    assert read_sheet(str(lab / "recordings.tsv"))[0] == {"subject": "S1", "path": "a.csv"}
    before = plan.recording_files_digest("lab")
    assert plan.recording_files_digest("lab", ["S2"]) == plan.recording_files_digest("lab", [])
    stat = os.stat(lab / "a.csv")
    (lab / "a.csv").write_text("t\n1\n")  # same size
    os.utime(lab / "a.csv", ns=(stat.st_atime_ns, stat.st_mtime_ns))  # and the same mtime
    assert plan.recording_files_digest("lab") != before
    plan.hashes.save()
    assert HashCache.load(plan.hashes.path).entries == plan.hashes.entries


def test_a_simulated_dataset_is_named_after_its_key(tmp_path):
    """The powered design simulates Kong's protocol as `kong_powered`: its dataset.yaml, and so
    its SUMMARY.md and validation.txt, carry that name, not the simulator's default kong_sim."""
    plan = _plan(
        tmp_path,
        {"kong_powered": {"simulate": {"protocol": "kong", "subjects": 93}, "analyses": ["kong"]}},
    )
    assert plan.simulate_options("kong_powered") == [
        "--simulate",
        "kong",
        "--seed=0",
        "--name=kong_powered",
        "--subjects=93",
    ]


def test_each_dataset_job_gets_a_worker_per_batch_up_to_the_cores(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "subjects.tsv").write_text("subject\n" + "".join(f"S{k}\n" for k in range(7)))
    plan = _plan(
        tmp_path,
        {
            "kong": {"simulate": {"protocol": "kong"}, "subjects_per_job": 3},
            "box": {"simulate": {"protocol": "box"}},
            "lab": {"path": str(lab), "subjects_per_job": 4},
            "qmt": {"import": {"format": "qmt", "source": "q", "subject": "S1"}},
        },
    )
    assert plan.dataset_threads("kong", 2) == 2  # five subjects: batches of 3 and 2
    assert plan.dataset_threads("kong", 1) == 1
    assert plan.dataset_threads("box", 2) == 1  # one box
    assert plan.dataset_threads("lab", 8) == 2  # seven subjects in batches of 4
    assert plan.dataset_threads("qmt", 2) == 1  # one subject imported


def test_an_edit_of_the_package_changes_the_code_digest_every_rule_reads(tmp_path):
    """A constant changed in aceval's source reruns the jobs (the digest is a param of every
    rule); its compiled cache does not count."""
    package = tmp_path / "aceval"
    (package / "data").mkdir(parents=True)
    (package / "data" / "contract.py").write_text("GRAVITY = 9.81\n")
    before = tree_digest(str(package))
    (package / "__pycache__").mkdir()
    (package / "__pycache__" / "x.cpython-311.pyc").write_bytes(b"\0")
    assert tree_digest(str(package)) == before
    (package / "data" / "contract.py").write_text("GRAVITY = 9.80665\n")
    assert tree_digest(str(package)) != before
    plan = _plan(tmp_path, {"sim": {"simulate": {"protocol": "kong"}}})
    assert plan.code_digest() == tree_digest(os.path.join(REPO, "src", "aceval"))


def test_simulate_writes_the_name_it_is_given(tmp_path):
    from aceval.cli import main

    out = tmp_path / "box"
    assert (
        main(["simulate", "box", "--out", str(out), "--name", "my_box", "--repetitions", "1"]) == 0
    )
    assert yaml.safe_load((out / "dataset.yaml").read_text())["name"] == "my_box"
