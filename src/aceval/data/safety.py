"""Where aceval may write: never inside an input dataset, never over a folder it did not write.

Raw recordings are only ever read. Every command's outputs are checked before anything is written:

* no output may be, or lie inside, an input dataset or source folder, and a folder output may not
  contain one (replacing it would delete the input); the same against every recording of an
  input dataset by its resolved path (:func:`check_recordings`: a data folder linked from
  elsewhere counts where it is), and against the command's other outputs
  (:func:`check_distinct`); a folder output may not be a symbolic link;
* a folder output (``simulate``, ``import``, ``apply``) is written into a hidden staging folder
  beside it and moved into place when complete, with a marker file :data:`MARKER`; ``--force``
  replaces an existing non-empty folder only when it holds that marker, i.e. aceval wrote it;
* a file output is written to a hidden temporary file and renamed into place; the files of one
  command (``calibrate``'s nine) are staged together and renamed into place together when all are
  written (:class:`FileSet`), so a failed or stopped run leaves none of them;
* every output folder is checked for writing before the work (:func:`check_writable`); a run's
  hidden temporaries are named for their output in full and locked by the run while it lives
  (:func:`new_temporary`): the next run writing the same output removes a dead run's leftovers
  and refuses to write beside a live one (:func:`claim`), and touches no other output's;
* a relative path read from a sheet (``recordings.tsv``) must stay inside its dataset, and every
  file written under an output folder must land inside it (:func:`contained`).

SIGTERM (Snakemake's way of stopping a job) is turned into a normal exit so that the clean-up of
staging folders and temporary files runs (:func:`exit_cleanly_on_sigterm`).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import secrets
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


def check_distinct(outputs: dict[str, str | Path], folders: tuple[str, ...] = ()) -> None:
    """UnsafeOutputError when two outputs of one command are the same file (one would be lost),
    or one lies inside another that is a folder output (``folders``: the options naming folders).
    """
    given = [(option, Path(out)) for option, out in outputs.items() if out]
    for k, (first, first_path) in enumerate(given):
        for second, second_path in given[k + 1 :]:
            if _resolved(first_path) == _resolved(second_path):
                raise UnsafeOutputError(
                    f"{first} and {second} both name {first_path}: one output would be lost; "
                    "give each its own file"
                )
            for (folder, folder_path), (inner, inner_path) in (
                ((first, first_path), (second, second_path)),
                ((second, second_path), (first, first_path)),
            ):
                if folder in folders and is_within(inner_path, folder_path):
                    raise UnsafeOutputError(
                        f"{inner} {inner_path} lies inside the folder output {folder} "
                        f"{folder_path}, which is written as a whole; choose another place"
                    )


def recording_files(root: str | Path) -> set[Path]:
    """Every file recordings.tsv of the dataset at ``root`` names, resolved (symbolic links
    followed, so a data folder linked from elsewhere counts where it really is); paths the
    validation refuses (absolute, climbing out) included, to be protected all the same. An
    unreadable sheet gives none (the validation reports it).
    """
    import csv

    sheet = Path(root) / "recordings.tsv"
    if not sheet.is_file():
        return set()
    try:
        with open(sheet, newline="", encoding="utf-8-sig") as handle:
            rows = csv.DictReader(handle, delimiter="\t")
            relative = [
                (row.get("path") or "").strip() for row in rows if (row.get("path") or "").strip()
            ]
    except (OSError, UnicodeDecodeError, csv.Error):
        return set()
    folders: dict[str, Path] = {}  # each folder resolved once: datasets share few folders
    out = set()
    for path in relative:
        head, _, name = path.replace("\\", "/").rpartition("/")
        if head not in folders:
            try:
                folders[head] = (Path(root) / head).resolve()
            except (OSError, RuntimeError):
                continue
        file = folders[head] / name
        try:
            out.add(file.resolve() if file.is_symlink() else file)
        except (OSError, RuntimeError):
            continue
    return out


def check_recordings(outputs: dict, root: str | Path, folders: tuple[str, ...] = ()) -> None:
    """UnsafeOutputError when an output is a recording of the dataset at ``root``
    (:func:`recording_files`), lies in a folder holding one, or (for the options named in
    ``folders``, written or replaced as a whole) contains one: checked on the resolved paths, so
    a symbolic link anywhere on the way changes nothing.
    """
    files = recording_files(root)
    holding = {file.parent for file in files}
    for option, out in outputs.items():
        if not out:
            continue
        target = _resolved(out)
        if target in files:
            raise UnsafeOutputError(
                f"{option} {out} is the recording {target} of {root}: aceval never writes over "
                "its inputs; choose an output outside the dataset"
            )
        inside = next((f for f in (target, *target.parents) if f in holding), None)
        if inside is not None:
            raise UnsafeOutputError(
                f"{option} {out} lies inside {inside}, which holds recordings of the input "
                f"{root}: aceval never writes into its inputs; choose an output outside it"
            )
        if option in folders:
            held = next((f for f in holding if target in f.parents), None)
            if held is not None:
                raise UnsafeOutputError(
                    f"{option} {out} contains {held}, which holds recordings of the input "
                    f"{root}: replacing it would delete them; choose another folder"
                )


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
    ``force`` and only when aceval wrote it (it holds :data:`MARKER`); a symbolic link is refused
    (:func:`check_folder_output`), all before ``write`` runs.
    """
    out = Path(out)
    check_folder_output(out, force)
    out.parent.mkdir(parents=True, exist_ok=True)
    claim(out)
    staging = new_temporary(out, folder=True)
    try:
        with naming(out):
            write(staging)
        _place_folder(staging, out)
    finally:
        release(staging)


def _place_folder(staging: Path, out: Path) -> None:
    """Mark a complete staging folder as aceval's (:data:`MARKER`) and move it to ``out``."""
    (staging / MARKER).write_text("written by aceval; `--force` may replace this folder\n")
    if out.exists():
        shutil.rmtree(out)
    staging.rename(out)


def check_folder_output(out: Path, force: bool) -> None:
    """UnsafeOutputError unless the folder output ``out`` may be written: absent, empty, or (with
    ``force``) a folder aceval wrote; never a file or a symbolic link (replacing a link's target,
    or the link, is not what the user asked for).
    """
    if out.is_symlink():
        raise UnsafeOutputError(
            f"{out} is a symbolic link (to {os.readlink(out)}): aceval writes a folder output "
            "itself, never through a link; give the folder's own path"
        )
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


def atomic_file(path: str | Path, write) -> None:
    """Call ``write(tmp_path)`` then move the file into place: a failed step leaves no output.
    The temporary file keeps the suffix, so writers can pick the format from it.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    claim(path)
    tmp = new_temporary(path)
    try:
        with naming(path):
            write(tmp)
        tmp.replace(path)
    finally:
        release(tmp)


@contextlib.contextmanager
def naming(output: Path):
    """An OSError that names no file (a write failing on a full disk) is said to be about
    ``output``, the output being written.
    """
    try:
        yield
    except OSError as exc:
        if exc.filename is None:
            exc.filename = str(output)
        raise


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


#: the hidden temporaries of an output ``name``: ``.aceval-<pid>-<8 hex digits>.<name>`` beside
#: it (a file keeps its suffix, so writers can pick the format from it)
_TEMPORARY = re.compile(r"\.aceval-(\d+)-[0-9a-f]{8}\.(.+)", re.DOTALL)
#: this run's own temporaries, each with the descriptor that holds its lock (:func:`new_temporary`)
_OURS: dict[Path, int] = {}


def new_temporary(path: Path, folder: bool = False) -> Path:
    """A new hidden temporary file (or ``folder``) for the output ``path``, registered as this
    run's and locked (``flock``) for as long as the run holds it: another run knows a temporary
    of a live run by its lock, not by a process id read from a name.
    """
    while True:
        tmp = path.with_name(f".aceval-{os.getpid()}-{secrets.token_hex(4)}.{path.name}")
        try:
            tmp.mkdir() if folder else tmp.touch(exist_ok=False)
            break
        except FileExistsError:
            continue
    handle = os.open(tmp, os.O_RDONLY)
    fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    _OURS[tmp] = handle
    return tmp


def release(tmp: Path) -> None:
    """Remove one of this run's temporaries (if still there) and drop its lock."""
    if tmp.is_dir() and not tmp.is_symlink():
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        tmp.unlink(missing_ok=True)
    handle = _OURS.pop(tmp, None)
    if handle is not None:
        os.close(handle)


def _temporaries(path: Path) -> list[tuple[Path, str]]:
    """The hidden temporaries of exactly the output ``path`` (:data:`_TEMPORARY`; the name must
    match in full: ``.aceval-1-x.res.2024`` belongs to ``res.2024``, never to ``res``), other runs'
    only, each with the process id its name gives (for messages).
    """
    if not path.parent.is_dir():
        return []
    found = []
    for candidate in path.parent.glob(".aceval-*"):
        match = _TEMPORARY.fullmatch(candidate.name)
        if match and match[2] == path.name and candidate not in _OURS:
            found.append((candidate, match[1]))
    return found


def _held(candidate: Path) -> bool:
    """True when a live run holds the lock of this temporary."""
    try:
        handle = os.open(candidate, os.O_RDONLY)
    except OSError:  # gone meanwhile
        return False
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(handle)
    return False


def claim(path: str | Path) -> None:
    """Before writing the output ``path``: UnsafeOutputError when a live run holds a temporary
    of it (another aceval is writing it); the temporaries that dead runs left are removed.
    """
    path = Path(path)
    busy = []
    for candidate, pid in _temporaries(path):
        if _held(candidate):
            busy.append(pid)
        elif candidate.is_dir() and not candidate.is_symlink():
            shutil.rmtree(candidate, ignore_errors=True)
        else:
            candidate.unlink(missing_ok=True)
    if busy:
        raise UnsafeOutputError(
            f"another aceval (process {', '.join(sorted(busy))}) is writing {path}: wait for "
            "it, or choose another output"
        )


class FileSet:
    """The outputs of one command, committed together or not at all: each file is written to a
    hidden temporary beside it (:meth:`write`), each folder output into a hidden staging folder
    (:meth:`folder`), and all are moved into place when the ``with`` block ends without error
    (a folder marked with :data:`MARKER`); an error, or SIGTERM
    (:func:`exit_cleanly_on_sigterm`), removes them. When the set is made, before the work: the
    folders (and ``folders``) are checked for writing, a killed run's leftovers removed, and each
    output reserved by an empty temporary, so that a second aceval writing the same output while
    this one works is refused (UnsafeOutputError naming the output and the other process).
    """

    def __init__(self, paths, folders=()):
        self.paths = [Path(p) for p in paths if p]
        check_writable({p.parent for p in self.paths} | {Path(f) for f in folders})
        for path in self.paths:
            claim(path)
        self.staged: dict[Path, Path] = {}
        self.reserved: dict[Path, Path] = {}
        self.staged_folders: set[Path] = set()
        for path in self.paths:
            path.parent.mkdir(parents=True, exist_ok=True)
            self.reserved[path] = new_temporary(path)

    def temporary(self, path: str | Path) -> Path:
        """Where ``path`` is staged (its suffix kept, so writers can pick the format from it)."""
        path = Path(path)
        if path not in self.reserved:
            path.parent.mkdir(parents=True, exist_ok=True)
            claim(path)
            self.reserved[path] = new_temporary(path)
        return self.reserved[path]

    def write(self, path: str | Path, write) -> None:
        """Call ``write(temporary)`` for the output ``path``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.staged[path] = self.temporary(path)
        with naming(path):
            write(self.staged[path])

    def folder(self, path: str | Path, force: bool = False) -> Path:
        """The staging folder of the folder output ``path`` (checked first, as
        :func:`staged_folder` does: absent, empty, or with ``force`` a folder aceval wrote),
        moved into place with the set's other outputs.
        """
        path = Path(path)
        check_folder_output(path, force)
        path.parent.mkdir(parents=True, exist_ok=True)
        claim(path)
        self.reserved[path] = self.staged[path] = new_temporary(path, folder=True)
        self.staged_folders.add(path)
        return self.staged[path]

    def __enter__(self) -> FileSet:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        try:
            if kind is None:
                for path, tmp in self.staged.items():
                    if path in self.staged_folders:
                        _place_folder(tmp, path)
                    else:
                        tmp.replace(path)
        finally:
            for tmp in self.reserved.values():
                release(tmp)


def exit_cleanly_on_sigterm() -> None:
    """Turn SIGTERM into SystemExit(143) so that ``finally`` blocks remove partial outputs."""

    def handler(signum, frame):
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, handler)


def fail(command: str, exc: Exception, code: int = 2) -> int:
    """Print ``aceval <command>: <cause>`` on stderr and return the exit code."""
    print(f"aceval {command}: {exc}", file=sys.stderr)
    return code
