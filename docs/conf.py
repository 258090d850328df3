"""Sphinx configuration of the rrr_robot manual (docs/).

Build: ``sphinx-build -W --keep-going -n -b html docs build-docs`` (scripts/run_tests.sh runs
exactly that; ``pip install '.[docs]'`` brings Sphinx, MyST and the theme). Sphinx, because the
Python API page is generated from the docstrings by autodoc; the pages are MyST Markdown.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent


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


def setup(app: Any) -> dict[str, Any]:
    app.connect("source-read", _drop_pending)
    return {"parallel_read_safe": True}
