"""Where results go: output paths checked before a run, atomic writes, JSON documents, records.

Every command writes its results through this module, so they share one contract:

* **Checked first.** :class:`Outputs` checks every output path (``--out``, ``--json``,
  ``--plot``) when it is built, before any computation: the nearest existing ancestor must be a
  writable folder, a folder is never given where a file is expected (nor the reverse), and the
  results of an earlier run are never replaced unless ``overwrite=True`` (``--overwrite``).
* **All or nothing.** A run writes into a staging area next to its targets and moves every
  file into place only when it finished (:meth:`Outputs.writing`); an exception or Ctrl-C
  leaves the earlier results as they were and no temporary file behind. With ``overwrite``, the
  files of the earlier run that this run did not write again (a figure of a study not run this
  time) are removed, so a folder never mixes two runs. A kill (SIGKILL) cannot clean up: the
  staging folders and temporary files are named with the process id (and the host), and a run
  that stages its outputs removes those of processes of this host that are no longer alive. A
  kill during the moves themselves (milliseconds) can leave part of a set of several files in
  place; every staged file is complete before the first is moved.
* **One JSON shape.** :func:`document` wraps a payload with the command, its arguments and
  the machine it ran on (:func:`machine`); :func:`json_ready` writes non-finite numbers as
  ``null``.
* **Finished work is kept.** :class:`RecordLog` appends one JSON line per finished trial, so an
  interrupted study resumes where it stopped.
"""

from __future__ import annotations

import contextlib
import fnmatch
import glob
import json
import math
import os
import platform
import re
import shutil
import socket
import sys
import uuid
import zlib
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = [
    "OutputBusyError",
    "OutputExistsError",
    "OutputPathError",
    "Outputs",
    "RecordLog",
    "RecordMismatchError",
    "atomic_path",
    "exclusive",
    "try_lock",
    "check_output_path",
    "cpu_model",
    "document",
    "json_ready",
    "machine",
    "say",
    "write_json",
]

_STAGING_PREFIX = ".windnav-staging-"
_TEMPORARY = ".windnav-tmp"
_OWNER = re.compile(r"(?P<pid>[0-9]+)-(?P<host>[0-9a-f]{8})-[0-9a-f]{8}")
"""The owner part of a staging or temporary name: ``<pid>-<host>-<random>``."""
_STAGING = re.compile(re.escape(_STAGING_PREFIX) + _OWNER.pattern)
_TEMPORARY_NAME = re.compile(r"\.(?P<stem>.*)\." + _OWNER.pattern + re.escape(_TEMPORARY)
                             + r"(?P<suffix>.*)")


class OutputPathError(ValueError):
    """An output path that cannot be written (its parent is a file, a folder is not writable,
    a folder where a file is expected)."""


class OutputExistsError(OutputPathError):
    """An output path that holds the results of an earlier run, without ``overwrite``."""


class RecordMismatchError(ValueError):
    """A record log that holds the records of another study."""


class OutputBusyError(RuntimeError):
    """An output that another running process is writing (:func:`exclusive`)."""


def try_lock(lock_path):
    """``(file, None)`` holding an exclusive ``flock`` on ``lock_path`` (created, with its
    folder), into which this process has written who it is (process id, host, start time,
    command line); or ``(None, holder)`` with what the process that holds it wrote, when one
    does. Closing the file releases the lock; so does the end of the process, however it
    ends."""
    import fcntl  # POSIX: the runs of one machine
    import socket
    import time

    path = Path(lock_path)
    path.parent.mkdir(parents=True, exist_ok=True)
    f = open(path, "a+")
    try:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        f.seek(0)
        holder = f.read().strip() or "a process that has not named itself yet"
        f.close()
        return None, holder
    f.seek(0)
    f.truncate()
    f.write(f"process {os.getpid()} on {socket.gethostname()}, started "
            f"{time.strftime('%Y-%m-%d %H:%M:%S %Z')}: {' '.join(sys.argv)}\n")
    f.flush()
    return f, None


@contextlib.contextmanager
def exclusive(lock_path, what: str):
    """Hold :func:`try_lock`'s lock on ``lock_path`` while the block runs, so that a second
    run into the same output refuses at once, naming the first.

    Raises
    ------
    OutputBusyError
        When another process holds it (two ``train-decoder`` runs into one ``--out`` resumed
        each other's live checkpoint and one crashed on the other's temporary file;
        concurrency audit).
    """
    f, holder = try_lock(lock_path)
    if f is None:
        raise OutputBusyError(f"Another run is writing {what} ({holder}). Wait for it to "
                              "end, or write elsewhere.")
    try:
        yield
    finally:
        f.close()  # releases the flock


@contextlib.contextmanager
def exclusive_folder(folder, what: str, *, on_wait=None):
    """Hold an exclusive ``flock`` on the existing ``folder`` itself (its directory descriptor,
    so no lock file is left in it) while the block runs.

    Parameters
    ----------
    folder : path-like
    what : str
        What the folder holds, for messages.
    on_wait : callable, optional
        When given and another process holds the lock, it is called with a message and this
        one waits for the lock; without it, a second process refuses at once.

    Raises
    ------
    OutputBusyError
        When another process holds it and ``on_wait`` is None.
    """
    import fcntl  # POSIX: the runs of one machine

    fd = os.open(os.fspath(folder), os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait is None:
                raise OutputBusyError(f"Another run is writing {what}. Wait for it to end and "
                                      "run this command again (what it finished is kept and "
                                      "skipped), or write elsewhere.") from None
            on_wait(f"another run is writing {what}: waiting for it to end, then going on "
                    "with what it left")
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError:  # a file system without flock: unlocked, as before
            pass
        yield
    finally:
        os.close(fd)  # releases the lock


# ------------------------------------------------------------------------------- JSON


def say(progress: bool, message: str) -> None:
    """One progress line on stderr when ``progress`` (the studies' per-step messages)."""
    if progress:
        print(message, file=sys.stderr, flush=True)


def json_ready(obj, *, keep_nonfinite: bool = False):
    """A JSON-safe copy of ``obj``: non-finite floats -> None (kept with ``keep_nonfinite``,
    for files only Python reads back), tuples and arrays -> lists, paths -> str, numpy scalars
    -> Python numbers, keys -> str."""
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if keep_nonfinite or math.isfinite(v) else None
    if isinstance(obj, Mapping):
        return {str(k): json_ready(v, keep_nonfinite=keep_nonfinite) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return json_ready(obj.tolist(), keep_nonfinite=keep_nonfinite)
    if isinstance(obj, (list, tuple)):
        return [json_ready(v, keep_nonfinite=keep_nonfinite) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return obj


def cpu_model() -> str:
    """The CPU's model name, e.g. ``"AMD EPYC 9B14"``: from ``/proc/cpuinfo`` on Linux, else
    the platform's processor string, else ``"unknown CPU"``."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine() -> dict:
    """The machine a run computes on, as a JSON document records it: ``platform`` (e.g.
    ``"x86_64"``), ``cpu`` (:func:`cpu_model`), ``cores`` (logical CPUs) and ``python``.

    Timings and last-bit results depend on it (a flight replays to the bit only under the
    arithmetic that flew it: :mod:`windnav.experiments.arithmetic`), so every document names it.
    """
    return {"platform": platform.machine(), "cpu": cpu_model(), "cores": os.cpu_count(),
            "python": platform.python_version()}


NOT_ARGUMENTS = ("func", "command", "argv", "filled_defaults")
"""Attributes of a parsed command line that are the parser's bookkeeping, not options: left out
of a document's ``arguments`` (``argv`` is kept apart, as typed; ``filled_defaults``: the names
of the options a command filled in after parsing,
:func:`windnav.commands._common.fill_defaults`'s, which :func:`document` records as None, as
typed)."""


def document(command: str, payload: Mapping, arguments=None) -> dict:
    """The JSON document of one run: ``command``, ``windnav_version``, ``machine``
    (:func:`machine`), ``arguments`` (the parsed command line, when given), ``argv`` (the words
    after ``windnav`` as typed, when the arguments carry them: since 2026-12-06) and the
    ``payload`` keys. The options named by the arguments' ``filled_defaults`` (filled in by the
    command after parsing) are recorded as None: ``arguments`` is the line as typed, which
    :mod:`windnav.provenance` parses back to it."""
    from windnav import __version__

    doc = {"command": f"windnav {command}", "windnav_version": __version__,
           "machine": machine()}
    if arguments is not None:
        args = vars(arguments) if not isinstance(arguments, Mapping) else dict(arguments)
        filled = args.get("filled_defaults") or ()
        doc["arguments"] = {k: None if k in filled else v for k, v in args.items()
                            if k not in NOT_ARGUMENTS}
        if isinstance(args.get("argv"), list | tuple):  # the words typed: the exact line
            doc["argv"] = [str(w) for w in args["argv"]]  # (windnav.provenance.command_line)
    doc.update(payload)
    return json_ready(doc)


def write_json(result: Mapping, path, *, indent: int | None = 1) -> Path:
    """Write ``result`` (made :func:`json_ready`) to ``path`` atomically; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(json_ready(result), indent=indent, allow_nan=False) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


# ------------------------------------------------------------------------------- atomic writes


def _host_tag() -> str:
    """This host, as 8 hex digits (a process id names a process on one host only)."""
    return f"{zlib.crc32(socket.gethostname().encode()):08x}"


def _owner() -> str:
    """The owner part of a new staging or temporary name: this process, this host, and a
    random part (:data:`_OWNER`)."""
    return f"{os.getpid()}-{_host_tag()}-{uuid.uuid4().hex[:8]}"


def _temporary_name(path: Path) -> Path:
    """A hidden sibling of ``path`` with the same suffix (writers pick the format from it),
    named with its owner: ``.NAME.<pid>-<host>-<random>.windnav-tmp.SUFFIX``."""
    return path.with_name(f".{path.stem}.{_owner()}{_TEMPORARY}{path.suffix}")


def _dead_owner(match: re.Match | None) -> bool:
    """Whether a staging or temporary name (``match`` of :data:`_OWNER`'s groups) belongs to a
    process of this host that is no longer alive. Anything else is kept: a name of another
    form (an older windnav's), of another host (a shared folder), of a live process, or where
    liveness cannot be told (not POSIX, no permission to ask)."""
    if match is None or os.name != "posix" or match["host"] != _host_tag():
        return False
    pid = int(match["pid"])
    if pid <= 0 or pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # PermissionError: alive, someone else's
        return False
    return False


def _remove_dead_leftovers(folder: Path, originals) -> list[Path]:
    """Remove from ``folder`` the staging folders and the temporary files of the names
    ``originals`` (glob patterns) that processes killed while writing left behind
    (:func:`_dead_owner`); returns what was removed."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    removed = []
    for entry in entries:
        name = entry.name
        if name.startswith(_STAGING_PREFIX):
            dead = _dead_owner(_STAGING.fullmatch(name))
        else:
            m = _TEMPORARY_NAME.fullmatch(name)
            dead = m is not None and any(fnmatch.fnmatchcase(m["stem"] + m["suffix"], pattern)
                                         for pattern in originals) and _dead_owner(m)
        if dead:
            path = folder / name
            _remove(path)
            if not (path.exists() or path.is_symlink()):
                removed.append(path)
    return removed


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


@contextlib.contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary sibling of ``path`` to write; on success it replaces ``path``.

    On an exception (or Ctrl-C) the temporary file or folder is removed and ``path`` is left
    as it was. Works for folders too (a Zarr store): the earlier one is replaced whole.
    """
    path = Path(path)
    tmp = _temporary_name(path)
    try:
        yield tmp
        _replace(tmp, path)
    finally:
        if tmp.exists() or tmp.is_symlink():
            _remove(tmp)


def _replace(src: Path, dst: Path) -> None:
    """Move ``src`` onto ``dst``; a folder ``dst`` is swapped out, then deleted."""
    if dst.is_dir() and not dst.is_symlink():
        old = _temporary_name(dst)
        os.replace(dst, old)
        try:
            os.replace(src, dst)
        except BaseException:
            os.replace(old, dst)
            raise
        _remove(old)
    else:
        os.replace(src, dst)


# ------------------------------------------------------------------------------- output paths


def _nearest_existing(path: Path) -> Path:
    p = path
    while not (p.exists() or p.is_symlink()):
        if p.parent == p:
            break
        p = p.parent
    return p


_DESCRIPTORS = ("/dev/stdin", "/dev/stdout", "/dev/stderr")


def check_output_path(path, flag: str, where: str, *, kind: str = "file") -> Path:
    """Check that ``path`` can be written as a ``kind`` (``"file"`` or ``"dir"``).

    A file path that is a symbolic link is returned resolved: the result replaces the link's
    target, and the link stays (it was replaced by a plain file).

    Raises
    ------
    OutputPathError
        When the path is empty or ``-``, an ancestor is a file, the nearest existing folder is
        not writable, the path is a folder where a file is expected (or the reverse), or a file
        path names something other than a regular file (a device, a pipe, a socket, a process's
        descriptor such as ``/dev/stdout``: results are written to a temporary file and moved
        into place, which would replace it).
    """
    if path is None or str(path) == "" or (kind == "file" and str(path) == "-"):
        hint = " (not standard output: name a file)" if str(path) == "-" else ""
        raise OutputPathError(f"The {flag!r} parameter of {where} must be a path{hint}. "
                              f"Got {path!r} instead.")
    p = Path(path)
    rule = "a file path" if kind == "file" else "a folder path"
    if kind == "file":
        real = os.path.realpath(p)
        # a device, pipe or socket (through links too: /dev/stdout to a pipe), or a process's
        # descriptor (/dev/stdout redirected to a file, whose contents --overwrite replaced);
        # /dev/shm holds regular files
        given = str(p.absolute())
        if (p.exists() and not (p.is_file() or p.is_dir())) or given in _DESCRIPTORS or any(
                s.startswith(("/dev/fd/", "/proc/")) for s in (given, real)):
            raise OutputPathError(
                f"The {flag!r} parameter of {where} must be {rule} to a regular file. Got "
                f"{str(path)!r} instead, a device, pipe, socket or descriptor (results are "
                "written to a temporary file and moved into place, which would replace it).")
        if p.is_symlink():
            p = Path(real)
    if p.exists():
        if kind == "file" and p.is_dir():
            raise OutputPathError(f"The {flag!r} parameter of {where} must be {rule}, not a "
                                  f"folder. Got {str(path)!r} instead, which is a folder.")
        if kind == "dir" and not p.is_dir():
            raise OutputPathError(f"The {flag!r} parameter of {where} must be {rule}. "
                                  f"Got {str(path)!r} instead, which is a file.")
    anchor = _nearest_existing(p if kind == "dir" and p.exists() else p.parent)
    if not anchor.is_dir():
        raise OutputPathError(f"The {flag!r} parameter of {where} must be {rule} that can be "
                              f"created. Got {str(path)!r} instead: {str(anchor)!r} is a file, "
                              "not a folder.")
    if not os.access(anchor, os.W_OK | os.X_OK):
        raise OutputPathError(f"The {flag!r} parameter of {where} must be {rule} in a writable "
                              f"folder. Got {str(path)!r} instead: {str(anchor)!r} is not "
                              "writable.")
    return p


def _matches(folder: Path, patterns: Sequence[str]) -> list[Path]:
    if not folder.is_dir():
        return []
    found = {m for pattern in patterns for m in folder.glob(pattern)}
    return sorted(m for m in found if not m.name.startswith(_STAGING_PREFIX))


class Outputs:
    """The output paths of one run, checked at construction, written all at once.

    Parameters
    ----------
    where : str
        The command, for messages (``"windnav fly"``).
    out : (flag, path, products), optional
        An output folder: its flag (``"--out"``), its path, and the names (glob patterns) of
        everything a run of the command writes there. Those that exist are the results of an
        earlier run.
    files : mapping flag -> path, optional
        Single output files (``{"--json": ..., "--plot": ...}``); None values are skipped.
    overwrite : bool
        Replace the results of an earlier run; otherwise an existing one is refused.

    Raises
    ------
    OutputPathError
        A path that cannot be written (see :func:`check_output_path`), or two outputs that name
        the same file.
    OutputExistsError
        An earlier run's results, without ``overwrite``.

    Examples
    --------
    >>> outputs = Outputs("windnav fly", out=("--out", "run", ("log.npz",)))  # doctest: +SKIP
    >>> with outputs.writing() as stage:                                      # doctest: +SKIP
    ...     log.save(stage.dir / "log.npz")
    >>> outputs.written                                                       # doctest: +SKIP
    [PosixPath('run/log.npz')]
    """

    def __init__(self, where: str, *, out=None, files: Mapping | None = None,
                 overwrite: bool = False):
        self.where = where
        self.overwrite = bool(overwrite)
        self.dir: Path | None = None
        self.products: tuple[str, ...] = ()
        self.files: dict[str, Path] = {}
        self.written: list[Path] = []
        self.removed: list[Path] = []
        self.cleaned: list[Path] = []  # what killed runs left beside the targets, removed
        if out is not None:
            flag, path, products = out
            self.dir = check_output_path(path, flag, where, kind="dir")
            self.products = tuple(products)
            self._out_flag = flag
        for flag, path in (files or {}).items():
            if path is not None:
                self.files[flag] = check_output_path(path, flag, where, kind="file")
        self._check_distinct()
        self._check_earlier_run()

    def _check_distinct(self) -> None:
        seen: dict[Path, str] = {}
        for flag, path in self.files.items():
            key = Path(os.path.abspath(path))
            if key in seen:
                raise OutputPathError(f"The {flag!r} parameter of {self.where} must differ from "
                                      f"{seen[key]}. Got {str(path)!r} for both.")
            seen[key] = flag
            if self.dir is not None and key.parent == Path(os.path.abspath(self.dir)) and any(
                    key.match(p) for p in self.products):
                raise OutputPathError(
                    f"The {flag!r} parameter of {self.where} must not name a file that "
                    f"{self._out_flag} holds. Got {str(path)!r} instead.")

    def _check_earlier_run(self) -> None:
        if self.overwrite:
            return
        hint = "pass --overwrite to replace them, or choose another path"
        if self.dir is not None:
            earlier = _matches(self.dir, self.products)
            if earlier:
                names = ", ".join(p.name for p in earlier[:6]) + (", ..." if len(earlier) > 6
                                                                   else "")
                raise OutputExistsError(
                    f"The {self._out_flag!r} parameter of {self.where} names "
                    f"{str(self.dir)!r}, which holds the results of an earlier run ({names}); "
                    f"{hint}.")
        for flag, path in self.files.items():
            if path.exists():
                raise OutputExistsError(f"The {flag!r} parameter of {self.where} names "
                                        f"{str(path)!r}, which already exists; {hint}.")

    @contextlib.contextmanager
    def writing(self) -> Iterator[_Stage]:
        """Stage the results; move them into place when the block ends without an exception.

        Yields a stage whose ``dir`` is the folder to write the ``out`` products into and
        whose :meth:`_Stage.file` gives where to write each single file. On success
        :attr:`written` lists the final paths and :attr:`removed` the files of an earlier run
        that this run did not write again; :attr:`cleaned` lists the staging folders and
        temporary files that killed runs left beside the targets, removed when staging.
        """
        stage = _Stage(self)
        try:
            yield stage
            self._commit(stage)
        finally:
            stage.discard()

    def _commit(self, stage: _Stage) -> None:
        folders = ([self.dir] if self.dir is not None else []) + [
            path.parent for path in self.files.values()]
        with _folder_locks(folders):  # the check and the moves as one step
            self._commit_locked(stage)

    def _commit_locked(self, stage: _Stage) -> None:
        if not self.overwrite:
            self._keep_apart_from_a_run_meanwhile(stage)
        written = []
        if stage.dir is not None:
            new = sorted(stage.dir.iterdir())
            names = {p.name for p in new}
            for src in new:
                dst = self.dir / src.name
                _replace(src, dst)
                written.append(dst)
            # the earlier run's outputs that this run did not write again
            for stale in _matches(self.dir, self.products):
                if stale.name not in names:
                    _remove(stale)
                    self.removed.append(stale)
        for flag, tmp in stage.staged_files.items():
            if tmp.exists():
                _replace(tmp, self.files[flag])
                written.append(self.files[flag])
        self.written = written


    def _keep_apart_from_a_run_meanwhile(self, stage: _Stage) -> None:
        """Without ``overwrite``: when another run wrote results to these paths while this one
        ran (the check at the start saw none), keep this run's beside them, under new names,
        and raise :class:`OutputExistsError` saying where; nothing of either run is replaced."""
        clash = []
        if stage.dir is not None:
            clash += _matches(self.dir, self.products)
        clash += [self.files[flag] for flag, tmp in stage.staged_files.items()
                  if tmp.exists() and os.path.lexists(self.files[flag])]
        if not clash:
            return
        tag = f"pid{os.getpid()}-{uuid.uuid4().hex[:6]}"
        kept = []
        if stage.dir is not None:
            folder = self.dir / f"results-{tag}"
            os.replace(stage.dir, folder)
            kept.append(folder)
        for flag, tmp in stage.staged_files.items():
            if tmp.exists():
                path = self.files[flag]
                dst = path.with_name(f"{path.stem}.{tag}{path.suffix}")
                os.replace(tmp, dst)
                kept.append(dst)
        names = ", ".join(str(p) for p in clash[:4]) + (", ..." if len(clash) > 4 else "")
        raise OutputExistsError(
            f"{self.where}: another run wrote {names} while this one ran; this run's results "
            f"are kept beside them in {', '.join(map(str, kept))} (nothing was replaced; pass "
            "--overwrite for a run that replaces earlier results).")

@contextlib.contextmanager
def _folder_locks(folders):
    """Hold :func:`exclusive_folder`'s lock on each of ``folders``, waiting for another run's,
    in one order: two runs that finished together both passed the check for the other's
    results and both moved theirs into place, or ``--out`` came from one run and ``--json``
    from the other (concurrency audit)."""
    with contextlib.ExitStack() as stack:
        for folder in sorted({os.path.abspath(f) for f in folders}):
            stack.enter_context(exclusive_folder(folder, folder, on_wait=lambda message: None))
        yield


class _Stage:
    """Where a run writes before :meth:`Outputs.writing` moves its files into place.

    Staging first removes what killed runs left beside the targets: their staging folders in
    the output folder and their temporary files of these targets (:func:`_dead_owner`).
    """

    def __init__(self, outputs: Outputs):
        self._outputs = outputs
        self.dir: Path | None = None
        self.staged_files: dict[str, Path] = {}
        if outputs.dir is not None:
            outputs.dir.mkdir(parents=True, exist_ok=True)
            outputs.cleaned += _remove_dead_leftovers(outputs.dir, outputs.products)
            self.dir = outputs.dir / f"{_STAGING_PREFIX}{_owner()}"
            self.dir.mkdir()
        for flag, path in outputs.files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            outputs.cleaned += _remove_dead_leftovers(path.parent,
                                                      [glob.escape(path.name)])
            self.staged_files[flag] = _temporary_name(path)

    def file(self, flag: str) -> Path | None:
        """Where to write the single file of ``flag`` (None when it was not asked for)."""
        return self.staged_files.get(flag)

    def discard(self) -> None:
        if self.dir is not None and self.dir.exists():
            shutil.rmtree(self.dir, ignore_errors=True)
        for tmp in self.staged_files.values():
            if tmp.exists() or tmp.is_symlink():
                _remove(tmp)


# ------------------------------------------------------------------------------- record logs


def _canonical(obj) -> str:
    """``obj`` as JSON with sorted keys (NaN written as ``NaN``, so equal to itself)."""
    return json.dumps(obj, sort_keys=True)


class RecordLog:
    """Finished records of a study, one JSON line each, kept across interruptions.

    The first line is a header (``{"header": ...}``) naming the study; :meth:`load` refuses a
    file whose header differs, so records of two studies never mix. Each :meth:`append` is
    flushed and synced before it returns: a Ctrl-C or a kill loses at most the record being
    written (a torn last line is ignored on load). Non-finite numbers are kept (as Python's
    ``json`` writes them, ``NaN``, ``Infinity``), so a record reads back as it was written.

    Parameters
    ----------
    path : str or path-like
    header : dict
        JSON-ready description of the study (its configuration).
    """

    def __init__(self, path, header: Mapping):
        self.path = Path(path)
        self.header = json_ready(dict(header), keep_nonfinite=True)

    def load(self) -> list[dict]:
        """The records already in the file ([] when there is none, or when the file is empty
        or holds only a header torn by a kill, which is then dropped); lines that are not
        JSON objects (torn, damaged) are skipped.

        Raises
        ------
        RecordMismatchError
            When the file holds another study's records (or is not a record log).
        """
        if not self.path.exists():
            return []
        raw = self.path.read_bytes()
        start = b'{"header"'
        if b"\n" not in raw and (start.startswith(raw) or raw.startswith(start)):
            # empty, or a header torn by a kill: no record yet (the next append writes it)
            if raw:
                self.path.write_bytes(b"")
            return []
        # bytes that are not UTF-8 (a damaged line) become U+FFFD: that line is skipped below
        lines = raw.decode("utf-8", errors="replace").splitlines()
        try:
            head = json.loads(lines[0])["header"] if lines else None
        except (json.JSONDecodeError, KeyError, TypeError):
            head = None
        # compared as canonical JSON: a NaN in the header (kept, keep_nonfinite) is never
        # equal to itself, so such a log was refused as another study's on every resume
        # (audit, 2026-12-05)
        if head is None or _canonical(head) != _canonical(self.header):
            raise RecordMismatchError(
                f"The record log {str(self.path)!r} holds the records of another study (or is "
                "not a record log); move it away, or start over.")
        records = []
        for line in lines[1:]:
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue  # a record torn by a kill mid-write
            if isinstance(rec, dict):  # a list or a number is no record (it crashed callers)
                records.append(rec)
        return records

    def append(self, record: Mapping) -> None:
        """Add one record (made :func:`json_ready`), durably."""
        new = not self.path.exists() or self.path.stat().st_size == 0
        lead = ""
        if new:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        else:
            with open(self.path, "rb") as f:
                f.seek(-1, os.SEEK_END)
                lead = "" if f.read(1) == b"\n" else "\n"  # end a torn line first
        with open(self.path, "a") as f:
            if new:
                f.write(json.dumps({"header": self.header}) + "\n")
            f.write(lead)
            f.write(json.dumps(json_ready(record, keep_nonfinite=True)) + "\n")
            f.flush()
            os.fsync(f.fileno())

    def remove(self) -> None:
        """Delete the file (once the study's results are written)."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
