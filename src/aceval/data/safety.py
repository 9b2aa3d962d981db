"""Where aceval may write: never inside an input dataset, never over a folder it did not write.

Raw recordings are only ever read. Every command's outputs are checked before anything is written:

* no output may be, or lie inside, an input dataset or source folder, and a folder output may not
  contain one (replacing it would delete the input);
* a folder output (``simulate``, ``import``, ``apply``) is written into a hidden staging folder
  beside it and moved into place when complete, with a marker file :data:`MARKER`; ``--force``
  replaces an existing non-empty folder only when it holds that marker, i.e. aceval wrote it;
* a file output is written to a hidden temporary file and renamed into place; the files of one
  command (``calibrate``'s nine) are staged together and renamed into place together when all are
  written (:class:`FileSet`), so a failed or stopped run leaves none of them;
* every output folder is checked for writing before the work (:func:`check_writable`), and the
  leftovers of a killed run (its hidden temporaries, named with its process id) are removed by the
  next run that writes the same output;
* a relative path read from a sheet (``recordings.tsv``) must stay inside its dataset, and every
  file written under an output folder must land inside it (:func:`contained`).

SIGTERM (Snakemake's way of stopping a job) is turned into a normal exit so that the clean-up of
staging folders and temporary files runs (:func:`exit_cleanly_on_sigterm`).
"""

from __future__ import annotations

import glob
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path, PurePath

#: left in every folder aceval writes as a whole; ``--force`` only replaces folders holding it
MARKER = ".aceval-output"


class UnsafeOutputError(ValueError):
    """An output would overwrite or delete an input, or a folder aceval did not write."""


def _resolved(path: str | Path) -> Path:
    return Path(path).expanduser().resolve()


def is_within(path: str | Path, folder: str | Path) -> bool:
    """True when ``path`` is ``folder`` or lies inside it (symbolic links resolved)."""
    path, folder = _resolved(path), _resolved(folder)
    return path == folder or folder in path.parents


def check_outputs(
    outputs: dict[str, str | Path], inputs: dict[str, str | Path], folders: tuple[str, ...] = ()
) -> None:
    """Refuse any output that is or lies inside an input folder, is an input file, or (for the
    options named in ``folders``) contains an input. ``outputs`` and ``inputs`` map an option name
    (for the message) to a path; None values are skipped.
    """
    for option, out in outputs.items():
        if out is None:
            continue
        for name, source in inputs.items():
            if source is None or not Path(source).exists():
                continue
            if is_within(out, source):
                what = "is" if _resolved(out) == _resolved(source) else "lies inside"
                raise UnsafeOutputError(
                    f"{option} {out} {what} the input {name} {source}: aceval never "
                    f"writes into its inputs; choose an output outside it"
                )
            if option in folders and is_within(source, out):
                raise UnsafeOutputError(
                    f"{option} {out} contains the input {name} {source}: replacing it "
                    f"would delete the input; choose another folder"
                )
        if option not in folders and Path(out).is_dir():
            raise UnsafeOutputError(f"{option} {out} is a folder; give a file name")


def contained(root: str | Path, relative: str | PurePath) -> Path:
    """``root / relative`` after checking that ``relative`` is relative and stays inside ``root``
    (no absolute path, no ``..`` that climbs out); raises UnsafeOutputError otherwise.
    """
    relative = PurePath(relative)
    if relative.is_absolute() or relative.drive:
        raise UnsafeOutputError(f"{relative} is an absolute path; paths must be relative to {root}")
    if os.path.normpath(relative).split(os.sep)[0] == os.pardir:
        raise UnsafeOutputError(f"{relative} climbs out of {root} ('..')")
    target = Path(root) / relative
    if not is_within(target.parent, root):  # a folder on the way is a link leading outside
        raise UnsafeOutputError(f"{relative} leads outside {root}")
    return target


def path_problem(relative: str) -> str:
    """Why a path from a sheet may not be used ('' when it may): absolute or climbing out."""
    if not relative:
        return "the path is empty"
    if not relative.startswith(("/", "\\")) and ".." not in relative and ":" not in relative:
        return ""  # a plain relative path (the common case, checked without building a path)
    path = PurePath(relative)
    if path.is_absolute() or path.drive or relative.startswith(("/", "\\")):
        return f"path {relative!r} is absolute: it must be relative to the dataset folder"
    if os.path.normpath(relative).split(os.sep)[0] == os.pardir:
        return f"path {relative!r} climbs out of the dataset folder ('..'): recordings must be inside it"
    return ""


def staged_folder(out: str | Path, force: bool, write) -> None:
    """Call ``write(folder)`` on a hidden staging sibling of ``out``, mark it as aceval's and move
    it into place: a failed run leaves nothing behind. A non-empty ``out`` is only replaced with
    ``force`` and only when aceval wrote it (it holds :data:`MARKER`).
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UnsafeOutputError(f"{out} exists and is a file, not a folder")
    if out.is_dir() and any(out.iterdir()):
        if not force:
            raise UnsafeOutputError(
                f"{out} exists and is not empty (use --force to replace a folder aceval wrote)"
            )
        if not (out / MARKER).is_file():
            raise UnsafeOutputError(
                f"{out} was not written by aceval (it has no {MARKER} file): --force only "
                f"replaces folders aceval wrote itself; choose a new folder"
            )
    out.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(out)
    _refuse_if_written(out)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.{os.getpid()}.", dir=out.parent))
    try:
        write(staging)
        (staging / MARKER).write_text("written by aceval; `--force` may replace this folder\n")
        if out.exists():
            shutil.rmtree(out)
        staging.rename(out)
    finally:
        if staging.exists():
            shutil.rmtree(staging)


def atomic_file(path: str | Path, write) -> None:
    """Call ``write(tmp_path)`` then move the file into place: a failed step leaves no output.
    The temporary file keeps the suffix, so writers can pick the format from it.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    tmp = path.with_name(f".tmp.{os.getpid()}.{path.name}")
    try:
        write(tmp)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def check_writable(folders) -> None:
    """UnsafeOutputError naming the first folder (or, where it does not exist yet, its nearest
    existing parent) in which no file can be created: checked before the work, not after it.
    """
    for folder in folders:
        existing = Path(folder).absolute()
        while not existing.exists():
            existing = existing.parent
        if not existing.is_dir():
            raise UnsafeOutputError(f"{existing} is a file: no output can be written under it")
        try:
            handle, probe = tempfile.mkstemp(prefix=".aceval-probe.", dir=existing)
            os.close(handle)
            os.unlink(probe)
        except OSError as exc:
            raise UnsafeOutputError(
                f"cannot write into {existing} ({exc.strerror}): choose another output folder"
            ) from None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _temporaries(path: Path) -> list[tuple[Path, int]]:
    """The hidden temporaries of the output ``path`` (``.tmp.<pid>.<name>`` files and
    ``.<name>.<pid>.*`` staging folders), each with the process id of the run that made it.
    """
    if not path.parent.is_dir():
        return []
    found = []
    for candidate in path.parent.glob(f".*{glob.escape(path.name)}*"):
        name = candidate.name
        if name.startswith(".tmp.") and name.endswith(f".{path.name}"):
            pid = name[len(".tmp.") : -len(path.name) - 1]
        elif name.startswith(f".{path.name}."):
            pid = name[len(path.name) + 2 :].split(".", 1)[0]
        else:
            continue
        if pid.isdigit() and int(pid) != os.getpid():
            found.append((candidate, int(pid)))
    return found


def remove_leftovers(path: str | Path) -> None:
    """Remove the hidden temporaries that a killed run (a process no longer alive) left for the
    output ``path`` (:func:`_temporaries`).
    """
    for candidate, pid in _temporaries(Path(path)):
        if not _alive(pid):
            if candidate.is_dir():
                shutil.rmtree(candidate, ignore_errors=True)
            else:
                candidate.unlink(missing_ok=True)


def _refuse_if_written(path: Path) -> None:
    """UnsafeOutputError when another live aceval has a temporary for ``path`` (it is writing it)."""
    busy = sorted({str(pid) for _, pid in _temporaries(path) if _alive(pid)})
    if busy:
        raise UnsafeOutputError(
            f"another aceval (process {', '.join(busy)}) is writing {path}: wait for it, or "
            "choose another output"
        )


class FileSet:
    """The output files of one command, committed together or not at all: each is written to a
    hidden temporary beside it (:meth:`write`), and all are renamed into place when the ``with``
    block ends without error; an error, or SIGTERM (:func:`exit_cleanly_on_sigterm`), removes
    them. When the set is made, before the work: the folders (and ``folders``) are checked for
    writing, a killed run's leftovers removed, and each output reserved by an empty temporary, so
    that a second aceval writing the same output while this one works is refused
    (UnsafeOutputError naming the output and the other process).
    """

    def __init__(self, paths, folders=()):
        self.paths = [Path(p) for p in paths if p]
        check_writable({p.parent for p in self.paths} | {Path(f) for f in folders})
        for path in self.paths:
            remove_leftovers(path)
            _refuse_if_written(path)
        self.staged: dict[Path, Path] = {}
        self.reserved: list[Path] = []
        for path in self.paths:
            path.parent.mkdir(parents=True, exist_ok=True)
            self.temporary(path).touch()
            self.reserved.append(self.temporary(path))

    def temporary(self, path: str | Path) -> Path:
        """Where ``path`` is staged (its suffix kept, so writers can pick the format from it)."""
        path = Path(path)
        return path.with_name(f".tmp.{os.getpid()}.{path.name}")

    def write(self, path: str | Path, write) -> None:
        """Call ``write(temporary)`` for the output ``path``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.staged[path] = self.temporary(path)
        write(self.staged[path])

    def __enter__(self) -> FileSet:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        try:
            if kind is None:
                for path, tmp in self.staged.items():
                    tmp.replace(path)
        finally:
            for tmp in [*self.staged.values(), *self.reserved]:
                tmp.unlink(missing_ok=True)


def exit_cleanly_on_sigterm() -> None:
    """Turn SIGTERM into SystemExit(143) so that ``finally`` blocks remove partial outputs."""

    def handler(signum, frame):
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, handler)


def fail(command: str, exc: Exception, code: int = 2) -> int:
    """Print ``aceval <command>: <cause>`` on stderr and return the exit code."""
    print(f"aceval {command}: {exc}", file=sys.stderr)
    return code
