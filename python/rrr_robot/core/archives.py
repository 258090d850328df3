"""Zip archives (SSP and FMU files) read as untrusted input: the one reader of the package.

Every zip the package opens goes through :class:`CheckedZip` (an SSP of ``rrr run-ssp``, the FMUs
inside it, an FMU that the co-simulation or the CAN bench loads). Before anything is read or
written, from the archive's end record and central directory:

- **names**: relative POSIX paths of plain parts: no absolute path, no drive letter or ``:``, no
  backslash, no ``..``, ``.`` or empty part, no control character, at most
  :data:`MAX_NAME_CHARS` characters; no two entries with one name (also not differing only in
  case, which one file system would merge), and no file that is also the folder of another;
- **kinds**: regular files and folders only: no symbolic link (nor a device or FIFO), no
  encrypted entry, stored or deflated data only;
- **sizes** (:class:`Limits`): at most ``max_entries`` entries; each at most ``max_entry_bytes``
  and all together at most ``max_total_bytes`` uncompressed; an entry over ``ratio_from`` bytes
  at most ``max_ratio`` times its compressed size (a deflate bomb is refused by its header); the
  compressed sizes add up to no more than the archive's size (no entries sharing data).

The headers can lie, so the same bounds hold while an entry is streamed: it is read in chunks
of :data:`CHUNK` bytes (never whole into memory, except the small entries :meth:`read` is asked
for), it must decompress to exactly its declared size, and its CRC must match.

Extraction goes only into a fresh temporary folder: :func:`extracted` makes one
(``tempfile.mkdtemp``) and removes it when the block ends, also on an error, Ctrl-C or SIGTERM
(which ``rrr`` turns into an exception); :func:`extract_to_temp` hands the folder to an owner
that removes it (the FMU slave) and removes it itself when the extraction fails. Files are
created exclusively (``O_EXCL``, never through a link). Errors are :class:`ArchiveError`, one
line naming the archive, the entry and the bound.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
import tempfile
import zipfile
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO

from ..errors import ArchiveError, one_line

__all__ = [
    "CHUNK",
    "LIMITS",
    "MAX_NAME_CHARS",
    "CheckedZip",
    "Limits",
    "check_entry_name",
    "extract_to_temp",
    "extracted",
    "scratch_folder",
]

KiB, MiB, GiB = 1 << 10, 1 << 20, 1 << 30
#: Bytes read from an entry at a time.
CHUNK = 1 * MiB
#: Characters of one entry name.
MAX_NAME_CHARS = 1024
#: Largest central directory read (bytes); the end record says its size before it is parsed.
MAX_DIRECTORY_BYTES = 64 * MiB
_STORED_OR_DEFLATED = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED)


@dataclass(frozen=True)
class Limits:
    """The bounds of one archive (see the module's docstring)."""

    max_entries: int = 4096
    max_entry_bytes: int = 512 * MiB
    max_total_bytes: int = 1 * GiB
    max_ratio: float = 200.0
    ratio_from: int = 1 * MiB


#: The bounds of every SSP and FMU archive: an archive of ``rrr ssp`` with the longest reference
#: (1,000,000 samples: a reference table of about 0.4 GB in the reference FMU) fits; our FMUs
#: have about 100 entries of at most 1 MB, compressed 2 to 10 times; a deflate bomb compresses
#: about 1000 times.
LIMITS = Limits()


def _fail(where: str, message: str) -> ArchiveError:
    return ArchiveError(f"{where}: {message}")


def check_entry_name(name: str, where: str = "archive") -> str:
    """``name`` if it is a safe entry name (see the module's docstring), else ArchiveError."""
    shown = repr(name) if len(name) <= 80 else repr(name[:77] + "...")
    if not name:
        raise _fail(where, "an entry has an empty name")
    if len(name) > MAX_NAME_CHARS:
        raise _fail(where, f"entry {shown}: a name of more than {MAX_NAME_CHARS} characters")
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        raise _fail(where, f"entry {shown}: a control character in the name")
    if "\\" in name:
        raise _fail(where, f"entry {shown}: a backslash in the name (entry names use /)")
    if name.startswith("/"):
        raise _fail(where, f"entry {shown}: an absolute path")
    if ":" in name:
        raise _fail(where, f"entry {shown}: a drive letter or ':' in the name")
    parts = name[:-1].split("/") if name.endswith("/") else name.split("/")
    for part in parts:
        if part in ("", ".", ".."):
            raise _fail(where, f"entry {shown}: a path part {part!r} (the entry could land "
                        "outside the extraction folder)")
    return name


def _kind(info: zipfile.ZipInfo) -> str:
    """'file', 'folder' or what else the entry's Unix mode says (link, device, ...)."""
    mode = info.external_attr >> 16
    if info.create_system == 3 and mode:  # Unix: the file type is in the upper bits
        if stat.S_ISLNK(mode):
            return "symbolic link"
        if stat.S_ISDIR(mode):
            return "folder"
        if not stat.S_ISREG(mode) and stat.S_IFMT(mode):
            return "special file"
    return "folder" if info.filename.endswith("/") else "file"


def _end_record(fp: IO[bytes]) -> tuple[int, int] | None:
    """(entries, central directory bytes) from the end record, before zipfile parses it."""
    end = getattr(zipfile, "_EndRecData", None)
    if end is None:  # pragma: no cover - every CPython has it
        return None
    rec = end(fp)
    if rec is None:
        return None
    return int(rec[4]), int(rec[5])


class CheckedZip:
    """A zip archive whose names, kinds and sizes passed the checks (a context manager).

    ``what`` names the archive in messages ("SSP archive", "FMU"), ``where`` (default: the
    path) prefixes them."""

    def __init__(self, path: str | os.PathLike[str], what: str = "archive",
                 limits: Limits = LIMITS, where: str | None = None) -> None:
        self.path = Path(path)
        self.what = what
        self.limits = limits
        self.where = where or str(self.path)
        if not self.path.is_file():
            raise _fail(self.where, f"no such {what} file" if not self.path.exists() else
                        f"the {what} is not a file")
        size = self.path.stat().st_size
        try:
            fh = open(self.path, "rb")  # owned by the ZipFile below
        except OSError as exc:
            raise _fail(self.where, f"cannot read the {what}: {exc.strerror or exc}") from exc
        try:
            head = _end_record(fh)
            if head is not None:
                self._check_directory(*head)
            fh.seek(0)
            self._zip = zipfile.ZipFile(fh)
        except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, ValueError, EOFError) as exc:
            fh.close()
            raise _fail(self.where, f"not an {what} (a zip archive): "
                        f"{one_line(exc)}") from exc
        except BaseException:
            fh.close()
            raise
        try:
            self.entries, self.folders = self._check_entries(size)
        except BaseException:
            self.close()
            raise

    # ---- the checks ------------------------------------------------------------------------
    def _check_directory(self, entries: int, directory_bytes: int) -> None:
        if entries > self.limits.max_entries:
            raise _fail(self.where, f"{entries} entries: at most {self.limits.max_entries} in "
                        f"a {self.what}")
        if directory_bytes > MAX_DIRECTORY_BYTES:
            raise _fail(self.where, f"a central directory of {directory_bytes} bytes: at most "
                        f"{MAX_DIRECTORY_BYTES}")

    def _check_entries(self, archive_bytes: int) -> tuple[dict[str, zipfile.ZipInfo], set[str]]:
        lim = self.limits
        infos = self._zip.infolist()
        if len(infos) > lim.max_entries:
            raise _fail(self.where, f"{len(infos)} entries: at most {lim.max_entries} in a "
                        f"{self.what}")
        files: dict[str, zipfile.ZipInfo] = {}
        folders: set[str] = set()
        seen: dict[str, str] = {}
        total = compressed = 0
        for info in infos:
            name = check_entry_name(info.filename, self.where)
            key = name.rstrip("/").casefold()
            if key in seen:
                same = "the same name" if seen[key] == name.rstrip("/") else \
                    f"a name that differs only in case from {seen[key]!r}"
                raise _fail(self.where, f"entry {name!r}: two entries with {same}")
            seen[key] = name.rstrip("/")
            kind = _kind(info)
            if kind not in ("file", "folder"):
                raise _fail(self.where, f"entry {name!r} is a {kind}: only files and folders "
                            f"are allowed in a {self.what}")
            if info.flag_bits & 0x1:
                raise _fail(self.where, f"entry {name!r} is encrypted")
            if info.compress_type not in _STORED_OR_DEFLATED:
                raise _fail(self.where, f"entry {name!r}: compression method "
                            f"{info.compress_type} (stored or deflated only)")
            if kind == "folder":
                if info.file_size:
                    raise _fail(self.where, f"entry {name!r}: a folder with data")
                folders.add(name.rstrip("/"))
                continue
            if info.file_size > lim.max_entry_bytes:
                raise _fail(self.where, f"entry {name!r}: {info.file_size} bytes uncompressed: "
                            f"at most {lim.max_entry_bytes} per entry")
            if info.compress_type == zipfile.ZIP_STORED and info.compress_size != info.file_size:
                raise _fail(self.where, f"entry {name!r}: stored with {info.compress_size} "
                            f"bytes but declared {info.file_size}")
            if info.file_size > lim.ratio_from and \
                    info.file_size > lim.max_ratio * max(1, info.compress_size):
                raise _fail(self.where, f"entry {name!r}: {info.file_size} bytes from "
                            f"{info.compress_size} compressed (ratio "
                            f"{info.file_size / max(1, info.compress_size):.0f}): at most "
                            f"{lim.max_ratio:g} (a zip bomb?)")
            total += info.file_size
            compressed += info.compress_size
            files[name] = info
        if total > lim.max_total_bytes:
            raise _fail(self.where, f"{total} bytes uncompressed in all: at most "
                        f"{lim.max_total_bytes} in a {self.what}")
        if compressed > archive_bytes:
            raise _fail(self.where, f"the entries claim {compressed} compressed bytes in an "
                        f"archive of {archive_bytes} (overlapping entries?)")
        for name in files:  # a file that is also the folder of another entry
            parts = name.split("/")
            for k in range(1, len(parts)):
                parent = "/".join(parts[:k])
                if parent in files:
                    raise _fail(self.where, f"entry {name!r}: {parent!r} is a file and a "
                                "folder")
        return files, folders

    # ---- reading ---------------------------------------------------------------------------
    def names(self) -> list[str]:
        """The files of the archive (not its folders), in archive order."""
        return list(self.entries)

    def has(self, name: str) -> bool:
        return name in self.entries

    def size(self, name: str) -> int:
        """The declared uncompressed size of the file ``name``."""
        return self._info(name).file_size

    def _info(self, name: str) -> zipfile.ZipInfo:
        try:
            return self.entries[name]
        except KeyError:
            raise _fail(self.where, f"the {self.what} has no {name}") from None

    def chunks(self, name: str) -> Iterator[bytes]:
        """The data of the file ``name`` in chunks of at most :data:`CHUNK` bytes, checked
        against its declared size and CRC."""
        info = self._info(name)
        left = info.file_size
        try:
            with self._zip.open(info) as src:
                while True:
                    block = src.read(min(CHUNK, left + 1))
                    if not block:
                        break
                    left -= len(block)
                    if left < 0:
                        raise _fail(self.where, f"entry {name!r} holds more data than its "
                                    f"header's {info.file_size} bytes")
                    yield block
        except (zipfile.BadZipFile, EOFError, zlib.error, OSError, ValueError) as exc:
            raise _fail(self.where, f"entry {name!r} is damaged or does not match its header: "
                        f"{one_line(exc)}") from exc
        if left:
            raise _fail(self.where, f"entry {name!r} holds {info.file_size - left} bytes, its "
                        f"header says {info.file_size}")

    def read(self, name: str, max_bytes: int) -> bytes:
        """The whole file ``name``, which must be at most ``max_bytes`` (for small entries:
        an SSD, a model description)."""
        size = self.size(name)
        if size > max_bytes:
            raise _fail(self.where, f"{name} has {size} bytes: at most {max_bytes}")
        return b"".join(self.chunks(name))

    def copy(self, name: str, dest: str | os.PathLike[str]) -> Path:
        """Stream the file ``name`` into the new file ``dest`` (created exclusively)."""
        dest = Path(dest)
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | \
            getattr(os, "O_BINARY", 0)
        fd = os.open(dest, flags, 0o644)
        try:
            with os.fdopen(fd, "wb") as out:
                for block in self.chunks(name):
                    out.write(block)
        except BaseException:
            with contextlib.suppress(OSError):
                dest.unlink()
            raise
        return dest

    def extract(self, folder: str | os.PathLike[str],
                include: Callable[[str], bool] | None = None) -> Path:
        """Write the files (those ``include`` accepts) under ``folder``, which must be empty
        (a fresh folder: :func:`extracted`)."""
        root = Path(folder)
        if any(root.iterdir()):
            raise ValueError(f"extract: {root} is not empty")
        base = root.resolve()
        for name in self.entries:
            if include is not None and not include(name):
                continue
            target = root.joinpath(*name.split("/"))
            if not target.resolve().is_relative_to(base):  # the names were checked: not reached
                raise _fail(self.where, f"entry {name!r} leaves the extraction folder")
            target.parent.mkdir(parents=True, exist_ok=True)
            self.copy(name, target)
        return root

    # ---- closing ---------------------------------------------------------------------------
    def close(self) -> None:
        z = getattr(self, "_zip", None)
        if z is not None:
            fp = z.fp
            z.close()
            if fp is not None:
                fp.close()

    def __enter__(self) -> CheckedZip:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


@contextlib.contextmanager
def scratch_folder(prefix: str = "rrr-") -> Iterator[Path]:
    """A fresh temporary folder, removed with everything in it when the block ends (also on an
    error, Ctrl-C or SIGTERM)."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def extract_to_temp(path: str | os.PathLike[str], what: str = "archive",
                    limits: Limits = LIMITS, include: Callable[[str], bool] | None = None,
                    prefix: str = "rrr-unzip-") -> Path:
    """Check the archive and extract it (the files ``include`` accepts) into a fresh temporary
    folder that the caller removes; nothing is left when it fails."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    try:
        with CheckedZip(path, what, limits) as z:
            z.extract(folder, include)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return folder


@contextlib.contextmanager
def extracted(path: str | os.PathLike[str], what: str = "archive", limits: Limits = LIMITS,
              include: Callable[[str], bool] | None = None) -> Iterator[Path]:
    """The archive checked and extracted into a fresh temporary folder, removed when the block
    ends (also on an error, Ctrl-C or SIGTERM)."""
    folder = extract_to_temp(path, what, limits, include)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
