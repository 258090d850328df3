"""Outputs a user can trust: files written atomically, and the files of a run all or nothing.

Every file the package writes goes through here:

- :func:`atomic_write_text`, :func:`atomic_write_bytes`: a whole file at once;
- :func:`atomic_open`: a file written incrementally (``csv.writer``, ...);
- :func:`atomic_path`: a temporary path for writers that want a path (matplotlib, numpy, the C
  nodes of the CAN bench), put in place when the block ends without an exception;
- :class:`ResultSet`: the files of one run (summary.json, CSVs, figures) written to a staging
  folder inside the output folder and moved into place only when the whole run succeeded, so an
  interrupted run leaves the previous results as they were and summary.json never describes the
  files of another run;
- :func:`strict_json`: JSON without ``NaN``/``Infinity`` (non-finite numbers become ``null``).

How: a file is written under a temporary name in the folder of its target (a rename never
crosses a file system), flushed and fsync'd, then renamed over the target (``os.replace``, atomic
on POSIX), and the folder is fsync'd. A reader sees the old file or the new one, never a part.

The temporary names are hidden and never end like a result (so ``*.csv`` finds no half file)::

    .rrr-tmp-<pid>-<token>-<name>.part    a file being written
    .rrr-staging-<pid>-<token>/           the staging folder of a run
    .rrr-results-<kind>.json              the files of the last run of that kind in the folder

:func:`clean_stale` removes those of processes that no longer run (a killed run); every result
set and every atomic write runs it on its folder, so leftovers go at the next run. A staging
folder whose commit had begun (its ``.commit`` journal exists) is finished instead (rolled
forward), so a run killed while its files were being renamed still ends complete.

A result set removes the files that the previous run of the same kind wrote and this run did not
(a run with fewer scenarios leaves no old ``<scenario>.csv`` behind); files it did not write
(other kinds' results, the user's files) are never touched.

Two runs into one folder: the folder is created race-free (a run that finds it just made by
another goes on), and commits are serialised by :func:`folder_lock` (``.rrr-lock-commit``, held
for the few milliseconds of a commit), so the folder holds one run's files whole: the last to
commit. A command that must own its folder for its whole run (``rrr sweep``) claims it with
:func:`folder_lock` (``wait=False``): a second one is refused at once, naming the first's pid.
The locks are ``flock`` locks (released by the system when their process dies, however it dies)
on hidden files that go when the lock is released.

A write that fails (a full disk, a used-up quota, a read-only file system, no permission) is an
:class:`~rrr_robot.errors.OutputError` that names the file or the output folder (never the hidden
temporary names) and what to do: :func:`output_error`.

Limits: the renames of a result set are one after another (a reader listing the folder during the
few milliseconds of a commit may see some files new and some old; summary.json is removed first
and renamed last, so it is absent rather than wrong during that time).
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import math
import os
import re
import shutil
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Any, TypeGuard

from ..errors import BadInputError, OutputError

log = logging.getLogger(__name__)

__all__ = [
    "LOCK_PREFIX",
    "MANIFEST_PREFIX",
    "STAGING_PREFIX",
    "TEMP_PREFIX",
    "TEMP_SUFFIX",
    "ResultSet",
    "atomic_open",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_folder",
    "check_name",
    "clean_stale",
    "folder_lock",
    "is_temporary",
    "make_folders",
    "output_error",
    "shown_paths",
    "strict_json",
    "to_strict_json_value",
]

TEMP_PREFIX = ".rrr-tmp-"
TEMP_SUFFIX = ".part"
STAGING_PREFIX = ".rrr-staging-"
MANIFEST_PREFIX = ".rrr-results-"
LOCK_PREFIX = ".rrr-lock-"
_JOURNAL = ".commit"
_OURS = re.compile(r"^\.rrr-(tmp|staging)-(\d+)-([0-9a-f]{8})(?:-|$)")
_KIND = re.compile(r"^[a-z0-9][a-z0-9-]{0,31}$")
_MAX_NAME = 100  # characters of the target's name kept in a temporary name

#: Tokens of the temporary files and staging folders this process made (a leftover with this
#: process's id but another token is stale: e.g. every run in a container is pid 1).
_OWN_TOKENS: set[str] = set()


#: What to do when a write fails, by errno (docs/outputs.md).
_WHAT_TO_DO = {
    errno.ENOSPC: "free space on its file system, or write the results elsewhere (--out)",
    errno.EDQUOT: "the disk quota is used up: free space, or write the results elsewhere "
                  "(--out)",
    errno.EFBIG: "the file is too large for its file system: write the results elsewhere "
                 "(--out)",
    errno.EROFS: "its file system is read-only: write the results elsewhere (--out)",
    errno.EACCES: "check the folder's permissions, or write the results elsewhere (--out)",
    errno.EPERM: "check the folder's permissions, or write the results elsewhere (--out)",
    errno.EIO: "the device failed: check it, or write the results elsewhere (--out)",
}
#: The errors of a write that fails whatever is written (a full disk, ...), as opposed to a
#: writer's own OSError (an input it reads inside an atomic write): named as the output's.
_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO})


def _shown(path: Path) -> Path:
    """What a user knows a path as: a result staged in a result set's hidden folder is the
    output folder's file; a temporary name is its target's; a hidden file of ours (a commit's
    journal, a manifest) is its folder."""
    if path.parent.name.startswith(STAGING_PREFIX):
        path = path.parent.parent / path.name
    m = _OURS.match(path.name)
    if m is not None and path.name.endswith(TEMP_SUFFIX):
        path = path.with_name(path.name[m.end():-len(TEMP_SUFFIX)])
    return path.parent if path.name.startswith(".") else path  # a journal: its folder


#: A staged or temporary name in a text (a C node's message quotes the path it was given).
_HIDDEN_PATH = re.compile(r"/\.rrr-staging-\d+-[0-9a-f]{8}(/[^\s:;,]*)")


def shown_paths(text: str) -> str:
    """``text`` with each path into a result set's staging folder (and a temporary name in it)
    as the output folder's file it becomes."""
    return _HIDDEN_PATH.sub(lambda m: "/" + _shown(Path("x" + m.group(1))).name, text)


def output_error(exc: OSError, path: str | os.PathLike[str]) -> OSError:
    """The error of a failed write of ``path`` (a file, or the output folder): "cannot write
    PATH: REASON; WHAT TO DO" (an OutputError with the system's errno); an OutputError as it
    is."""
    if isinstance(exc, OutputError):
        return exc
    shown = _shown(Path(path))
    what = _WHAT_TO_DO.get(exc.errno or 0, "check it, then run again")
    error = OutputError(f"cannot write {shown}: {exc.strerror or exc}; {what}")
    error.errno = exc.errno
    return error


def _a_write_failure(exc: BaseException) -> TypeGuard[OSError]:
    return (isinstance(exc, OSError) and not isinstance(exc, OutputError)
            and exc.errno in _WRITE_ERRNOS)


def _token() -> str:
    token = os.urandom(4).hex()  # secrets.token_hex(4), without importing secrets (5 ms)
    _OWN_TOKENS.add(token)
    return token


def is_temporary(path: str | os.PathLike[str]) -> bool:
    """True for the temporary files, staging folders and manifests of this module."""
    name = Path(path).name
    return name.startswith((TEMP_PREFIX, STAGING_PREFIX, MANIFEST_PREFIX, LOCK_PREFIX))


def check_name(name: str) -> str:
    """A result's file name: one plain, visible name (no folder, not hidden, not ours)."""
    if (not isinstance(name, str) or not name or name in (".", "..") or name.startswith(".")
            or "/" in name or "\\" in name or "\0" in name or len(name) > 200):
        raise BadInputError(f"{name!r} cannot name an output file (one plain file name, "
                            "not hidden, at most 200 characters)")
    return name


def check_folder(folder: str | os.PathLike[str]) -> Path:
    """Check, without creating anything, that ``folder`` is or can become a writable output
    folder: BadInputError otherwise (before a run reads or simulates anything)."""
    folder = Path(folder)
    p = folder
    while not p.exists() and p != p.parent:
        p = p.parent
    if not p.is_dir():
        what = "is not a folder" if p == folder else f"cannot be created: {p} is not a folder"
        raise BadInputError(f"the output folder {folder} {what}")
    if not os.access(p, os.W_OK | os.X_OK):
        raise BadInputError(f"the output folder {folder} cannot be written: {p} is not writable")
    return folder


def make_folders(folder: str | os.PathLike[str]) -> list[Path]:
    """Create ``folder`` and its missing parents, race-free: a folder that another process
    creates at the same moment is taken as it is. Returns the folders this call created (outer
    first); BadInputError when one cannot be created or a path part is not a folder."""
    folder = Path(folder)
    missing: list[Path] = []
    p = folder
    while not p.exists() and p != p.parent:
        missing.append(p)
        p = p.parent
    created: list[Path] = []
    try:
        for d in reversed(missing):
            try:
                d.mkdir()
                created.append(d)
            except FileExistsError:
                if not d.is_dir():
                    raise
        if not folder.is_dir():
            raise NotADirectoryError(f"{folder} is not a folder")
    except OSError as exc:
        for d in reversed(created):
            with contextlib.suppress(OSError):
                d.rmdir()
        what = "it exists and is not a folder" if isinstance(exc, FileExistsError | \
                                                             NotADirectoryError) else \
            (exc.strerror or str(exc))
        raise BadInputError(f"cannot create the output folder {folder}: {what}") from exc
    return created


class _Lock:
    """An exclusive lock on ``folder/.rrr-lock-<purpose>`` (see :func:`folder_lock`)."""

    def __init__(self, folder: Path, purpose: str) -> None:
        self.path = folder / f"{LOCK_PREFIX}{purpose}"
        self.fd = -1

    def try_lock(self) -> bool:
        """Take the lock if it is free; the file is checked to be the one locked (another
        process may remove it between our open and our lock)."""
        import fcntl

        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                return False
            except BaseException:
                os.close(fd)
                raise
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                self.fd = fd
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
                return True
            os.close(fd)  # locked a file that was removed meanwhile: again

    def holder(self) -> str:
        try:
            return self.path.read_text(encoding="ascii").strip() or "?"
        except (OSError, UnicodeError):
            return "?"

    def release(self) -> None:
        if self.fd >= 0:
            with contextlib.suppress(OSError):
                self.path.unlink()  # while it is held: the next one makes a new file
            os.close(self.fd)
            self.fd = -1


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str], purpose: str, *, wait: bool = False,
                timeout: float = 60.0, what: str = "") -> Iterator[None]:
    """Hold ``folder``'s lock ``purpose`` for the block (the folder must exist). ``wait``:
    wait for it up to ``timeout`` s; otherwise BadInputError at once when another process holds
    it (``what`` names what holds it in the message: "another rrr sweep"). Where the system has
    no ``flock`` (Windows) the lock is not taken."""
    folder = Path(folder)
    if not _KIND.match(purpose):
        raise ValueError(f"folder_lock: purpose must match {_KIND.pattern}, got {purpose!r}")
    try:
        import fcntl  # noqa: F401
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    lock = _Lock(folder, purpose)
    deadline = time.monotonic() + timeout
    try:
        while not lock.try_lock():
            if not wait:
                raise BadInputError(f"{folder} is in use by {what or 'another run'} (process "
                                    f"{lock.holder()}): wait for it to end or choose another "
                                    "--out")
            if time.monotonic() > deadline:
                raise BadInputError(f"{folder}: {what or 'another run'} (process "
                                    f"{lock.holder()}) has held {lock.path.name} for "
                                    f"{timeout:g} s")
            time.sleep(0.01)
    except OSError as exc:
        raise BadInputError(f"cannot lock the output folder {folder}: "
                            f"{exc.strerror or exc}") from exc
    try:
        yield
    finally:
        lock.release()


# ---- durability -------------------------------------------------------------------------------


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(folder: Path) -> None:
    """Make the renames in ``folder`` durable (not possible on every platform: best effort)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# ---- stale leftovers --------------------------------------------------------------------------


def _running(pid: int, token: str) -> bool:
    """Whether the process that made a temporary name may still be writing it."""
    if pid <= 0:
        return False
    if pid == os.getpid():
        return token in _OWN_TOKENS
    if os.name != "posix":  # no harmless probe of another process: assume it runs
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: it exists (another user's)
        return True
    return True


def clean_stale(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files and staging folders in ``folder`` left by processes that no
    longer run; finish (roll forward) a staging folder whose commit had begun. Returns what was
    removed or finished. Errors are logged, never raised (a leftover is harmless)."""
    folder = Path(folder)
    done: list[Path] = []
    try:
        entries = [e for e in folder.iterdir() if e.name.startswith((TEMP_PREFIX, STAGING_PREFIX))]
    except OSError:
        return done
    for entry in entries:
        m = _OURS.match(entry.name)
        if m is None or _running(int(m.group(2)), m.group(3)):
            continue
        try:
            if m.group(1) == "staging" and entry.is_dir():
                journal = _read_journal(entry)
                if journal is not None:
                    log.warning("finishing the interrupted commit of %s", entry)
                    _roll_forward(entry, folder, journal)
                else:
                    log.info("removing %s (left by an interrupted run)", entry)
                    shutil.rmtree(entry)
            else:
                log.info("removing %s (left by an interrupted run)", entry)
                entry.unlink()
            done.append(entry)
        except OSError as exc:
            log.warning("cannot remove %s: %s", entry, exc)
    return done


# ---- single files -----------------------------------------------------------------------------


def _reserve(path: Path) -> Path:
    """Create an empty temporary file beside ``path`` (mode 0666 less the umask, like open())."""
    name = path.name[-_MAX_NAME:]
    while True:
        tmp = path.with_name(f"{TEMP_PREFIX}{os.getpid()}-{_token()}-{name}{TEMP_SUFFIX}")
        try:
            fd = os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp


@contextlib.contextmanager
def _replace_at_end(path: Path) -> Iterator[Path]:
    try:
        tmp = _reserve(path)
    except OSError as exc:
        raise output_error(exc, path) from exc
    try:
        yield tmp
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if _a_write_failure(exc):  # the writer's write into tmp
            raise output_error(exc, path) from exc
        raise
    try:
        _fsync_file(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise output_error(exc, path) from exc
    _fsync_dir(path.parent)


def atomic_path(path: str | os.PathLike[str]) -> contextlib.AbstractContextManager[Path]:
    """A temporary path beside ``path`` to write the file to; when the block ends without an
    exception the file is fsync'd and renamed to ``path``, otherwise it is removed and ``path``
    is left as it was. For writers that open the path themselves (they must not infer the
    format from the suffix, which is ``.part``)."""
    path = Path(path)
    clean_stale(path.parent)
    return _replace_at_end(path)


@contextlib.contextmanager
def _open_at_end(path: Path, mode: str, encoding: str, newline: str | None,
                 clean: bool = True) -> Iterator[IO[Any]]:
    with (atomic_path(path) if clean else _replace_at_end(path)) as tmp:
        if mode == "wb":
            with open(tmp, "wb") as fh:
                yield fh
        else:
            with open(tmp, "w", encoding=encoding, newline=newline) as fh:
                yield fh


def atomic_open(path: str | os.PathLike[str], mode: str = "w", *, encoding: str = "utf-8",
                newline: str | None = None) -> contextlib.AbstractContextManager[IO[Any]]:
    """Open a file for writing ("w": text, "wb": bytes) that appears at ``path`` complete, when
    the block ends without an exception, or not at all."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open: mode must be 'w' or 'wb', got {mode!r}")
    return _open_at_end(Path(path), mode, encoding, newline)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike[str], text: str, *, encoding: str = "utf-8",
                      newline: str | None = None) -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_open(path, "w", encoding=encoding, newline=newline) as fh:
        fh.write(text)
    return Path(path)


# ---- strict JSON ------------------------------------------------------------------------------


def to_strict_json_value(value: Any) -> Any:
    """``value`` with non-finite floats replaced by None, numpy scalars and arrays by Python
    numbers and lists, tuples by lists (JSON has no NaN or Infinity)."""
    if isinstance(value, Mapping):
        return {str(k): to_strict_json_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_strict_json_value(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):  # numpy
        return to_strict_json_value(value.tolist())
    if isinstance(value, bool) or value is None or isinstance(value, str | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def strict_json(value: Any, indent: int | None = 2) -> str:
    """JSON text of ``value`` that every parser accepts: non-finite numbers are ``null``."""
    return json.dumps(to_strict_json_value(value), indent=indent, allow_nan=False)


# ---- result sets ------------------------------------------------------------------------------


def _read_journal(staging: Path) -> dict[str, Any] | None:
    try:
        data = json.loads((staging / _JOURNAL).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or not _KIND.match(str(data.get("kind", ""))):
        return None
    return data


def _plain_names(values: Any) -> list[str]:
    names = []
    for v in values if isinstance(values, list) else []:
        try:
            names.append(check_name(v))
        except BadInputError:
            continue
    return names


def _manifest(folder: Path, kind: str) -> Path:
    return folder / f"{MANIFEST_PREFIX}{kind}.json"


def _roll_forward(staging: Path, folder: Path, journal: Mapping[str, Any]) -> None:
    """Move the staged files into ``folder`` as the journal says; idempotent, so it may be
    repeated after an interruption at any point."""
    files = _plain_names(journal.get("files"))
    last = set(_plain_names(journal.get("last")))
    for name in files:  # summary.json absent rather than describing the wrong files
        if name in last and (staging / name).exists():
            with contextlib.suppress(FileNotFoundError):
                (folder / name).unlink()
    for name in _plain_names(journal.get("remove")):
        if name not in files:
            with contextlib.suppress(FileNotFoundError):
                (folder / name).unlink()
    for name in files:
        if (staging / name).exists():
            os.replace(staging / name, folder / name)
    _fsync_dir(folder)
    manifest = {"kind": journal["kind"], "files": files}
    with _open_at_end(_manifest(folder, str(journal["kind"])), "w", "utf-8", None,
                      clean=False) as fh:  # clean_stale may be what is running this
        fh.write(strict_json(manifest) + "\n")
    shutil.rmtree(staging)
    _fsync_dir(folder)


class ResultSet:
    """The files of one run, put into ``folder`` all together when the run succeeded.

    ::

        with ResultSet(out, kind="writing") as rs:   # creates out (and its parents) if needed
            res.to_csv(rs.path("ctc.csv"))            # files go to a staging folder in out
            rs.write_text("summary.json", text)
        # the block ended without an exception: the files are now in out (summary.json last)

    An exception (or Ctrl-C) in the block removes the staging folder and the folders the result
    set created, and leaves ``folder`` as it was. ``kind`` names the run's kind: the files the
    previous run of that kind put into ``folder`` and this one did not write are removed at the
    commit. ``last`` are put into place after the others (summary.json)."""

    def __init__(self, folder: str | os.PathLike[str], kind: str,
                 last: Sequence[str] = ("summary.json",)) -> None:
        if not _KIND.match(kind):
            raise ValueError(f"ResultSet kind must match {_KIND.pattern}, got {kind!r}")
        self.folder = Path(folder)
        self.kind = kind
        self.last = tuple(check_name(n) for n in last)
        self._staging: Path | None = None
        self._created: list[Path] = []
        self.committed: list[Path] = []

    # ---- opening ---------------------------------------------------------------------------
    def _make_folder(self) -> None:
        self._created = make_folders(self.folder)

    def open(self) -> ResultSet:
        """Create the output folder if needed, clean stale leftovers, make the staging folder."""
        if self._staging is not None:
            raise RuntimeError("ResultSet.open() called twice")
        self._make_folder()
        clean_stale(self.folder)
        try:
            while True:
                staging = self.folder / f"{STAGING_PREFIX}{os.getpid()}-{_token()}"
                try:
                    staging.mkdir()
                    break
                except FileExistsError:
                    continue
        except OSError as exc:
            self._remove_created()
            raise output_error(exc, self.folder) from exc
        self._staging = staging
        return self

    def __enter__(self) -> ResultSet:
        return self.open()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            self.commit()
            return
        staging = self._staging
        self.discard()
        if exc is not None and _a_write_failure(exc):  # a result written into the staging
            name, where = exc.filename, self.folder
            if staging is not None and isinstance(name, str) and Path(name).parent == staging:
                where = self.folder / Path(name).name
            raise output_error(exc, where) from exc

    # ---- writing ---------------------------------------------------------------------------
    @property
    def staging(self) -> Path:
        """The staging folder (files written here are the run's results once committed)."""
        if self._staging is None:
            raise RuntimeError("the ResultSet is not open (use it in a with block)")
        return self._staging

    def path(self, name: str) -> Path:
        """Where to write the result ``name`` (a plain file name) during the run."""
        return self.staging / check_name(name)

    def write_text(self, name: str, text: str, *, encoding: str = "utf-8") -> Path:
        path = self.path(name)
        with open(path, "w", encoding=encoding) as fh:
            fh.write(text)
        return path

    def write_bytes(self, name: str, data: bytes) -> Path:
        path = self.path(name)
        path.write_bytes(data)
        return path

    def names(self) -> list[str]:
        """The results staged so far (not the temporary files of writers still at work)."""
        return sorted(p.name for p in self.staging.iterdir()
                      if p.is_file() and not p.name.startswith("."))

    # ---- ending ----------------------------------------------------------------------------
    def commit(self) -> list[Path]:
        """Put the staged files into the output folder (the others first, then ``last``),
        remove the previous run's files that this run did not write, record this run's files
        in the manifest. Returns the paths of the results. A run that wrote nothing changes
        nothing."""
        staging = self.staging
        files = self.names()
        if not files:
            shutil.rmtree(staging, ignore_errors=True)
            self._staging = None
            return []
        try:
            for name in files:
                _fsync_file(staging / name)
            with folder_lock(self.folder, "commit", wait=True, what="another run's commit"):
                self._commit_locked(staging, files)
        except OSError as exc:
            raise output_error(exc, self.folder) from exc
        return self.committed

    def _commit_locked(self, staging: Path, files: list[str]) -> None:
        try:
            old = json.loads(_manifest(self.folder, self.kind).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = {}
        previous = _plain_names(old.get("files") if isinstance(old, dict) else None)
        order = [n for n in files if n not in self.last] + [n for n in self.last if n in files]
        journal = {"kind": self.kind, "files": order, "last": list(self.last),
                   "remove": [n for n in previous if n not in files]}
        for name in order:
            if (self.folder / name).is_dir():  # before anything is moved
                raise BadInputError(f"cannot write {self.folder / name}: a folder of that "
                                    "name is in the way; move it away")
        # from here on the commit is finished, by clean_stale if this process dies
        with _open_at_end(staging / _JOURNAL, "w", "utf-8", None, clean=False) as fh:
            fh.write(strict_json(journal) + "\n")
        _fsync_dir(staging)
        _roll_forward(staging, self.folder, journal)
        self._staging = None
        self.committed = [self.folder / n for n in order]
        log.debug("results in %s: %s", self.folder, ", ".join(order))

    def discard(self) -> None:
        """Drop the staged files and the folders this result set created (if empty). A commit
        that had begun is finished instead (its journal exists), so the folder is complete."""
        staging, self._staging = self._staging, None
        if staging is None:
            return
        journal = _read_journal(staging)
        try:
            if journal is not None:
                _roll_forward(staging, self.folder, journal)
                return
            shutil.rmtree(staging)
        except OSError as exc:  # left for clean_stale at the next run
            log.warning("cannot clean up %s: %s", staging, exc)
        self._remove_created()

    def _remove_created(self) -> None:
        for d in reversed(self._created):
            try:
                d.rmdir()
            except OSError:
                break
        self._created = []
