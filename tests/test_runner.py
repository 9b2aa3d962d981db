"""tests/runner.py's ``aceval``: a command run in the test's process says and returns what
``python -m aceval`` says and returns, and leaves nothing behind for the next one."""

import os
import signal
import sys
import warnings
from pathlib import Path

import pytest

from . import runner
from .minidataset import make_dataset
from .runner import aceval, aceval_process


def _meddling(argv):
    """A command that changes what a process's end would undo, and warns (as from one place)."""
    import matplotlib
    import numpy as np

    assert matplotlib.rcParams["lines.linewidth"] == matplotlib.rcParamsOrig["lines.linewidth"]
    os.chdir("/")
    os.environ["ACEVAL_RUNNER_TEST"] = "set"
    signal.signal(signal.SIGTERM, lambda *_: None)
    np.seterr(all="raise")
    matplotlib.rcParams["lines.linewidth"] = 9.0
    for _ in range(2):
        warnings.warn("a user warning", UserWarning, stacklevel=1)
    warnings.warn("an old call", DeprecationWarning, stacklevel=1)
    print("done")
    return int(argv[0])


@pytest.fixture
def meddling(monkeypatch):
    monkeypatch.setattr(runner, "_main", lambda: _meddling)


def test_each_command_starts_as_a_new_process_and_leaves_nothing_behind(meddling, tmp_path):
    """The working folder, environment, SIGTERM handler, NumPy's error handling and Matplotlib's
    settings are the caller's again afterwards; a warning is printed once per place, in every
    command (not only the first: a process's registry of shown warnings starts empty), and a
    DeprecationWarning outside __main__ is not printed, whatever the test session's filters."""
    import matplotlib
    import numpy as np

    matplotlib.rcParams["lines.linewidth"] = 2.5  # the caller's own (a seaborn theme, say)
    before = (os.getcwd(), dict(os.environ), signal.getsignal(signal.SIGTERM), np.geterr())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the session's filters do not reach the command
        for code in (0, 3):
            result = aceval(code, cwd=tmp_path)
            assert result.code == code and result.out == "done\n"
            assert result.err.count("UserWarning: a user warning") == 1, result.err
            assert "DeprecationWarning" not in result.err
    assert (os.getcwd(), dict(os.environ), signal.getsignal(signal.SIGTERM), np.geterr()) == before
    assert matplotlib.rcParams["lines.linewidth"] == 2.5
    matplotlib.rc_file_defaults()


@pytest.mark.parametrize(
    "ending, code, said",
    [
        (SystemExit(None), 0, ""),
        (SystemExit(4), 4, ""),
        (SystemExit("stopped: a reason"), 1, "stopped: a reason\n"),
        (ValueError("a bug"), 1, "Traceback (most recent call last)"),
    ],
)
def test_an_exit_or_an_exception_ends_as_in_a_process(monkeypatch, ending, code, said):
    def main(argv):
        raise ending

    monkeypatch.setattr(runner, "_main", lambda: main)
    result = aceval("anything")
    assert result.code == code and said in result.err
    assert result.traceback == isinstance(ending, ValueError)


def test_stdout_is_strict_utf8_and_stderr_escapes_as_in_a_process(monkeypatch):
    """A file name that is not UTF-8 (its bytes as surrogates) printed on stderr is escaped; on
    stdout it is an error, as in a process whose output is a pipe."""
    name = os.fsdecode(b"data/\xff.csv")

    def main(argv):
        print(name, file=sys.stderr if argv[0] == "err" else sys.stdout)
        return 0

    monkeypatch.setattr(runner, "_main", lambda: main)
    assert aceval("err").err == "data/\\udcff.csv\n"
    failed = aceval("out")
    assert failed.code == 1 and "UnicodeEncodeError" in failed.err


@pytest.mark.slow  # a subprocess for each command (about 1.5 CPU-s of imports each)
def test_a_command_here_says_and_returns_what_the_process_does(tmp_path):
    """The same exit code, stdout and stderr, in this process and in a subprocess: a usage error,
    the help, a valid and an invalid dataset, a calibration that flags its IMU, and a refused
    output."""
    mini = make_dataset(tmp_path / "mini")
    broken = make_dataset(tmp_path / "broken")
    (broken / "s1_t1_r2.csv").unlink()
    out = tmp_path / "out.csv"
    commands = [
        ("calibrate",),
        ("--help",),
        ("validate", mini),
        ("validate", broken),
        ("calibrate", mini, "--out", out, "--subsets", "full"),
        ("calibrate", mini, "--out", mini / "imus.tsv"),
    ]
    for args in commands:
        here, there = aceval(*args), aceval_process(*args)
        assert (here.code, here.out, here.err) == (there.code, there.out, there.err), args
        Path(out).unlink(missing_ok=True)
