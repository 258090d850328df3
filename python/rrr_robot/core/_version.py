"""The package's version, from the toolkit's one source: ``RRR_VERSION_STRING`` in
``c_src/rrr/include/rrr/rrr_version.h`` (which CMake, the FMUs' XML and the wheel's metadata read
too). The wheel carries it as ``rrr_robot.core._build_version``, written by scikit-build-core
from the header (pyproject.toml, ``[[tool.scikit-build.generate]]``); a source tree that was not
built reads the header itself."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

#: The header's line that holds the version (also the regex of pyproject.toml and CMakeLists.txt).
VERSION_PATTERN = re.compile(r'^#define RRR_VERSION_STRING "(\d+\.\d+\.\d+)"$', re.MULTILINE)

#: The header in a source tree (python/rrr_robot/core/ -> c_src/rrr/include/rrr/).
SOURCE_HEADER = (Path(__file__).resolve().parents[3]
                 / "c_src" / "rrr" / "include" / "rrr" / "rrr_version.h")


def header_version(text: str) -> str:
    """The version ``X.Y.Z`` that the text of ``rrr_version.h`` defines; ValueError if none."""
    found = VERSION_PATTERN.findall(text)
    if len(found) != 1:
        raise ValueError(f'rrr_version.h must define RRR_VERSION_STRING "X.Y.Z" once, found '
                         f"{len(found)}")
    return str(found[0])


def package_version() -> str:
    """The version of this installation: the one the build wrote, else the source tree's."""
    try:
        built = importlib.import_module(f"{__package__}._build_version")
    except ModuleNotFoundError:
        return header_version(SOURCE_HEADER.read_text(encoding="utf-8"))
    return str(built.version)
