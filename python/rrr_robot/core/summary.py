"""summary.json, built once for every kind of run: ``rrr writing`` (writing.job), ``rrr
run-ssp`` (ssp.run) and ``rrr hil`` (hil.results).

Every summary has a ``reference`` section (what was run: ``text``, ``duration``, ``step``, and
what the run adds: the writing task's margins, the bench's ``periods``), the sections of its
kind, in the caller's order, and ``files``, last: the result set's files, summary.json
included. The text is strict JSON (a non-finite number is null: :func:`to_strict_json_value`),
written atomically into the result set, whose commit puts summary.json into place after the
other files (core.outputs).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .outputs import ResultSet, atomic_write_text, strict_json, to_strict_json_value

__all__ = ["SUMMARY_FILE", "reference_section", "write_summary"]

#: The summary's file name in a result set.
SUMMARY_FILE = "summary.json"


def reference_section(text: str | None, duration: float, step: float,
                      **extra: Any) -> dict[str, Any]:
    """The ``reference`` section: the written text, the reference's duration and sample step
    (s), then ``extra`` (e.g. ``periods``, the workspace margins)."""
    return {"text": text, "duration": float(duration), "step": float(step), **extra}


def write_summary(rs: ResultSet, sections: Mapping[str, Any]) -> dict[str, Any]:
    """Write summary.json into ``rs``: ``sections`` (which must hold ``reference``; ``files``
    is added, not given), then ``files``. Returns the summary as written (strict JSON values)."""
    if "reference" not in sections:
        raise ValueError("a summary needs its 'reference' section (reference_section)")
    if "files" in sections:
        raise ValueError("'files' is the result set's list: write_summary adds it")
    summary: dict[str, Any] = dict(sections)
    summary["files"] = sorted({*rs.names(), SUMMARY_FILE})
    strict: dict[str, Any] = to_strict_json_value(summary)
    atomic_write_text(rs.path(SUMMARY_FILE), strict_json(strict) + "\n")
    return strict
