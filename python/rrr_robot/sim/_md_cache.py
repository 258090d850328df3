"""What a co-simulation slave needs of an FMU's model description, kept in the cache folder
(:mod:`rrr_robot.core.cache`): FMPy's reading of a model description (lxml's import, the parse
and FMPy's validation) costs about 5 ms an FMU, a few times what reading this entry back does.

- Key: a SHA-256 of the model description's bytes (modelDescription.xml as extracted), FMPy's
  version and this module's format: an FMU whose description differs by one byte, or another
  FMPy, misses the cache. Only a description that FMPy read and validated, with a
  Co-Simulation interface of FMI 2.0 or 3.0, is stored.
- Entry: one JSON file per key (FMI version, GUID or instantiation token, model identifier,
  and each variable's name, value reference and type), holding its key and a SHA-256 of its
  content; written atomically (a temporary file in the folder, then renamed). An entry that
  cannot be read, holds another key or content that does not match its hash is ignored and
  rebuilt. At most MAX_ENTRIES are kept (the oldest go). ``RRR_NO_CACHE=1`` turns it off.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import fmpy

from ..core.cache import cache_dir

log = logging.getLogger(__name__)

#: The most model descriptions kept; storing another removes the oldest.
MAX_ENTRIES = 64
_FORMAT = 1


@dataclass(frozen=True)
class Variable:
    """A model variable as the slave uses it (FMPy's ScalarVariable has these fields too)."""

    name: str
    valueReference: int
    type: str


@dataclass(frozen=True)
class CoSimulation:
    modelIdentifier: str


@dataclass(frozen=True)
class Description:
    """The fields of FMPy's ModelDescription that :class:`~rrr_robot.sim.fmu_slave.FmuSlave`
    reads, under FMPy's names."""

    fmiVersion: str
    guid: str
    coSimulation: CoSimulation
    modelVariables: tuple[Variable, ...]


def key(xml: bytes) -> str:
    """The cache key of a model description's bytes (hex SHA-256)."""
    h = hashlib.sha256(f"rrr-md-cache {_FORMAT} fmpy {fmpy.__version__}\n".encode())
    h.update(xml)
    return h.hexdigest()


def _digest(content: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


def _path(folder: Path, k: str) -> Path:
    return folder / f"fmu-md-{k[:40]}.json"


def load(xml: bytes) -> Description | None:
    """The cached description of these bytes, or None (cache off, no entry, or an entry that
    is not exactly what :func:`store` writes: it is then ignored)."""
    folder = cache_dir()
    if folder is None:
        return None
    k = key(xml)
    file = _path(folder, k)
    try:
        entry = json.loads(file.read_bytes())
        content = entry["content"]
        if entry["key"] != k or entry["sha256"] != _digest(content):
            raise ValueError("another key or a damaged content")
        variables = tuple(Variable(str(n), int(vr), str(t)) for n, vr, t in content["variables"])
        if not all(isinstance(v, str) for v in (content["fmiVersion"], content["guid"],
                                                content["modelIdentifier"])):
            raise ValueError("not text")
        md = Description(content["fmiVersion"], content["guid"],
                         CoSimulation(content["modelIdentifier"]), variables)
    except FileNotFoundError:
        return None
    except Exception as exc:  # a damaged or foreign file: rebuilt, never trusted
        log.debug("model description cache: ignoring %s (%s)", file, exc)
        return None
    os.utime(file)  # most recently used: kept longest
    return md


def store(xml: bytes, md: Any) -> None:
    """Keep what the slave needs of ``md`` (FMPy's ModelDescription of ``xml``, with a
    Co-Simulation interface), atomically; a folder that cannot be written is left alone."""
    folder = cache_dir()
    if folder is None:
        return
    k = key(xml)
    content = {"fmiVersion": md.fmiVersion, "guid": md.guid,
               "modelIdentifier": md.coSimulation.modelIdentifier,
               "variables": [[v.name, int(v.valueReference), v.type] for v in md.modelVariables]}
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".fmu-md-", suffix=".tmp")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                json.dump({"key": k, "sha256": _digest(content), "content": content}, f)
            os.replace(tmp, _path(folder, k))
        except BaseException:
            os.unlink(tmp)
            raise
        entries = sorted(folder.glob("fmu-md-*.json"), key=lambda p: p.stat().st_mtime,
                         reverse=True)
        for old in entries[MAX_ENTRIES:]:
            old.unlink(missing_ok=True)
    except OSError as exc:
        log.debug("model description cache: not stored in %s (%s)", folder, exc)
