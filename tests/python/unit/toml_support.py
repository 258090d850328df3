"""Helpers of the robot and scenario file tests: a TOML writer for any value tomllib can give
back (so a test can build hostile files from parsed ones), and hypothesis strategies of such
values."""

from __future__ import annotations

import datetime
import json
from typing import Any

from hypothesis import strategies as st


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # nan, inf, -inf, 1e+300 are TOML floats
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, datetime.date):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def toml_document(doc: dict[str, Any]) -> str:
    """Tables as [name] sections; top-level values (not tables) first, as TOML requires."""
    head, lines = [], []
    for name, table in doc.items():
        if isinstance(table, dict):
            lines.append(f"[{json.dumps(name)}]")
            lines += [f"{json.dumps(k)} = {toml_value(v)}" for k, v in table.items()]
        else:
            head.append(f"{json.dumps(name)} = {toml_value(table)}")
    return "\n".join(head + lines) + "\n"


#: Strings a file can hold (no lone surrogates).
texts = st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=8)
scalars = st.one_of(
    texts, st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True), st.just(10**400), st.just(-(10**400)),
    st.dates(), st.sampled_from([1e300, -1e300, 1e-300, 5e-324, 0.0, -0.0, 1.0, 2, 1e6, 1e6 + 1]),
)
#: Any TOML value: scalars, arrays and inline tables, nested.
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=5), st.dictionaries(st.sampled_from(["a", "b"]), inner, max_size=2)),
    max_leaves=10)
