"""The path-safety functions on their own (data/safety.py): absolute paths, '..', folders that are
symbolic links leading outside, outputs inside inputs, and folders aceval did not write. The
command-level cases are in test_bad_input.py; here each function's contract, so that a
refactor that bypasses the sheet validation still cannot write outside ``--out`` (issue 44)."""

import errno
import os
import re
import subprocess
import sys
from pathlib import Path, PurePosixPath

import pytest

from aceval.data.safety import (
    MARKER,
    FileSet,
    UnsafeOutputError,
    atomic_file,
    check_outputs,
    check_writable,
    claim,
    contained,
    fail,
    is_within,
    path_problem,
    staged_folder,
)


@pytest.fixture
def tree(tmp_path):
    """root/ with a sub folder and a file; outside/ beside it; root/link -> outside/,
    root/inner_link -> root/sub."""
    root, outside = tmp_path / "root", tmp_path / "outside"
    (root / "sub").mkdir(parents=True)
    outside.mkdir()
    (root / "sub" / "a.csv").write_text("a")
    (root / "link").symlink_to(outside, target_is_directory=True)
    (root / "inner_link").symlink_to(root / "sub", target_is_directory=True)
    return root, outside


# --- contained: where a file under an output folder may be written -----------------------------


@pytest.mark.parametrize(
    "relative", ["a.csv", "sub/a.csv", "sub/new/deeper/b.csv", "sub/../a.csv", "./a.csv"]
)
def test_contained_joins_a_relative_path_that_stays_inside(tree, relative):
    root, _ = tree
    assert contained(root, relative) == root / relative
    assert contained(str(root), PurePosixPath(relative)) == root / relative


@pytest.mark.parametrize(
    "relative, cause",
    [
        ("/etc/passwd", "absolute"),
        ("/tmp/x.csv", "absolute"),
        ("../x.csv", "climbs out"),
        ("../root/x.csv", "climbs out"),  # back in through the parent: still refused
        ("sub/../../x.csv", "climbs out"),
        ("sub/../../../etc/x.csv", "climbs out"),
        ("..", "climbs out"),
        ("link/x.csv", "leads outside"),  # a folder on the way is a link out of root
        ("link/deeper/x.csv", "leads outside"),
    ],
)
def test_contained_refuses_every_way_out(tree, relative, cause):
    root, outside = tree
    with pytest.raises(UnsafeOutputError, match=cause):
        contained(root, relative)
    assert not any(outside.iterdir())


def test_contained_allows_a_link_that_stays_inside(tree):
    root, _ = tree
    assert contained(root, "inner_link/x.csv") == root / "inner_link" / "x.csv"


def test_contained_names_the_path_and_the_root(tree):
    root, _ = tree
    with pytest.raises(UnsafeOutputError) as raised:
        contained(root, "../x.csv")
    assert "../x.csv" in str(raised.value) and str(root) in str(raised.value)


# --- path_problem: a path read from a sheet ----------------------------------------------------


@pytest.mark.parametrize(
    "relative", ["a.csv", "s1/t1.csv", "s1/../s1/t1.csv", "a..b.csv", "./x.csv"]
)
def test_path_problem_accepts_relative_paths_inside(relative):
    assert path_problem(relative) == ""


@pytest.mark.parametrize(
    "relative, cause",
    [
        ("", "empty"),
        ("/data/s1.csv", "absolute"),
        ("\\data\\s1.csv", "absolute"),
        ("../s1.csv", "climbs out"),
        ("s1/../../s1.csv", "climbs out"),
        ("..", "climbs out"),
    ],
)
def test_path_problem_names_absolute_and_climbing_paths(relative, cause):
    problem = path_problem(relative)
    assert cause in problem
    if relative:
        assert repr(relative) in problem


# --- is_within and check_outputs: outputs never in or around an input -------------------------


def test_is_within_resolves_links_and_parents(tree):
    root, outside = tree
    assert is_within(root, root) and is_within(root / "sub" / "a.csv", root)
    assert is_within(root / "sub" / ".." / "sub", root)
    assert not is_within(outside, root) and not is_within(root, root / "sub")
    assert is_within(root / "link" / "x", outside)  # through the link: outside, not in root
    assert not is_within(root / "link" / "x", root)
    assert not is_within(root.parent / "root2", root)  # a name prefix is not a parent


def test_check_outputs_refuses_an_output_in_an_input_or_around_it(tree):
    root, outside = tree
    with pytest.raises(UnsafeOutputError, match="lies inside the input dataset"):
        check_outputs({"--out": root / "results"}, {"dataset": root}, folders=("--out",))
    with pytest.raises(UnsafeOutputError, match="is the input dataset"):
        check_outputs({"--out": root}, {"dataset": root}, folders=("--out",))
    with pytest.raises(UnsafeOutputError, match="contains the input dataset"):
        check_outputs({"--out": root.parent}, {"dataset": root}, folders=("--out",))
    with pytest.raises(UnsafeOutputError, match="lies inside the input"):
        check_outputs({"--out": root / "link" / "x"}, {"dataset": outside})  # via the link
    with pytest.raises(UnsafeOutputError, match="is a folder"):
        check_outputs({"--table": outside}, {"dataset": root})
    # a file output beside the input, a folder output beside it, None and absent inputs: allowed
    check_outputs({"--table": outside / "t.csv"}, {"dataset": root})
    check_outputs({"--out": outside / "new"}, {"dataset": root}, folders=("--out",))
    check_outputs({"--out": None}, {"dataset": root})
    check_outputs({"--out": root / "x"}, {"dataset": None, "other": root / "missing"})
    # a file output containing an input is not a folder: only folder outputs are refused for it
    check_outputs({"--table": root.parent / "t.csv"}, {"dataset": root})
    # an option not given, or an input not given, does not end the checks of the others
    with pytest.raises(UnsafeOutputError, match="--b .* lies inside"):
        check_outputs({"--a": None, "--b": root / "x"}, {"dataset": root})
    with pytest.raises(UnsafeOutputError, match="lies inside the input dataset"):
        check_outputs({"--out": root / "x"}, {"other": None, "gone": root / "no", "dataset": root})


# --- the writers: nothing outside, nothing partial, nothing over a folder aceval did not write ----


def test_staged_folder_moves_a_complete_folder_into_place_with_its_marker(tmp_path):
    out = tmp_path / "out"
    staged_folder(out, False, lambda folder: (folder / "x.csv").write_text("x"))
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "x.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging folder left

    def failing(folder):
        (folder / "half.csv").write_text("half")
        raise RuntimeError("stopped")

    with pytest.raises(RuntimeError):
        staged_folder(tmp_path / "other", False, failing)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_staged_folder_replaces_only_a_folder_aceval_wrote_and_only_with_force(tmp_path):
    out = tmp_path / "out"
    staged_folder(out, False, lambda folder: (folder / "old.csv").write_text("old"))
    with pytest.raises(UnsafeOutputError, match="not empty.*--force"):
        staged_folder(out, False, lambda folder: None)
    staged_folder(out, True, lambda folder: (folder / "new.csv").write_text("new"))
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "new.csv"]
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "raw.csv").write_text("raw")
    with pytest.raises(UnsafeOutputError, match="not written by aceval"):
        staged_folder(theirs, True, lambda folder: None)
    assert (theirs / "raw.csv").read_text() == "raw"
    with pytest.raises(UnsafeOutputError, match="is a file"):
        staged_folder(theirs / "raw.csv", True, lambda folder: None)
    empty = tmp_path / "empty"
    empty.mkdir()
    staged_folder(empty, False, lambda folder: (folder / "x").write_text("x"))  # empty: allowed
    assert (empty / MARKER).is_file()


def test_atomic_file_leaves_the_old_file_when_writing_fails(tmp_path):
    path = tmp_path / "deep" / "deeper" / "t.csv"  # two folders to make
    atomic_file(path, lambda tmp: Path(tmp).write_text("one"))
    assert path.read_text() == "one"

    def failing(tmp):
        Path(tmp).write_text("half")
        raise RuntimeError("stopped")

    with pytest.raises(RuntimeError):
        atomic_file(path, failing)
    assert path.read_text() == "one"
    assert sorted(p.name for p in path.parent.iterdir()) == ["t.csv"]
    seen = []
    atomic_file(tmp_path / "f.parquet", lambda tmp: seen.append(Path(tmp).suffix) or tmp.touch())
    assert seen == [".parquet"]  # the temporary keeps the suffix: writers pick the format


def test_check_writable_names_a_folder_it_cannot_write(tmp_path, monkeypatch):
    """A folder where no file can be created (a read-only one; made so here by the probe itself
    failing, since root writes into read-only folders): refused, naming the nearest existing
    folder and the cause."""
    import tempfile

    def refused(*args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

    monkeypatch.setattr(tempfile, "mkstemp", refused)
    with pytest.raises(UnsafeOutputError, match=f"cannot write into {tmp_path} .Permission denied"):
        check_writable([tmp_path / "new" / "deeper"])


def test_check_writable_refuses_a_folder_under_a_file_and_leaves_no_probe(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(UnsafeOutputError, match="is a file"):
        check_writable([tmp_path / "afile" / "out"])
    check_writable([tmp_path / "new" / "deeper", tmp_path])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]  # nothing created, no probe


# --- the leftovers of a killed run, and nothing else, are removed -------------------------------

#: a process that holds a temporary of ``out.csv`` (locked) and waits, dying of any signal but 0
#: (SIGHUP too, even when started under nohup)
HOLDER = (
    "import signal, sys, time; from pathlib import Path; "
    "signal.signal(signal.SIGHUP, signal.SIG_DFL); "
    "from aceval.data.safety import new_temporary; "
    "print(new_temporary(Path(sys.argv[1])), flush=True); time.sleep(30)"
)


def test_only_a_dead_runs_own_temporaries_are_removed(tmp_path):
    """A killed run's temporaries of the output (its file and staging folder, no longer locked)
    go; a live run's (locked) stay, and so do other outputs' and a user's hidden files that
    merely look alike: names are matched in full, and no process id is read from one."""
    out = tmp_path / "out.csv"
    leftovers = [tmp_path / ".aceval-7-0123abcd.out.csv", tmp_path / ".aceval-7-89abcdef.out.csv"]
    leftovers[0].write_text("partial")
    leftovers[1].mkdir()
    (leftovers[1] / "half.csv").write_text("partial")
    live = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE, text=True
    )
    try:
        held = Path(live.stdout.readline().strip())
        kept = [
            tmp_path / ".aceval-7-0123abcd.out.csv.bak",  # another output's
            tmp_path / ".aceval-x-0123abcd.out.csv",  # no process id
            tmp_path / ".aceval-7-0123ABCD.out.csv",  # not our token
            tmp_path / ".aceval-7-0123abcd.out",  # another output's
            tmp_path / ".tmp.7.out.csv",  # an older aceval's naming: not ours to guess
            tmp_path / ".out.csv.7.k2j4h1x0",
        ]
        for path in kept:
            path.write_text("keep")
        with pytest.raises(
            UnsafeOutputError,
            match=rf"another aceval \(process {live.pid}\) is writing {out}: wait for it, or "
            "choose another output",
        ):
            FileSet([out])
        assert not any(p.exists() for p in leftovers)
        assert held.exists() and all(p.read_text() == "keep" for p in kept)
        with pytest.raises(subprocess.TimeoutExpired):  # asking whether it lives did not kill it
            live.wait(timeout=1)
    finally:
        live.kill()
        live.wait()
    claim(out)  # its holder dead: its temporary is a leftover now
    assert not held.exists() and all(p.read_text() == "keep" for p in kept)
    claim(tmp_path / "missing" / "out.csv")  # no folder: nothing to do


def test_a_temporary_is_held_while_its_run_lives(tmp_path):
    from aceval.data.safety import _held

    live = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(tmp_path / "x")], stdout=subprocess.PIPE, text=True
    )
    held = Path(live.stdout.readline().strip())
    assert _held(held)
    live.kill()
    live.wait()
    assert held.exists() and not _held(held)
    assert not _held(tmp_path / "gone")


def test_outputs_are_staged_beside_their_target_in_new_folders(tmp_path):
    """A folder output's staging folder is a hidden sibling named after it and this process
    ('.aceval-<pid>-<8 hex>.<name>'); missing parent folders are made; a file set's too."""
    out = tmp_path / "new" / "deeper" / "out"
    seen = []
    staged_folder(out, False, lambda folder: seen.append(folder))
    staging = re.fullmatch(rf"\.aceval-{os.getpid()}-[0-9a-f]{{8}}\.out", seen[0].name)
    assert seen[0].parent == out.parent and staging
    assert (out / MARKER).read_text().startswith("written by aceval")
    paths = [tmp_path / "a" / "b" / "t.csv", tmp_path / "c" / "u.csv"]
    with FileSet(paths, folders=[tmp_path / "d"]) as files:
        for path in paths:
            files.write(path, lambda tmp: Path(tmp).write_text(Path(tmp).name))
    for path in paths:
        assert re.fullmatch(rf"\.aceval-{os.getpid()}-[0-9a-f]{{8}}\.{path.name}", path.read_text())
    assert not [p for p in tmp_path.rglob(".aceval-*") if p.name != MARKER]


def test_check_writable_probes_inside_the_folder_itself(tmp_path, monkeypatch):
    import tempfile

    probes = []
    real = tempfile.mkstemp

    def spy(*args, **kwargs):
        handle, path = real(*args, **kwargs)
        probes.append(Path(path))
        return handle, path

    monkeypatch.setattr(tempfile, "mkstemp", spy)
    check_writable([tmp_path / "not" / "yet"])
    assert [p.parent for p in probes] == [tmp_path] and probes[0].name.startswith(".aceval-probe.")
    assert not probes[0].exists()


def test_fail_names_the_command_and_the_cause_on_stderr(capsys):
    assert fail("calibrate", ValueError("no such dataset")) == 2
    assert fail("apply", ValueError("x"), code=1) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == "aceval calibrate: no such dataset\naceval apply: x\n"
