"""What a sweep can vary: the fields of a scenario, and what a writing job writes, by dotted name.

A key names one field and carries its check, the one the scenario reader (or the robot file's
[writing] table) applies, so a varied value is refused exactly as it would be in a file:

- ``scenario.feedforward`` (true or false);
- ``gains.kp``, ``gains.kd`` (three numbers: the scenario's [gains]);
- ``mismatch.<group>_rel`` for every group of the C parameter table (``mismatch.p_rel``,
  ``mismatch.kt_rel``, ...): one relative error, or (p, kt, f, w, b) one per value;
- ``writing.<field>`` for the fields of a robot file's [writing] table (``writing.text``,
  ``writing.peak_speed``, ``writing.letter_height``, ...) and ``writing.scale``, the factor on
  the letter height of ``rrr writing --scale``.

A key is ``number`` (a scalar value is allowed: ``scalar``; ``shape`` is that of one value per
element, () for a number only), ``text`` or ``flag``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from ..core.checked import Field, Flag, Matrix, Number, ScalarOrArray, Text, Vector
from ..core.robot import WRITING_FIELDS
from ..writing.scenarios import SCHEMA

__all__ = ["SCALE", "Target", "element_checks", "target", "targets"]

#: ``writing.scale``: the factor on the letter height (``rrr writing --scale``).
SCALE = Number(lo=0.0, lo_open=True, hi=10.0)
#: Fields of a scenario that name or describe it, not what it runs.
_NOT_VARIED = {("scenario", "name"), ("scenario", "description")}
#: Fields of [writing] that are notes, not inputs of the writing task.
_IGNORED_WRITING = {"duration_hint"}


@dataclass(frozen=True)
class Target:
    """One field a sweep can vary."""

    key: str                  # "mismatch.p_rel"
    table: str                # "scenario", "gains", "mismatch" or "writing"
    name: str                 # "p_rel"
    field: Field              # the check of one value
    kind: str                 # "number", "text" or "flag"
    scalar: bool              # a single number is a value of the field
    shape: tuple[int, ...]    # the shape of one number per element; () when there is none

    @property
    def size(self) -> int:
        """Numbers per element-wise value (1 for a number only)."""
        n = 1
        for k in self.shape:
            n *= k
        return n

    def describe(self) -> str:
        """What a value must be, for messages."""
        return self.field.describe()


def _target(table: str, name: str, field: Field) -> Target:
    key = f"{table}.{name}"
    if isinstance(field, Flag):
        return Target(key, table, name, field, "flag", False, ())
    if isinstance(field, Text):
        return Target(key, table, name, field, "text", False, ())
    if isinstance(field, Number):
        return Target(key, table, name, field, "number", True, ())
    if isinstance(field, ScalarOrArray):
        return Target(key, table, name, field, "number", True, _shape(field.array))
    if isinstance(field, Vector | Matrix):
        return Target(key, table, name, field, "number", False, _shape(field))
    raise TypeError(f"no sweep target for a {type(field).__name__} field")  # pragma: no cover


def _shape(field: Vector | Matrix) -> tuple[int, ...]:
    return (field.n,) if isinstance(field, Vector) else (field.rows, field.cols)


@cache
def targets() -> Mapping[str, Target]:
    """Every key a sweep can vary, in a stable order (scenario, gains, mismatch, writing)."""
    out: dict[str, Target] = {}
    for table, fields in SCHEMA.items():
        for name, field in fields.items():
            if (table, name) not in _NOT_VARIED:
                t = _target(table, name, field)
                out[t.key] = t
    for name, field in WRITING_FIELDS.items():
        if name not in _IGNORED_WRITING:
            t = _target("writing", name, field)
            out[t.key] = t
    out["writing.scale"] = _target("writing", "scale", SCALE)
    return out


def target(key: str) -> Target | None:
    """The target called ``key``, None when there is none."""
    return targets().get(key)


def element_checks(t: Target) -> list[Number]:
    """The check of each element of an element-wise value (row-major), or of the number."""
    field: Any = t.field
    if isinstance(field, ScalarOrArray):
        field = field.array
    if isinstance(field, Vector):
        return [field.elements if isinstance(field.elements, Number) else field.elements[i]
                for i in range(field.n)]
    if isinstance(field, Matrix):
        return [field.elements(i, k) for i in range(field.rows) for k in range(field.cols)]
    assert isinstance(field, Number)
    return [field]
