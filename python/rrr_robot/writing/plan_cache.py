"""The cache of the writing task's tip plans (:class:`TipPlan`).

A tip plan is a pure function of the (fitted) :class:`~rrr_robot.writing.trajectory.WritingSpec`
and of the code that builds it, and building it needs SciPy's splines: about 0.4 s to import
``scipy.interpolate`` and 40 ms of fits for the default text, several times what the
co-simulation of one scenario costs. So a built plan is kept, one ``.npz`` file per plan, and
read back the next time the same plan is asked for: the same arrays, bit for bit (a test builds
both ways and compares).

- Where: ``$RRR_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/rrr-robot``, else
  ``~/.cache/rrr-robot``. ``RRR_NO_CACHE=1`` (or ``make_reference(..., cache=False)``) turns the
  cache off.
- Key: a SHA-256 of the spec's fields (as asked: the plan holds the letter height the text was
  fitted to, so that a hit does not even read the font), the source of the modules that build
  the plan (``letters``, ``writing_path``, ``trajectory``, this one) and the installed versions
  of NumPy, SciPy and HersheyFonts (their ``.dist-info`` folders): a change of any of them
  misses the cache. The key is stored in the file and
  compared on reading.
- A file is written atomically (a temporary file in the cache folder, then renamed), and a file
  that cannot be read, holds another key or arrays of the wrong shape is ignored and rebuilt:
  the cache can make a run faster, never wrong and never fail. Plans that fail (a text out of
  the workspace, too long) are not cached. At most MAX_ENTRIES plans are kept (the oldest go).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import os
import tempfile
from dataclasses import dataclass
from importlib.machinery import PathFinder
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.cache import cache_dir

__all__ = ["MAX_ENTRIES", "TipPlan", "cache_dir", "load", "plan_key", "store"]

log = logging.getLogger(__name__)

#: The most plans kept in the cache folder; storing another removes the oldest.
MAX_ENTRIES = 64
_FORMAT = 1
_ARRAYS = ("t", "s", "x", "xd", "xdd", "pen_down", "ws_x")
_SOURCES = ("letters.py", "writing_path.py", "trajectory.py", "plan_cache.py")
#: (import name, distribution name) of the libraries whose versions the key holds
_PACKAGES = (("numpy", "numpy"), ("scipy", "scipy"), ("HersheyFonts", "Hershey_Fonts"))


@dataclass(frozen=True)
class TipPlan:
    """The part of the reference that does not depend on the robot: the tip motion on the time
    grid ``spec.dt`` (t, the path parameter s, x, xd, xdd, pen_down) and the tip positions of the
    workspace check (``ws_x``, every 0.2 mm of the path). Built by
    :func:`~rrr_robot.writing.trajectory.tip_plan` (the splines: the expensive part) or read
    back from this cache."""

    t: FloatArray
    s: FloatArray
    x: FloatArray
    xd: FloatArray
    xdd: FloatArray
    pen_down: np.ndarray
    ws_x: FloatArray
    path_length: float
    letter_height: float  # the fitted spec's (:func:`fitted_spec`)


def _installed(module: str, dist: str) -> str:
    """Which version of a library is installed, without importing it nor importlib.metadata
    (16 ms): its top-level folder and the names of the ``.dist-info`` folders beside it."""
    spec = PathFinder.find_spec(module)
    if spec is None or not spec.origin:
        return "absent"
    folder = Path(spec.origin).parent
    infos = sorted(p.name for p in folder.parent.glob(f"{dist}-*.dist-info"))
    return f"{folder}:{','.join(infos)}"


@functools.cache
def _code_fingerprint() -> str:
    here = Path(__file__).parent
    h = hashlib.sha256()
    for name in _SOURCES:
        h.update(name.encode())
        h.update((here / name).read_bytes())
    for module, dist in _PACKAGES:
        h.update(f"{module}={_installed(module, dist)}".encode())
    return h.hexdigest()


def plan_key(spec: Any) -> str:
    """The cache key of a spec's tip plan (hex SHA-256); ``spec`` is a
    :class:`~rrr_robot.writing.trajectory.WritingSpec`."""
    fields = {f.name: getattr(spec, f.name) for f in dataclasses.fields(spec)}
    text = json.dumps({"format": _FORMAT, "code": _code_fingerprint(), "spec": fields},
                      sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _path(folder: Path, key: str) -> Path:
    return folder / f"plan-{key[:40]}.npz"


def load(spec: Any) -> TipPlan | None:
    """The cached tip plan of ``spec``, or None (cache off, no entry, or an entry that is not
    exactly what :func:`store` writes: it is then ignored)."""
    folder = cache_dir()
    if folder is None:
        return None
    key = plan_key(spec)
    file = _path(folder, key)
    try:
        with np.load(file, allow_pickle=False) as z:
            if str(z["key"]) != key:
                raise ValueError("another key")
            arrays = {name: z[name] for name in _ARRAYS}
            length = float(z["path_length"])
            height = float(z["letter_height"])
    except FileNotFoundError:
        return None
    except Exception as exc:  # a damaged or foreign file: rebuilt, never trusted
        log.debug("plan cache: ignoring %s (%s)", file, exc)
        return None
    n = arrays["t"].shape[0] if arrays["t"].ndim == 1 else -1
    shapes_ok = (n >= 2 and arrays["s"].shape == (n,) and arrays["pen_down"].shape == (n,)
                 and all(arrays[a].shape == (n, 3) for a in ("x", "xd", "xdd"))
                 and arrays["ws_x"].ndim == 2 and arrays["ws_x"].shape[1] == 3
                 and arrays["pen_down"].dtype == np.bool_
                 and all(arrays[a].dtype == np.float64 for a in _ARRAYS if a != "pen_down"))
    if not shapes_ok or not all(np.all(np.isfinite(arrays[a])) for a in _ARRAYS
                                if a != "pen_down") or not np.isfinite(length) \
            or not (np.isfinite(height) and height > 0):
        log.debug("plan cache: ignoring %s (wrong arrays)", file)
        return None
    os.utime(file)  # most recently used: kept longest
    return TipPlan(path_length=length, letter_height=height, **arrays)


def store(spec: Any, plan: TipPlan) -> None:
    """Add ``plan`` to the cache (atomically); a cache folder that cannot be written is left
    alone (logged at debug level): the run goes on without the cache."""
    folder = cache_dir()
    if folder is None:
        return
    key = plan_key(spec)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".plan-", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, key=np.array(key), path_length=np.array(plan.path_length),
                         letter_height=np.array(plan.letter_height),
                         **{name: getattr(plan, name) for name in _ARRAYS})
            os.replace(tmp, _path(folder, key))
        except BaseException:
            os.unlink(tmp)
            raise
        _prune(folder)
    except OSError as exc:
        log.debug("plan cache: not stored in %s (%s)", folder, exc)


def _prune(folder: Path) -> None:
    entries = sorted(folder.glob("plan-*.npz"), key=lambda p: p.stat().st_mtime, reverse=True)
    for old in entries[MAX_ENTRIES:]:
        old.unlink(missing_ok=True)
