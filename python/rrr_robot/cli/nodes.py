"""The CAN bench's C nodes under their own names on PATH: ``rrr_hil_plant`` and
``rrr_hil_controller`` (pyproject.toml's [project.scripts]). Each replaces its Python process
with the binary the package ships (``rrr_robot/bin/``, built by ``pip install``) by
``os.execv``, with the same arguments: the process, its exit status and the signals it gets
(Ctrl-C, ``kill``) are the node's own."""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["BIN_DIR", "controller", "plant"]

#: The folder of the packaged nodes.
BIN_DIR = Path(__file__).resolve().parents[1] / "bin"


def _exec(name: str) -> None:
    path = BIN_DIR / name
    try:
        os.execv(path, [sys.argv[0], *sys.argv[1:]])
    except OSError as exc:  # only when the exec itself failed: on success it never returns
        print(f"{name}: cannot run {path}: {exc.strerror} (the package was installed without "
              "its C nodes: reinstall it with 'pip install .' on Linux)", file=sys.stderr)
        raise SystemExit(127) from None


def plant() -> None:
    """``rrr_hil_plant``: the C plant node (``rrr_hil_plant --help``)."""
    _exec("rrr_hil_plant")


def controller() -> None:
    """``rrr_hil_controller``: the C controller node (``rrr_hil_controller --help``)."""
    _exec("rrr_hil_controller")
