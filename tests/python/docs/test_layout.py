"""The layout of the pytest suite (CONTRIBUTING.md, "Where a new test module goes"): every test
module is in a folder whose conftest.py names its markers, and that folder is in CONTRIBUTING's
table with the same markers; module names are unique across the folders; every path of
tests/python that the repository's files name exists (a moved module leaves no stale path)."""

from __future__ import annotations

import ast
import re

from support import REPO

TESTS = REPO / "tests" / "python"


def _folder_markers(conftest_text: str) -> set[str] | None:
    """The markers a conftest.py names with support.markers.folder_markers (None: it names
    none)."""
    for node in ast.walk(ast.parse(conftest_text)):
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "folder_markers":
            names = {a.value for a in node.args[1:] if isinstance(a, ast.Constant)}
            for kw in node.keywords:
                if kw.arg == "maybe" and isinstance(kw.value, ast.Tuple | ast.List):
                    names |= {e.value for e in kw.value.elts if isinstance(e, ast.Constant)}
            return names
    return None


def _test_folders() -> dict[str, set[str] | None]:
    folders = {p.parent for p in TESTS.rglob("test_*.py")}
    return {str(f.relative_to(TESTS)): (_folder_markers((f / "conftest.py").read_text())
                                        if (f / "conftest.py").exists() else None)
            for f in sorted(folders)}


def test_every_test_module_is_in_a_folder_that_names_its_markers() -> None:
    folders = _test_folders()
    assert "." not in folders, sorted(p.name for p in TESTS.glob("test_*.py"))
    assert {f: m for f, m in folders.items() if m is None} == {}
    assert {"unit", "docs", "can"} <= set(folders)
    assert folders["unit"] == folders["docs"] == set()  # the fast subset
    assert folders["can"] == {"slow", "bus", "vm"}


def test_contributing_lists_every_folder_with_its_markers() -> None:
    text = (REPO / "CONTRIBUTING.md").read_text()
    rows = {m.group(1): m.group(2) for m in
            re.finditer(r"^\| `([a-z/]+)/` \| .* \| ([^|]*) \|$", text, re.M)}
    for folder, markers in _test_folders().items():
        assert folder in rows, f"CONTRIBUTING.md: no row for tests/python/{folder}/"
        named = set(re.findall(r"`(\w+)`", rows[folder]))
        assert named == (markers or set()), (folder, rows[folder])


def test_module_names_are_unique_across_the_folders() -> None:
    names = [p.name for p in TESTS.rglob("*.py") if p.name not in ("conftest.py", "__init__.py")]
    assert sorted(n for n in set(names) if names.count(n) > 1) == []


#: Where the repository names paths of tests/python (the CHANGELOG's history aside).
NAMING = ("README.md", "CONTRIBUTING.md", "pyproject.toml", "CMakeLists.txt", "docs", "scripts",
          "tools", "c_src", "fmu", "python", "bench", "tests", "examples")


def test_every_named_test_path_exists() -> None:
    """Each ``tests/python/...`` path in the repository's docs, scripts, tools, sources and
    tests is a file or folder of the checkout."""
    path = re.compile(r"tests/python/[\w/.-]*\w")
    missing = []
    for top in NAMING:
        files = [REPO / top] if (REPO / top).is_file() else sorted((REPO / top).rglob("*"))
        for file in files:
            if not file.is_file() or "__pycache__" in file.parts:
                continue
            try:
                text = file.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                continue
            for m in path.finditer(text):
                if not (REPO / m.group(0)).exists():
                    line = text.count("\n", 0, m.start()) + 1
                    missing.append(f"{file.relative_to(REPO)}:{line}: {m.group(0)}")
    assert missing == []
