"""Where the FMUs are, and what each archive holds.

Shipped in the package (``pip install .``) or named by ``$RRR_FMU_DIR`` (e.g. a CMake build's
``fmus/`` folder), with the same layout: ``rrr_<name>.fmu`` (FMI 2.0) and ``fmi3/rrr_<name>.fmu``
(FMI 3.0). Each archive holds Model Exchange and Co-Simulation, the sources and binaries for the
platforms the build could compile for.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..core._package import PACKAGE_DIR
from ..core.archives import CheckedZip
from ..errors import ArchiveError, BadInputError, RrrError

FMU_NAMES = {"plant": "rrr_plant.fmu", "controller": "rrr_controller.fmu",
             "reference": "rrr_reference.fmu"}
FMI_VERSIONS = (2, 3)


def fmu_dir() -> Path:
    """The folder of the FMUs: $RRR_FMU_DIR, else the copies installed with the package."""
    env = os.environ.get("RRR_FMU_DIR")
    return Path(env) if env else PACKAGE_DIR / "fmus"


def fmu_path(which: str, fmi_version: int = 2) -> Path:
    """Path of the 'plant', 'controller' or 'reference' FMU for FMI version 2 or 3.

    $RRR_FMU_DIR (e.g. a CMake build's ``fmus/`` folder) takes precedence over the copies
    installed with the package.
    """
    if which not in FMU_NAMES:
        raise BadInputError(f"unknown FMU {which!r}: expected one of {sorted(FMU_NAMES)}")
    if fmi_version not in FMI_VERSIONS:
        raise BadInputError(f"unknown FMI version {fmi_version!r}: expected 2 or 3")
    folder = fmu_dir() if fmi_version == 2 else fmu_dir() / "fmi3"
    path = folder / FMU_NAMES[which]
    if not path.exists():
        raise RrrError(
            f"{which} FMU (FMI {fmi_version}.0) not found at {path}: install with "
            "'pip install .' or set RRR_FMU_DIR to a build's fmus/ folder"
        )
    return path


@dataclass(frozen=True)
class FmuVariant:
    """One FMU archive: which model, FMI version, interface types, platforms, sources."""

    which: str
    fmi_version: int
    path: Path
    interfaces: tuple[str, ...]   # "ModelExchange", "CoSimulation"
    platforms: tuple[str, ...]    # binaries/<platform>/ folders, e.g. linux64, x86_64-windows
    has_sources: bool
    has_documentation: bool


def describe(which: str, fmi_version: int) -> FmuVariant:
    """What the archive of one FMU holds (read from its file list and model description)."""
    path = fmu_path(which, fmi_version)
    try:
        with CheckedZip(path, "FMU") as z:
            names = z.names()
            md = z.read("modelDescription.xml", 16_000_000).decode("utf-8")
    except (ArchiveError, UnicodeError) as exc:
        raise RrrError(f"{path} is not a readable FMU: {exc}") from exc
    platforms = sorted({n.split("/")[1] for n in names
                        if n.startswith("binaries/") and n.count("/") >= 2 and n.split("/")[2]})
    interfaces = tuple(k for k in ("ModelExchange", "CoSimulation") if f"<{k}" in md)
    return FmuVariant(which=which, fmi_version=fmi_version, path=path, interfaces=interfaces,
                      platforms=tuple(platforms),
                      has_sources=any(n.startswith("sources/") and n.endswith(".c")
                                      for n in names),
                      has_documentation="documentation/index.html" in names)


def variants() -> list[FmuVariant]:
    """Every FMU the package provides: plant, controller and reference, FMI 2.0 and 3.0."""
    return [describe(which, v) for v in FMI_VERSIONS for which in FMU_NAMES]
