"""Checked reading of TOML files (robot files, scenario files), and their writer: one loader and
one set of field checks, so that every reader refuses the same things with the same kind of
message, naming the file, the table and the key (and the index in an array), what was expected
and what was found::

    robot.toml: [control] kp[2] must be a finite number >= 0 and <= 1e6, got "abc"

:func:`load_toml` refuses a file that is missing, larger than :data:`MAX_FILE_BYTES`, not UTF-8,
not TOML or nested deeper than the parser handles. :class:`Document` checks the parsed tables
against a schema: unknown tables and keys are errors that name them and list the allowed ones,
and each value passes a field check (:class:`Number`, :class:`Vector`, :class:`Matrix`,
:class:`Text`, :class:`Flag`, :class:`ScalarOrArray`) that returns it converted (float, tuple of
floats, str, bool). :func:`write_toml` writes tables of scalars and arrays back.
"""

from __future__ import annotations

import itertools
import json
import math
import numbers
import re
import tomllib
from abc import ABC, abstractmethod
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

from ..errors import RrrError

__all__ = [
    "MAX_FILE_BYTES",
    "Document",
    "Field",
    "Flag",
    "Invalid",
    "Matrix",
    "Number",
    "ScalarOrArray",
    "Text",
    "Vector",
    "load_toml",
    "show",
    "write_toml",
]

#: Largest robot or scenario file read, bytes (the default robot file has 4 kB).
MAX_FILE_BYTES = 1_000_000

#: Makes the package's error for a file: (message, source, table, key).
ErrorFactory = Callable[[str, str, str, str], RrrError]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]{1,40}$")


def show(value: Any, depth: int = 0) -> str:
    """A short rendering of a parsed TOML value for a message (strings quoted and cut, long or
    deep arrays summarised, huge integers by their size)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        text = value if len(value) <= 40 else value[:37] + "..."
        return json.dumps(text, ensure_ascii=False)
    if isinstance(value, int):
        if value.bit_length() > 64:
            return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list | tuple):
        if depth >= 2 or len(value) > 8:
            return f"an array of {len(value)}"
        return "[" + ", ".join(show(v, depth + 1) for v in value) + "]"
    if isinstance(value, Mapping):
        return "a table"
    return f"a {type(value).__name__}"


def key_text(key: str) -> str:
    """A key as written in a message: bare, or quoted (and cut) when it is not a bare key."""
    return key if _BARE_KEY.match(key) else show(key)


def _num(x: float) -> str:
    """A bound in a message: 1e6, 0.01, 1e-5."""
    text = f"{x:g}"
    return re.sub(r"e([+-])0*(\d)", lambda m: "e" + ("-" if m.group(1) == "-" else "") + m.group(2),
                  text)


class Invalid(Exception):  # internal signal, converted to the package's error
    """A value that fails its field check: ``index`` ("[2]", "[1,3]" or "") locates it in an
    array, ``requirement`` says what it must be."""

    def __init__(self, requirement: str, value: Any, index: str = "") -> None:
        super().__init__(requirement)
        self.requirement, self.value, self.index = requirement, value, index


class Field(ABC):
    """A field check: ``check(value)`` returns the value converted or raises ``Invalid``."""

    @abstractmethod
    def check(self, value: Any) -> Any:
        """The value converted, or ``Invalid``."""

    @abstractmethod
    def describe(self) -> str:
        """What the field must be, for messages."""


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclass(frozen=True)
class Number(Field):
    """A finite number in [lo, hi] (either end open with lo_open / hi_open; None: unbounded);
    ``integer``: a whole number (an int, or a float with no fraction), returned as int.
    ``extra``: a further test of the converted value (e.g. the C table's range)."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    extra: Callable[[float], bool] | None = None

    def describe(self) -> str:
        what = "a whole number" if self.integer else "a finite number"
        lo, hi = self.lo, self.hi
        if lo is not None and hi is not None and lo == -hi and not self.lo_open:
            return f"{what} of magnitude <= {_num(hi)}"
        parts = []
        if lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {_num(lo)}")
        if hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {_num(hi)}")
        return " ".join([what, " and ".join(parts)]).strip()

    def check(self, value: Any) -> float:
        if not _is_number(value):
            raise Invalid(f"must be {self.describe()}", value)
        try:
            x = float(value)
        except (OverflowError, ValueError, TypeError):
            raise Invalid(f"must be {self.describe()}", value) from None
        ok = math.isfinite(x)
        if ok and self.lo is not None:
            ok = x > self.lo if self.lo_open else x >= self.lo
        if ok and self.hi is not None:
            ok = x < self.hi if self.hi_open else x <= self.hi
        if ok and self.integer:
            ok = x == math.floor(x)
        if ok and self.extra is not None:
            ok = self.extra(x)
        if not ok:
            raise Invalid(f"must be {self.describe()}", value)
        return int(x) if self.integer else x


def _array(value: Any, n: int, what: str) -> Sequence[Any]:
    if not isinstance(value, list | tuple) or len(value) != n:
        raise Invalid(f"must be {what}", value)
    return value


@dataclass(frozen=True)
class Vector(Field):
    """An array of ``n`` numbers, each passing ``elements`` (one check for all, or one per
    element); ``increasing``: strictly increasing ([low, high] with low < high)."""

    n: int
    elements: Number | Sequence[Number]
    increasing: bool = False

    def _element(self, i: int) -> Number:
        return self.elements if isinstance(self.elements, Number) else self.elements[i]

    def describe(self) -> str:
        if self.increasing and self.n == 2:
            return "[low, high], two finite numbers with low < high"
        return f"an array of {self.n} numbers"

    def check(self, value: Any) -> tuple[Any, ...]:
        items = _array(value, self.n, self.describe())
        out = []
        for i, item in enumerate(items):
            try:
                out.append(self._element(i).check(item))
            except Invalid as exc:
                raise Invalid(exc.requirement, item, f"[{i + 1}]") from None
        if self.increasing and any(b <= a for a, b in itertools.pairwise(out)):
            raise Invalid(f"must be {self.describe()}", value)
        return tuple(out)


@dataclass(frozen=True)
class Matrix(Field):
    """An array of ``rows`` arrays of ``cols`` numbers; element (i, k) passes
    ``elements(i, k)`` (0-based); errors locate it as [i,k] (1-based, like the FMU names)."""

    rows: int
    cols: int
    elements: Callable[[int, int], Number]

    def describe(self) -> str:
        return f"an array of {self.rows} arrays of {self.cols} numbers"

    def check(self, value: Any) -> tuple[tuple[float, ...], ...]:
        out = []
        for i, row in enumerate(_array(value, self.rows, self.describe())):
            if not isinstance(row, list | tuple) or len(row) != self.cols:
                raise Invalid(f"must be an array of {self.cols} numbers", row, f"[{i + 1}]")
            cells = []
            for k, item in enumerate(row):
                try:
                    cells.append(self.elements(i, k).check(item))
                except Invalid as exc:
                    raise Invalid(exc.requirement, item, f"[{i + 1},{k + 1}]") from None
            out.append(tuple(cells))
        return tuple(out)


@dataclass(frozen=True)
class ScalarOrArray(Field):
    """One number for every element (``scalar``), or an array with one per element (``array``,
    a :class:`Vector` or :class:`Matrix` whose elements pass the same check): a float or the
    array's tuple."""

    scalar: Number
    array: Vector | Matrix

    def describe(self) -> str:
        return f"{self.scalar.describe()}, or {self.array.describe()}"

    def check(self, value: Any) -> float | tuple[Any, ...]:
        if isinstance(value, list | tuple):
            result: tuple[Any, ...] = self.array.check(value)
            return result
        if not _is_number(value):
            raise Invalid(f"must be {self.describe()}", value)
        return self.scalar.check(value)


@dataclass(frozen=True)
class Text(Field):
    """A string of at most ``max_len`` characters; ``choices``: one of them; ``pattern``: a full
    match; ``nonblank``: not only white space. Control characters are refused."""

    max_len: int = 200
    choices: tuple[str, ...] = ()
    pattern: str = ""
    pattern_text: str = ""
    nonblank: bool = False

    def describe(self) -> str:
        if self.choices:
            return "one of " + ", ".join(json.dumps(c) for c in self.choices)
        if self.pattern_text:
            return self.pattern_text
        return f"a{' non-blank' if self.nonblank else ''} string of at most {self.max_len} " \
               "characters"

    def check(self, value: Any) -> str:
        if not isinstance(value, str):
            raise Invalid(f"must be {self.describe()}", value)
        ok = len(value) <= self.max_len and not any(
            (ord(c) < 32 and c not in "\t\n") or ord(c) == 127 for c in value)
        if ok and self.choices:
            ok = value in self.choices
        if ok and self.pattern:
            ok = re.fullmatch(self.pattern, value) is not None
        if ok and self.nonblank:
            ok = bool(value.strip())
        if not ok:
            raise Invalid(f"must be {self.describe()}", value)
        return value


@dataclass(frozen=True)
class Flag(Field):
    """true or false."""

    def describe(self) -> str:
        return "true or false"

    def check(self, value: Any) -> bool:
        if not isinstance(value, bool):
            raise Invalid(f"must be {self.describe()}", value)
        return value


def load_toml(path: str | Path, what: str, error: ErrorFactory) -> dict[str, Any]:
    """Parse a TOML file; ``what`` ("robot file") names it in messages, ``error`` makes the
    exception. Refuses missing and unreadable files, files over MAX_FILE_BYTES, text that is not
    UTF-8, TOML syntax errors and nesting deeper than the parser handles."""
    path = Path(path)
    src = str(path)
    try:
        if path.is_dir():
            raise error(f"{what} {path} is a directory, not a file", src, "", "")
        with path.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise error(f"{what} {path} does not exist", src, "", "") from None
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc}", src, "", "") from None
    if len(raw) > MAX_FILE_BYTES:
        raise error(f"{path}: malformed {what}: larger than {MAX_FILE_BYTES} bytes (the bound "
                    f"of a {what})", src, "", "")
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise error(f"{path}: malformed {what}: not valid TOML (not UTF-8 text: {exc})",
                    src, "", "") from None
    except RecursionError:
        raise error(f"{path}: malformed {what}: not valid TOML (arrays or tables nested too "
                    "deeply)", src, "", "") from None
    except ValueError as exc:  # TOMLDecodeError, and int literals beyond Python's digit limit
        raise error(f"{path}: malformed {what}: not valid TOML ({exc})", src, "", "") from None


class Document:
    """The parsed tables of one file, checked table by table against field schemas.

    ``source`` names the file in messages, ``what`` says what it is ("robot file"), ``error``
    makes the exception (RobotFileError, ScenarioError)."""

    def __init__(self, data: Any, source: str, what: str, error: ErrorFactory) -> None:
        self.source, self.what, self.error = source, what, error
        if not isinstance(data, Mapping):
            self.fail("", "", f"a {what} must be a mapping of tables, got {show(data)}")
        self.data: Mapping[str, Any] = data

    def fail(self, table: str, key: str, message: str) -> NoReturn:
        """Raise the file's error: ``source: message``."""
        raise self.error(f"{self.source}: {message}", self.source, table, key)

    def only_tables(self, allowed: Collection[str]) -> None:
        """Every top-level entry must be one of the ``allowed`` tables."""
        names = ", ".join(allowed)
        for name, value in self.data.items():
            if not isinstance(name, str) or name not in allowed:
                label = key_text(str(name))
                if isinstance(value, Mapping):
                    self.fail(str(name), "", f"unknown table [{label}] (allowed: {names})")
                self.fail("", str(name), f"unknown key {label} at the top level (a {self.what} "
                          f"has only the tables {names})")
            if not isinstance(value, Mapping):
                self.fail(name, "", f"[{name}] must be a table, got {show(value)}")

    def has(self, table: str) -> bool:
        return table in self.data

    def table(self, name: str, schema: Mapping[str, Field], required: Collection[str] = (),
              *, must_exist: bool = False, hints: Mapping[str, str] | None = None,
              ) -> dict[str, Any] | None:
        """The checked entries of table ``name`` (in schema order), None if it is absent and
        not ``must_exist``. Unknown keys (``hints`` adds a word for some), missing ``required``
        keys and values failing their field check raise the file's error."""
        if name not in self.data:
            if must_exist:
                self.fail(name, "", f"missing table [{name}] (keys: {', '.join(schema)})")
            return None
        entries = self.data[name]
        if not isinstance(entries, Mapping):
            self.fail(name, "", f"[{name}] must be a table, got {show(entries)}")
        for key in entries:
            if key not in schema:
                hint = (hints or {}).get(key, "")
                self.fail(name, str(key), f"unknown key {key_text(str(key))} in [{name}] "
                          f"(allowed: {', '.join(schema)}){hint}")
        missing = [k for k in required if k not in entries]
        if missing:
            self.fail(name, missing[0], f"missing key {missing[0]!r} in [{name}] (required: "
                      f"{', '.join(required)})")
        return {key: self.value(name, key, field, entries[key])
                for key, field in schema.items() if key in entries}

    def value(self, table: str, key: str, field: Field, value: Any) -> Any:
        """``field.check(value)``, with the failure turned into the file's error."""
        try:
            return field.check(value)
        except Invalid as exc:
            self.fail(table, key, f"[{table}] {key}{exc.index} {exc.requirement}, got "
                      f"{show(exc.value)}")


def _fmt(value: Any) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):  # a whole number of the schema (Number(integer=True)): 846
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def write_toml(data: Mapping[str, Mapping[str, Any]], path: Path, header: str = "") -> None:
    """Write a two-level mapping (tables of scalars and arrays) as TOML."""
    lines = [f"# {line}" for line in header.splitlines()]
    for table, entries in data.items():
        lines.append(f"\n[{table}]")
        lines.extend(f"{key} = {_fmt(value)}" for key, value in entries.items())
    path.write_text("\n".join(lines).lstrip("\n") + "\n")
