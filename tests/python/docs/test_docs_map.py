"""Nothing of the old README is lost: each of its sections (the headings of README.md at
50ca721, before it was shortened into the manual) maps to a heading of a page of the manual or
of today's README, and that heading exists. And the schema page lists every key the robot and
scenario file readers accept."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from support import REPO

ROOT = REPO

#: heading of the old README -> (file, heading there)
OLD_README = {
    "rrr_robot: closed-form models of an RRR robot arm, as a C core, FMUs and Python tools":
        ("README.md", "rrr_robot: closed-form models of an RRR robot arm, as a C core, FMUs and "
                      "Python tools"),
    "Two commands": ("README.md", "Two commands"),
    "Layout": ("docs/layout.md", "Layout of the repository"),
    "The FMUs": ("docs/fmus.md", "The FMUs"),
    "The plant's integrator": ("docs/fmus.md", "The plant's integrator"),
    "The writing task (the main job)": ("docs/writing.md", "The writing task"),
    "Benchmark of the core": ("docs/performance.md",
                              "The core against Pinocchio and the Robotics Toolbox"),
    "Through Python": ("docs/performance.md", "Through Python"),
    "The CAN bench (hardware in the loop)": ("docs/can-bench.md",
                                             "The CAN bench (hardware in the loop)"),
    "Results of a bench run": ("docs/can-bench.md", "Results of a bench run"),
    "Frame logs": ("docs/can-bench.md", "Frame logs"),
    "Bus load": ("docs/can-bench.md", "Bus load"),
    "Real time": ("docs/can-bench.md", "Real time"),
    "Identification": ("docs/identification.md", "Identification"),
    "Using it from C, ROS and notebooks": ("docs/c-library.md",
                                           "The C library as a CMake package"),
    "The C library as a CMake package": ("docs/c-library.md", "The C library as a CMake package"),
    "URDF: Pinocchio, ROS and other URDF tools": ("docs/urdf.md",
                                                  "URDF: Pinocchio, ROS and other URDF tools"),
    "The notebook": ("docs/python.md", "The notebook"),
    "Outputs and exit statuses": ("docs/outputs.md", "Outputs and exit statuses"),
    "Known limits": ("docs/limits.md", "Known limits"),
    "Conventions (in full: `docs/conventions.md`)": ("docs/conventions.md", "In brief"),
    "Python": ("docs/python.md", "Using rrr_robot from Python"),
    "The closed loop from Python": ("docs/python.md", "The closed loop from Python"),
    "The binding": ("docs/python.md", "The binding"),
    "Robot and scenario files": ("docs/files.md", "Robot and scenario files"),
    "The default robot": ("docs/files.md", "The default robot"),
    "Dependencies and what each is for": ("docs/getting-started.md",
                                          "Dependencies and what each is for"),
    "Verification": ("docs/verification.md", "Verification"),
}


def headings(path: Path) -> set[str]:
    """The headings of a Markdown page (# to ######), outside fenced blocks."""
    out: set[str] = set()
    fence = False
    for line in path.read_text(encoding="utf-8").split("\n"):
        if re.match(r"^\s*(```|~~~)", line):
            fence = not fence
        elif not fence:
            m = re.match(r"^#{1,6}\s+(.*?)\s*$", line)
            if m:
                out.add(m.group(1))
    return out


@pytest.mark.parametrize("old", sorted(OLD_README))
def test_old_readme_section_has_a_place(old: str) -> None:
    page, heading = OLD_README[old]
    assert heading in headings(ROOT / page), f"{old!r}: no heading {heading!r} in {page}"


def test_readme_is_short() -> None:
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n <= 260, f"README.md has {n} lines: move text into a page of docs/"


def test_files_page_lists_every_key() -> None:
    from rrr_robot.core.robot import (
        CONTROL_FIELDS,
        IDENTIFICATION_FIELDS,
        LINK_FIELDS,
        PARAM_TABLES,
        TABLES,
        WRITING_FIELDS,
    )
    from rrr_robot.writing.scenarios import SCHEMA

    text = (ROOT / "docs" / "files.md").read_text(encoding="utf-8")
    keys = {*LINK_FIELDS, *CONTROL_FIELDS, *WRITING_FIELDS, *IDENTIFICATION_FIELDS,
            "rotor_inertia", *(k for groups in PARAM_TABLES.values() for k in groups)}
    missing = sorted(k for k in keys if f"`{k}`" not in text)
    missing += sorted(f"[{t}]" for t in TABLES if t not in ("link1", "link2", "link3")
                      and f"`[{t}]`" not in text)
    for table, fields in SCHEMA.items():
        missing += [f"[{table}]"] if f"`[{table}]`" not in text else []
        missing += sorted(k for k in fields if k != "name" and f"`{k}`" not in text
                          and not k.endswith("_rel"))
        missing += sorted(k for k in fields if k.endswith("_rel") and f"`{k}`" not in text)
    assert not missing, f"docs/files.md does not describe: {missing}"
