"""Sphinx configuration of the rrr_robot manual (docs/).

Build: ``sphinx-build -W --keep-going -n -b html docs build-docs`` (scripts/run_tests.sh runs
exactly that; ``pip install '.[docs]'`` brings Sphinx, MyST, breathe and the theme, and the C API
page needs Doxygen: Debian's ``doxygen``). Sphinx, because the Python API page is generated from
the docstrings by autodoc; the pages are MyST Markdown. The C API page (api/c.md) is rendered by
breathe from the XML that Doxygen writes from librrr's public headers (docs/Doxyfile) at the
start of every build, into the build folder: nothing of it is committed.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
#: librrr's public headers: each has its ``doxygenfile`` on the C API page
HEADERS = ROOT / "c_src" / "rrr" / "include" / "rrr"


def _version() -> str:
    """The package's version (rrr_robot.core._version: the built one, or the source header's),
    the one the package, librrr and the FMUs report."""
    from rrr_robot.core._version import package_version

    return str(package_version())


project = "rrr_robot"
author = "the rrr_robot developers"
copyright = "the rrr_robot developers"
release = version = _version()

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "breathe",
]
source_suffix = {".md": "markdown"}
root_doc = "index"
# docs/README.md is the index for readers of the repository; the site starts at index.md
exclude_patterns = ["README.md", "_build"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
# every heading down to ### gets an anchor, so [text](page.md#a-heading) links are checked
myst_heading_anchors = 3

# -n: every reference must resolve. Links from pages to files of the repository outside docs/
# (sources, the DBC, READMEs next to the code) become download links, which Sphinx checks too.
nitpicky = True
# types of other packages (the build is offline: no intersphinx) and the package's private
# helpers in signatures
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|pathlib|collections\.abc|typing|argparse|scipy|can|cantools|fmpy|pandas"
              r"|pyarrow|dask|distributed|matplotlib|ctypes|concurrent|threading|subprocess|io"
              r"|os)(\..*)?"),
    ("py:.*", r"(.*\.)?_[A-Za-z]\w*(\..*)?"),
    # names that autodoc leaves unresolved in signatures (aliases, TYPE_CHECKING imports)
    ("py:class", r"ArrayLike|Path|Mapping|Sequence|Callable|Iterator|Any|Progress"
                 r"|ScipyStateSpace|BSpline"),
]
# the C API page: Doxygen's XML, written by _doxygen below; C's own types in signatures
breathe_projects: dict[str, str] = {}
breathe_default_project = "rrr"
breathe_domain_by_extension = {"h": "c"}
breathe_show_include = False
breathe_show_define_initializer = True
nitpick_ignore_regex += [
    ("c:identifier", r"size_t|u?int(8|16|32|64)_t|bool"),
]
autodoc_typehints = "description"
autodoc_member_order = "bysource"

html_theme = "furo"
html_title = f"rrr_robot {release}"

#: Pages written in parallel with this configuration (the API pages, the SSP and sweep pages):
#: while one is missing from the tree, its toctree entry and the links to it are left out, so
#: the build of the other pages stays warning-free. Once it exists, it is built and checked
#: like every page.
PENDING = ("api/python", "api/c", "ssp", "sweeps")


def _drop_pending(app: Any, docname: str, source: list[str]) -> None:
    for page in PENDING:
        if (DOCS / f"{page}.md").exists():
            continue
        text = source[0]
        text = re.sub(rf"^{re.escape(page)}\n", "", text, flags=re.M)
        text = re.sub(rf"\[([^\]]*)\]\((?:\.\./)*{re.escape(page)}\.md(?:#[^)]*)?\)", r"\1", text)
        source[0] = text


def _profile_pages(app: Any, docname: str, source: list[str]) -> None:
    """The CAN profiles' pages (docs/<name>.md) in the Reference toctree of index.md, where its
    line ``RRR_HIL_PROFILES`` stands: the list of c_src/hil/CMakeLists.txt, as the installed
    package reads it (rrr_robot.hil.PROFILES), so that each profile has its page in the manual
    (a listed profile without one is a warning of the build) and no second list names them."""
    if docname != "index":
        return
    from rrr_robot.hil import PROFILES, PROFILES_FILE

    if not PROFILES:
        raise RuntimeError(f"no CAN profiles: {PROFILES_FILE} is missing (pip install . first)")
    source[0] = re.sub(r"^RRR_HIL_PROFILES$", "\n".join(PROFILES), source[0], flags=re.M)


def _doxygen(app: Any) -> None:
    """Doxygen's XML of the public headers into the build folder, for breathe; each warning of
    Doxygen (an undocumented declaration, a broken comment) becomes a warning of the build, and
    a header without its ``doxygenfile`` on api/c.md is one too."""
    from sphinx.util import logging

    log = logging.getLogger("rrr.c_api")
    doxygen = shutil.which("doxygen")
    if doxygen is None:
        raise RuntimeError("the C API page (docs/api/c.md) needs Doxygen: install it (Debian: "
                           "apt-get install doxygen); docs/Doxyfile says what it reads")
    out = Path(app.doctreedir) / "doxygen"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    config = (DOCS / "Doxyfile").read_text(encoding="utf-8") + f"\nOUTPUT_DIRECTORY = \"{out}\"\n"
    run = subprocess.run([doxygen, "-"], input=config, cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"doxygen failed ({run.returncode}): {run.stderr.strip()}")
    warnings: list[str] = []
    for line in run.stderr.splitlines():  # a warning's continuation lines are indented
        if line.strip() and line[:1].isspace() and warnings:
            warnings[-1] += " " + line.strip()
        elif line.strip():
            warnings.append(line.strip())
    for warning in warnings:
        log.warning("doxygen: %s", warning)
    app.config.breathe_projects["rrr"] = str(out / "xml")
    page = (DOCS / "api" / "c.md").read_text(encoding="utf-8")
    for header in sorted(HEADERS.glob("*.h")):
        if f"{{doxygenfile}} {header.name}\n" not in page:
            log.warning("docs/api/c.md has no doxygenfile of the public header %s", header.name)


def setup(app: Any) -> dict[str, Any]:
    app.connect("source-read", _drop_pending)
    app.connect("source-read", _profile_pages)
    app.connect("builder-inited", _doxygen)
    return {"parallel_read_safe": True}
