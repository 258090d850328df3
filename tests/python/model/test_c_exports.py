"""librrr.so exports exactly the functions its public headers declare (``RRR_API``): every
function of the C API page (docs/api/c.md, Doxygen's reading of the same headers) links, and
nothing else is exported."""

from __future__ import annotations

import re
import shutil
import subprocess

from rrr_robot.core import _lib
from support import REPO

HEADERS = REPO / "c_src" / "rrr" / "include" / "rrr"


def test_librrr_exports_exactly_the_functions_of_its_headers() -> None:
    nm = shutil.which("nm")
    assert nm, "nm (binutils) is needed to list librrr.so's exports"
    out = subprocess.run([nm, "-D", "--defined-only", str(_lib.library_path())], check=True,
                         capture_output=True, text=True).stdout
    exported = {line.split()[-1] for line in out.splitlines()
                if line.split()[-2:-1] == ["T"] and line.split()[-1].startswith("rrr_")}
    declared = set()
    for path in HEADERS.glob("*.h"):
        text = path.read_text(encoding="utf-8")
        declared |= set(re.findall(r"^RRR_API\b[^;(]*?\b(rrr_\w+)\s*\(", text, re.M))
    assert len(exported) > 40
    assert exported == declared, exported ^ declared
