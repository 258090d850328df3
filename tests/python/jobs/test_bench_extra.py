"""``pip install '.[bench]'`` gives every bench script what it imports: the third-party modules
imported anywhere in bench/*.py, in the generator run_bench.py runs and in the package they use
belong to distributions that rrr_robot's dependencies and its ``bench`` extra require (directly
or through their own requirements). The quick modes themselves run in the test command
(scripts/run_tests.sh)."""

from __future__ import annotations

import ast
import importlib.metadata as md
import sys
import tomllib
from pathlib import Path

from packaging.utils import canonicalize_name
from support import REPO
from support.doc_blocks import closure

ROOT = REPO
#: the bench scripts, the generator run_bench.py runs, and the package they import
SOURCES = [*sorted((ROOT / "bench").glob("*.py")), ROOT / "c_src/rrr/gen/derive_dynamics.py",
           *sorted((ROOT / "python/rrr_robot").rglob("*.py"))]
#: imported by the package only when a user asks for them, none by a bench script
OPTIONAL = {"imageio_ffmpeg": "rrr writing --animate mp4 (the mp4 extra)",
            "pandas": "the tests read sweep results with it; the package does not",
            "fmu_manipulation_toolbox": "rrr ls-bus (the lsbus extra)"}
#: the package, the generator and the bench scripts' own helper modules (bench/_*.py)
LOCAL = {"rrr_robot", "derive_dynamics", *(p.stem for p in (ROOT / "bench").glob("*.py"))}
#: modules whose distribution metadata does not list them (cmeel wheels install into their own
#: prefix through a .pth file)
INSTALLED_BY = {"pinocchio": "pin"}


def imported(path: Path) -> set[str]:
    """Top-level names of the absolute imports anywhere in a file."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_the_bench_extra_covers_what_the_bench_scripts_import() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    provided = closure(project["dependencies"] + project["optional-dependencies"]["bench"])
    dists = md.packages_distributions()
    missing = {}
    for path in SOURCES:
        for name in imported(path) - LOCAL - set(sys.stdlib_module_names) - set(OPTIONAL):
            owners = {canonicalize_name(d) for d in dists.get(name, [INSTALLED_BY.get(name, "")])
                      if d}
            assert owners, f"{path.relative_to(ROOT)} imports {name}, which no installed " \
                           "distribution provides"
            if not owners & provided:
                missing[name] = (sorted(owners), str(path.relative_to(ROOT)))
    assert not missing, f"not in rrr_robot[bench]: {missing}"
    for name in OPTIONAL:  # still optional: no bench script imports it itself
        assert all(name not in imported(p) for p in (ROOT / "bench").glob("*.py")), name
