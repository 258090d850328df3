"""The package's cache folder: the writing task's tip plans (rrr_robot.writing.plan_cache) are
kept there.

``$RRR_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/rrr-robot``, else ``~/.cache/rrr-robot``;
``RRR_NO_CACHE=1`` turns every cache off. A cache can make a run faster, never wrong and never
fail: each entry is written atomically, checked when it is read, and ignored (rebuilt) when it
is not exactly what was written.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir"]


def cache_dir() -> Path | None:
    """The cache folder, or None when the cache is off (``RRR_NO_CACHE`` set and not 0)."""
    if os.environ.get("RRR_NO_CACHE", "0") not in ("", "0"):
        return None
    if os.environ.get("RRR_CACHE_DIR"):
        return Path(os.environ["RRR_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rrr-robot"
