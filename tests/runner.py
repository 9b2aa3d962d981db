"""How the tests run aceval and the workflow.

* :func:`aceval`: ``aceval <args>`` in this process, through :func:`aceval.cli.main`, as faithful
  to ``python -m aceval`` as a subprocess is (its exit code, stdout and stderr as text, a
  traceback where the process would print one), without the 1-2 CPU-s of imports a process pays;
* :func:`aceval_process`: the same in a subprocess, for what only a process shows (a hang, a
  signal, a resource limit, another user);
* :func:`snakemake`: the README's workflow command (``snakemake --cores 2``), with the Snakefile
  of this checkout, in a folder of the test's own, by the interpreter running the tests.
"""

from __future__ import annotations

import contextlib
import io
import os
import resource
import signal
import subprocess
import sys
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: the real recordings, beside the project (../shared/data/README.md)
DATA = REPO.parent / "shared" / "data"
#: the README's workflow command (tests/test_habits.py checks that the README says exactly this)
README_WORKFLOW = ["snakemake", "--cores", "2"]
#: a new interpreter's warning filters (no -W option, no PYTHONWARNINGS, not in development mode:
#: the Python documentation's "Default Warning Filter"), first match wins
DEFAULT_WARNING_FILTERS = (
    ("default", DeprecationWarning, "__main__"),
    ("ignore", DeprecationWarning, ""),
    ("ignore", PendingDeprecationWarning, ""),
    ("ignore", ImportWarning, ""),
    ("ignore", ResourceWarning, ""),
)
#: the signals whose handlers a command could set (a process's end would drop them)
HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@dataclass
class Result:
    """What a user sees of one command: exit code (None: did not end before its timeout), stdout
    and stderr."""

    code: int | None
    out: str
    err: str

    @property
    def said(self) -> str:
        return self.out + self.err

    @property
    def traceback(self) -> bool:
        return "Traceback (most recent call last)" in self.said


def aceval(*args, cwd: Path | str | None = None) -> Result:
    """``aceval *args`` in this process, as ``python -m aceval *args`` would run.

    What a new process starts from, each command starts from here too, and what it changes ends
    with it: the working folder (``cwd``), the environment (and a pipe's 80 columns for the
    help's lines where the environment does not say COLUMNS), the warning filters (a new
    interpreter's: each warning printed on stderr once per place, whatever the test session's
    filters), NumPy's floating-point error handling, the SIGINT and SIGTERM handlers, and
    Matplotlib's settings (its matplotlibrc's for the command) and the figures it opened. stdout
    and stderr are UTF-8 as in a process (stdout strict, stderr backslash-escaping what cannot be
    encoded), never a terminal. An exit (``SystemExit``) gives its code, as the interpreter does;
    any other exception its traceback on stderr and exit code 1. The files a command leaves
    locked must be none: a process would release them at its end, a library call must not keep
    them.
    """
    out, err = _stream("strict"), _stream("backslashreplace")
    with _as_a_new_process(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = _exit_code(_main()([str(a) for a in args]))
        except SystemExit as exc:
            code = _exit_code(exc.code)
        except Exception:
            traceback.print_exc()
            code = 1
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
    return Result(code, _text(out), _text(err))


def _main():
    from aceval.cli import main

    return main


def _stream(errors: str) -> io.TextIOWrapper:
    return io.TextIOWrapper(io.BytesIO(), encoding="utf-8", errors=errors, write_through=True)


def _text(stream: io.TextIOWrapper) -> str:
    return stream.buffer.getvalue().decode("utf-8", errors="replace")


def _exit_code(code) -> int:
    """The exit status the interpreter gives ``sys.exit(code)``: None is 0, an integer itself,
    anything else printed on stderr and 1."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


@contextlib.contextmanager
def _as_a_new_process(cwd):
    import numpy as np

    from aceval.data import safety

    folder, environment = os.getcwd(), dict(os.environ)
    handlers = {s: signal.getsignal(s) for s in HANDLED_SIGNALS}
    held = set(_locked(safety))
    try:
        if cwd is not None:
            os.chdir(cwd)
        for name, size in (("COLUMNS", "80"), ("LINES", "24")):  # a pipe's, not the terminal's
            os.environ.setdefault(name, size)
        with warnings.catch_warnings(), np.errstate(all="warn", under="ignore"), _matplotlib():
            warnings.resetwarnings()
            for action, category, module in DEFAULT_WARNING_FILTERS:
                warnings.filterwarnings(action, category=category, module=module, append=True)
            warnings.showwarning = _show_on_stderr
            yield
    finally:
        os.chdir(folder)
        if os.environ != environment:
            os.environ.clear()
            os.environ.update(environment)
        for number, handler in handlers.items():
            signal.signal(number, handler)
    left = _locked(safety) - held
    assert not left, f"aceval left temporaries locked after it returned: {sorted(map(str, left))}"


def _locked(safety) -> set:
    """This process's locked output temporaries (none known to a checkout older than them)."""
    return set(getattr(safety, "_OURS", {}))


def _show_on_stderr(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as the interpreter prints it, on the stderr of the moment."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


@contextlib.contextmanager
def _matplotlib():
    """Matplotlib's settings as a new process reads them (its matplotlibrc) for the command, the
    caller's again after it (a fresh import's if the command imported it), and the figures the
    command opened closed."""
    before = _figures()
    caller = sys.modules.get("matplotlib")
    try:
        if caller is None:
            yield
        else:
            with caller.rc_context():
                caller.rc_file_defaults()
                yield
    finally:
        for number in _figures() - before:
            sys.modules["matplotlib.pyplot"].close(number)
        if caller is None and "matplotlib" in sys.modules:
            sys.modules["matplotlib"].rc_file_defaults()


def _figures() -> set:
    pyplot = sys.modules.get("matplotlib.pyplot")
    return set(pyplot.get_fignums()) if pyplot else set()


def aceval_process(
    *args,
    cwd: Path | str | None = None,
    timeout: float = 300,
    limit_bytes: int | None = None,
    user: int | None = None,
) -> Result:
    """``python -m aceval *args`` in a subprocess: its exit code (None: still running after
    ``timeout`` s, then killed), stdout and stderr. ``limit_bytes``: writes beyond it fail
    (EFBIG), as on a full disk; ``user``: run as this user and group id."""

    def limits():
        if limit_bytes is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
        if user is not None:
            os.setgid(user)
            os.setuid(user)

    try:
        done = subprocess.run(
            [sys.executable, "-m", "aceval", *map(str, args)],
            capture_output=True,
            text=True,
            cwd=cwd,
            timeout=timeout,
            preexec_fn=limits,
        )
    except subprocess.TimeoutExpired as exc:
        return Result(None, _decoded(exc.stdout), _decoded(exc.stderr))
    return Result(done.returncode, done.stdout, done.stderr)


def _decoded(text) -> str:
    return text.decode(errors="replace") if isinstance(text, bytes) else str(text or "")


def snakemake(
    workdir: Path, *args: str, config: bool = True, env: dict | None = None
) -> subprocess.CompletedProcess:
    """Run the README's workflow command in ``workdir`` (with its config.yaml unless ``config`` is
    False: then the repository's config/config.yaml)."""
    command = [sys.executable, "-m", *README_WORKFLOW, "-s", str(REPO / "Snakefile")]
    command += ["--directory", str(workdir)]
    if config:
        command += ["--configfile", str(workdir / "config.yaml"), "--replace-workflow-config"]
    # the rules call `python -m aceval`: make that the interpreter running the tests
    env = env or os.environ
    env = {**env, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"}
    return subprocess.run(command + list(args), capture_output=True, text=True, env=env)
