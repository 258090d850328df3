"""One version: ``RRR_VERSION_STRING`` in rrr_version.h is the source, and the Python package
(``__version__``, the wheel's metadata, ``rrr --version``), librrr (``rrr_version()``), CMake's
project, pyproject.toml, every packaged FMU's modelDescription.xml (``version``,
``generationTool``), the committed modelDescription.xml copies and CHANGELOG.md agree with it."""

from __future__ import annotations

import importlib
import importlib.metadata
import re
import runpy
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
import rrr_robot as rr
from rrr_robot.core import _lib
from rrr_robot.core._version import header_version
from rrr_robot.sim.fmus import FMU_NAMES, fmu_path
from support import REPO
from support.fmu_support import COMMITTED_XML

HEADER = REPO / "c_src" / "rrr" / "include" / "rrr" / "rrr_version.h"
VERSION = header_version(HEADER.read_text(encoding="utf-8"))


def test_the_header_defines_one_consistent_version():
    text = HEADER.read_text(encoding="utf-8")
    parts = [int(re.search(rf"^#define RRR_VERSION_{p} (\d+)$", text, re.M).group(1))
             for p in ("MAJOR", "MINOR", "PATCH")]
    assert ".".join(map(str, parts)) == VERSION
    with pytest.raises(ValueError, match="once"):
        header_version(text + '\n#define RRR_VERSION_STRING "9.9.9"\n')
    with pytest.raises(ValueError, match="found 0"):
        header_version("#define RRR_VERSION_STRING 0.1\n")


def test_the_python_package_reports_it():
    assert rr.__version__ == VERSION
    assert importlib.metadata.version("rrr_robot") == VERSION
    out = subprocess.run([sys.executable, "-m", "rrr_robot", "--version"], check=True,
                         capture_output=True, text=True).stdout
    assert out.strip() == f"rrr_robot {VERSION}"


def test_the_installed_package_carries_the_built_version():
    """The wheel holds the version the build read from the header (no header at run time)."""
    built = importlib.import_module("rrr_robot.core._build_version")
    assert built.version == VERSION


def test_librrr_reports_it():
    assert _lib.library_version() == VERSION


def test_pyproject_and_cmake_read_the_header():
    meta = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in meta["project"] and meta["project"]["dynamic"] == ["version"]
    provider = meta["tool"]["scikit-build"]["metadata"]["version"]
    assert (REPO / provider["input"]).resolve() == HEADER
    assert re.search(provider["regex"], HEADER.read_text()).group("value") == VERSION
    cmake = (REPO / "CMakeLists.txt").read_text(encoding="utf-8")
    assert "c_src/rrr/include/rrr/rrr_version.h" in cmake
    assert re.search(r"^project\(rrr VERSION \$\{RRR_VERSION\}", cmake, re.M)


def test_cmake_reads_the_version_as_the_header_states_it(tmp_path):
    """CMakeLists.txt's reading of the header, run by CMake itself in script mode."""
    cmake = (REPO / "CMakeLists.txt").read_text(encoding="utf-8")
    start = cmake.index("file(STRINGS")
    end = cmake.index("project(rrr")
    script = tmp_path / "version.cmake"
    script.write_text(f'set(CMAKE_CURRENT_SOURCE_DIR "{REPO}")\n{cmake[start:end]}'
                      'message(STATUS "version=${RRR_VERSION}")\n')
    out = subprocess.run(["cmake", "-P", str(script)], check=True, capture_output=True,
                         text=True)
    assert f"version={VERSION}" in out.stdout + out.stderr


@pytest.mark.parametrize("which", FMU_NAMES)
@pytest.mark.parametrize("fmi", [2, 3])
def test_every_fmu_reports_it(which, fmi):
    with zipfile.ZipFile(fmu_path(which, fmi)) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    assert root.get("version") == VERSION
    assert root.get("generationTool") == f"rrr_robot {VERSION} (fmu/common/fmu_xml.c)"


@pytest.mark.parametrize("which", sorted(COMMITTED_XML))
def test_the_committed_model_descriptions_report_it(which):
    root = ET.parse(COMMITTED_XML[which]).getroot()
    assert root.get("version") == VERSION
    assert root.get("generationTool") == f"rrr_robot {VERSION} (fmu/common/fmu_xml.c)"


def test_the_changelog_has_the_version():
    text = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    versions = re.findall(r"^## \[([^\]]+)\]", text, re.M)
    assert versions[0] == "Unreleased" and VERSION in versions, versions


def test_the_manual_reports_it():
    """docs/conf.py's release (the site's title and the version Sphinx shows)."""
    conf = runpy.run_path(str(REPO / "docs" / "conf.py"))
    assert conf["release"] == conf["version"] == VERSION
    assert conf["html_title"] == f"rrr_robot {VERSION}"


def test_a_copy_of_the_package_folder_still_imports(tmp_path):
    """Neither the built version module nor the source header beside it (the CTest pyext_smoke
    imports such a copy): the installed distribution's version, and ``import`` never fails."""
    import shutil

    pkg = Path(rr.__file__).parent
    shutil.copytree(pkg, tmp_path / "rrr_robot",
                    ignore=shutil.ignore_patterns("__pycache__", "_build_version.py"))
    out = subprocess.run([sys.executable, "-c", "import rrr_robot; print(rrr_robot.__version__)"],
                         cwd=tmp_path, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin"},
                         check=True, capture_output=True, text=True).stdout
    assert out.strip() == VERSION
