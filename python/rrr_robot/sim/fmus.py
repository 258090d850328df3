"""Where the FMUs are, and what each archive holds.

Shipped in the package (``pip install .``) or named by ``$RRR_FMU_DIR`` (e.g. a CMake build's
``fmus/`` folder), with the same layout: ``rrr_<name>.fmu`` (FMI 2.0) and ``fmi3/rrr_<name>.fmu``
(FMI 3.0), and, when the build had the aarch64 cross compiler, ``aarch64-linux/rrr_<name>.fmu``:
FMI 2.0 for aarch64 Linux hosts, whose ``binaries/linux64`` is the aarch64 binary (the folder
FMPy and the FMI Library load there; docs/aarch64.md). Each archive holds Model Exchange and
Co-Simulation, the sources and binaries for the platforms the build could compile for.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..core._package import PACKAGE_DIR
from ..core.archives import CheckedZip
from ..core.fmu_vars import FMUS
from ..errors import ArchiveError, BadInputError, RrrError

__all__ = [
    "FMI_VERSIONS",
    "FMU_NAMES",
    "HOST_VARIANTS",
    "FmuVariant",
    "describe",
    "fmu_dir",
    "fmu_path",
    "variants",
]

#: The packaged FMUs' files by role (the roles of fmu/CMakeLists.txt's RRR_FMU_NAMES, in order).
FMU_NAMES = {which: f"rrr_{which}.fmu" for which in FMUS}
#: The FMI versions each FMU is built for.
FMI_VERSIONS = (2, 3)
#: fmus/<folder>/: FMI 2.0 archives for the hosts of another CPU, binaries/linux64 built for it.
HOST_VARIANTS = ("aarch64-linux",)
# ELF e_machine -> CPU, to tell what a linux32/linux64 folder (FMI 2.0: no CPU in the name) holds
_ELF_MACHINES = {3: "x86", 62: "x86_64", 40: "arm", 183: "aarch64"}


def fmu_dir() -> Path:
    """The folder of the FMUs: $RRR_FMU_DIR, else the copies installed with the package."""
    env = os.environ.get("RRR_FMU_DIR")
    return Path(env) if env else PACKAGE_DIR / "fmus"


def fmu_path(which: str, fmi_version: int = 2) -> Path:
    """Path of an FMU (one of FMU_NAMES: 'plant', 'controller', ...) for FMI version 2 or 3.

    ``fmi_version``: 2 (the default) gives the FMI 2.0 archive (``fmus/rrr_<which>.fmu``), 3 the
    FMI 3.0 one (``fmus/fmi3/rrr_<which>.fmu``): the same variables and value references, the
    same results bit for bit (docs/fmpy.md). Another value is refused (BadInputError).
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
    host: str = ""                # "" or the HOST_VARIANTS folder the archive is in
    linux_cpu: str = ""           # the CPU of the binary in binaries/linux64 (or linux32)

    def platform_labels(self) -> list[str]:
        """The platform folders; linux64/linux32 with their binary's CPU: 'linux64 (aarch64)'."""
        return [f"{p} ({self.linux_cpu})" if p in ("linux64", "linux32") and self.linux_cpu
                else p for p in self.platforms]


def _elf_cpu(head: bytes) -> str:
    if len(head) < 20 or head[:4] != b"\x7fELF":
        return ""
    machine = int.from_bytes(head[18:20], "little" if head[5] == 1 else "big")
    return _ELF_MACHINES.get(machine, f"ELF machine {machine}")


def describe(which: str, fmi_version: int, host: str = "") -> FmuVariant:
    """What the archive of one FMU holds (read from its file list and model description);
    ``host``: one of HOST_VARIANTS, the FMI 2.0 archive for that platform's hosts."""
    if host:
        if host not in HOST_VARIANTS or fmi_version != 2 or which not in FMU_NAMES:
            raise BadInputError(f"no {host!r} FMI {fmi_version}.0 variant of {which!r}: "
                                f"hosts {HOST_VARIANTS} have FMI 2.0 archives")
        path = fmu_dir() / host / FMU_NAMES[which]
    else:
        path = fmu_path(which, fmi_version)
    try:
        with CheckedZip(path, "FMU") as z:
            names = z.names()
            md = z.read("modelDescription.xml", 16_000_000).decode("utf-8")
            linux = [n for n in names if n.startswith(("binaries/linux64/", "binaries/linux32/"))
                     and n.endswith(".so")]
            cpu = ""
            if linux:
                cpu = _elf_cpu(z.read(linux[0], 64_000_000)[:20])
    except (ArchiveError, UnicodeError) as exc:
        raise RrrError(f"{path} is not a readable FMU: {exc}") from exc
    platforms = sorted({n.split("/")[1] for n in names
                        if n.startswith("binaries/") and n.count("/") >= 2 and n.split("/")[2]})
    interfaces = tuple(k for k in ("ModelExchange", "CoSimulation") if f"<{k}" in md)
    return FmuVariant(which=which, fmi_version=fmi_version, path=path, interfaces=interfaces,
                      platforms=tuple(platforms),
                      has_sources=any(n.startswith("sources/") and n.endswith(".c")
                                      for n in names),
                      has_documentation="documentation/index.html" in names,
                      host=host, linux_cpu=cpu)


def variants() -> list[FmuVariant]:
    """Every FMU the package provides (FMU_NAMES), FMI 2.0 and 3.0, and the FMI 2.0 archives
    for other hosts (HOST_VARIANTS) the build made."""
    found = [describe(which, v) for v in FMI_VERSIONS for which in FMU_NAMES]
    for host in HOST_VARIANTS:
        found += [describe(which, 2, host) for which in FMU_NAMES
                  if (fmu_dir() / host / FMU_NAMES[which]).exists()]
    return found
