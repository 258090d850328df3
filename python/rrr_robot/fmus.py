"""Where the FMUs are: shipped in the package (pip install .) or named by $RRR_FMU_DIR."""

from __future__ import annotations

import os
from pathlib import Path

from .errors import RrrError

FMU_NAMES = {"plant": "rrr_plant.fmu", "controller": "rrr_controller.fmu"}


def fmu_path(which: str) -> Path:
    """Path of the 'plant' or 'controller' FMU.

    $RRR_FMU_DIR (e.g. a CMake build's ``fmus/`` folder) takes precedence over the copies
    installed with the package.
    """
    if which not in FMU_NAMES:
        raise ValueError(f"unknown FMU {which!r}: expected one of {sorted(FMU_NAMES)}")
    env = os.environ.get("RRR_FMU_DIR")
    folder = Path(env) if env else Path(__file__).with_name("fmus")
    path = folder / FMU_NAMES[which]
    if not path.exists():
        raise RrrError(
            f"{which} FMU not found at {path}: install with 'pip install .' or set RRR_FMU_DIR"
        )
    return path
