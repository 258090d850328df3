"""The runnable blocks of docs/linearization.md and of the partial-derivatives section of
docs/fmu.md: each ```python run``` block runs in a fresh interpreter and must succeed; a
```text output``` block lists lines the block before it prints (in that order)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
FENCE = re.compile(r"^```(\w+) (run|output)\n(.*?)^```$", re.S | re.M)


def blocks(page: str) -> list[tuple[str, str, str]]:
    return [(m.group(1), m.group(2), m.group(3)) for m in FENCE.finditer(
        (DOCS / page).read_text(encoding="utf-8"))]


@pytest.mark.parametrize("page", ["linearization.md", "fmu.md"])
def test_runnable_blocks(page: str, tmp_path: Path) -> None:
    found = blocks(page)
    assert any(marker == "run" for _, marker, _ in found)
    printed = ""
    for lang, marker, text in found:
        if marker == "run":
            assert lang == "python"
            result = subprocess.run([sys.executable, "-c", text], cwd=tmp_path,
                                    capture_output=True, text=True, timeout=300)
            assert result.returncode == 0, result.stdout + result.stderr
            printed = result.stdout + result.stderr
        else:
            lines = iter(printed.splitlines())
            for want in (x.strip() for x in text.splitlines() if x.strip()):
                assert any(line.strip() == want for line in lines), (want, printed)
