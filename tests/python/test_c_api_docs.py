"""The C API pages (docs/api/c.md, docs/api/c/*.md) are generated from librrr's public headers
by tools/gen_c_api.py: regenerating gives the committed pages, every declaration has a comment,
every function librrr.so exports is on its header's page (and nothing that it does not export),
and the generator refuses a declaration without a comment."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from rrr_robot.core import _lib

REPO = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("gen_c_api", REPO / "tools" / "gen_c_api.py")
assert spec is not None and spec.loader is not None
gen = importlib.util.module_from_spec(spec)
sys.modules["gen_c_api"] = gen
spec.loader.exec_module(gen)

HEADERS = gen.public_headers()


def test_regenerating_gives_the_committed_pages():
    result = subprocess.run([sys.executable, str(REPO / "tools" / "gen_c_api.py"), "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_every_installed_header_has_a_page():
    installed = sorted(p.name for p in (REPO / "c_src/rrr/include/rrr").glob("*.h"))
    assert sorted(h.name for h in HEADERS) == installed
    pages = sorted(p.stem for p in (REPO / "docs/api/c").glob("*.md"))
    assert pages == sorted(Path(n).stem for n in installed)
    index = (REPO / "docs/api/c.md").read_text(encoding="utf-8")
    for h in HEADERS:
        assert f"c/{h.path.stem}\n" in index  # in the index's toctree


def test_every_declaration_is_documented_on_its_page():
    for h in HEADERS:
        assert h.missing == [], h.missing
        assert h.doc.brief, h.name
        page = (REPO / "docs/api/c" / f"{h.path.stem}.md").read_text(encoding="utf-8")
        for item in h.items:
            assert item.doc is not None and item.doc.brief, (h.name, item.name)
            assert f"({gen.label(item)})=\n### `{item.name}`" in page, item.name
            for decl, comment in item.members:
                assert comment, (item.name, decl)
                assert f"| `{decl}` |" in page


def _header_functions() -> set[str]:
    """The RRR_API declarations of the headers, read by a regex independent of the generator."""
    names = set()
    for path in (REPO / "c_src/rrr/include/rrr").glob("*.h"):
        text = path.read_text(encoding="utf-8")
        names |= set(re.findall(r"^RRR_API\b[^;(]*?\b(rrr_\w+)\s*\(", text, re.M))
    return names


def test_the_pages_hold_exactly_the_functions_librrr_exports():
    nm = shutil.which("nm")
    assert nm, "nm (binutils) is needed to list librrr.so's exports"
    out = subprocess.run([nm, "-D", "--defined-only", str(_lib.library_path())], check=True,
                         capture_output=True, text=True).stdout
    exported = {line.split()[-1] for line in out.splitlines()
                if line.split()[-2:-1] == ["T"] and line.split()[-1].startswith("rrr_")}
    documented = {i.name for h in HEADERS for i in h.items if i.kind == "function"}
    assert len(exported) > 40
    assert documented == exported, (documented ^ exported)
    assert _header_functions() == documented


def test_every_type_and_macro_of_the_headers_is_on_a_page():
    text = "\n".join(p.read_text(encoding="utf-8")
                     for p in (REPO / "c_src/rrr/include/rrr").glob("*.h"))
    types = set(re.findall(r"^\}\s*(rrr_\w+)\s*;", text, re.M))
    macros = set(re.findall(r"^#define\s+(RRR_\w+)", text, re.M)) - {
        m for m in re.findall(r"^#ifndef\s+(RRR_\w*H)$", text, re.M)}
    documented = {i.name for h in HEADERS for i in h.items}
    assert types and types <= documented, types - documented
    assert macros and macros <= documented, macros - documented


@pytest.mark.parametrize(("source", "missing"), [
    ("RRR_API int rrr_x(void);\n", "function rrr_x"),
    ("/** @brief A. */\ntypedef struct rrr_s {\n    int a;\n} rrr_s;\n", "int a"),
    ("#define RRR_N 3\n", "macro RRR_N"),
    ("typedef struct rrr_t {\n    int a; ///< a\n} rrr_t;\n", "type rrr_t"),
])
def test_an_undocumented_declaration_is_named(tmp_path, source, missing):
    header = tmp_path / "rrr_bad.h"
    header.write_text(f"/** @file rrr_bad.h\n * @brief Bad. */\n#ifndef RRR_BAD_H\n"
                      f"#define RRR_BAD_H\n{source}#endif\n", encoding="utf-8")
    gen.ROOT = tmp_path  # rel paths in the messages
    try:
        found = gen.parse_header(header).missing
    finally:
        gen.ROOT = REPO
    assert len(found) == 1 and found[0].endswith(missing), found


def test_markdown_characters_of_a_comment_mean_themselves():
    assert gen.md("|q_i| <= pi * 2, `a_b*c`") == r"\|q\_i\| \<= pi \* 2, `a_b*c`"
