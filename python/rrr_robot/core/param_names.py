"""The model's parameters by name, from the C parameter table (``rrr_params.h``, exported by
librrr as ``rrr_param_table``): the names are the FMU variable names ("d1", "p[3]", "kt[2]",
"f[1,3]", "u_max"), the same for plant and controller, and none is spelled here by hand.

:data:`PARAMS` holds the rows in table order (the order of the FMU value references);
:func:`group_names` lists the scalars of one group ("p" -> "p[1]" ... "p[16]"), :func:`values`
reads a model's parameters under their names and :func:`set_values` writes them.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

from ..errors import BadInputError, RrrError
from . import _lib

__all__ = [
    "GROUPS",
    "PARAMS",
    "ParamInfo",
    "group_names",
    "group_shape",
    "model_fmu_values",
    "param",
    "param_index",
    "set_values",
    "values",
]

_NAME = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)(?:,(\d+))?\])?$")
_BOUND_TEXT = {_lib.PARAM_ANY: "", _lib.PARAM_NONNEG: ">= 0", _lib.PARAM_POS: "> 0"}


@dataclass(frozen=True)
class ParamInfo:
    """One row of the C parameter table."""

    row: int                    # index in the table (rrr_param_get/set)
    name: str                   # FMU variable name, e.g. "f[2,3]"
    unit: str                   # FMU unit, e.g. "kg.m2"
    bound: int                  # rrr_param_bound: _lib.PARAM_ANY, PARAM_NONNEG or PARAM_POS
    description: str
    group: str                  # the name without its index: "f"
    index: tuple[int, ...]      # 1-based index within the group: (2, 3); () for a scalar

    @property
    def bound_text(self) -> str:
        """The lower bound as text: "", ">= 0" or "> 0"."""
        return _BOUND_TEXT.get(self.bound, "")

    def in_range(self, value: float) -> bool:
        """Finite and within the lower bound (``rrr_param_in_range``)."""
        return _lib.param_in_range(self.row, value)


def _load() -> tuple[ParamInfo, ...]:
    rows = []
    for i, (name, unit, bound, description) in enumerate(_lib.param_table()):
        m = _NAME.match(name)
        if m is None:  # a C table row this module cannot split: a build mismatch
            raise RrrError(f"librrr's parameter table has an unexpected name {name!r}")
        index = tuple(int(g) for g in m.groups()[1:] if g is not None)
        rows.append(ParamInfo(i, name, unit, bound, description, m.group(1), index))
    return tuple(rows)


#: Every scalar parameter of the model, in the C table's order.
PARAMS: tuple[ParamInfo, ...] = _load()
_BY_NAME = {p.name: p for p in PARAMS}
#: The groups in table order: "d1", "a2", ..., "g", "p", "kt", "f", "w", "b", "u_max".
GROUPS: tuple[str, ...] = tuple(dict.fromkeys(p.group for p in PARAMS))


def param_index(name: str) -> int:
    """Row of ``name`` in the C table (``rrr_param_index``), -1 when there is none."""
    if "\0" in name:
        return -1
    return _lib.param_index(name)


def param(name: str) -> ParamInfo:
    """The row called ``name``; BadInputError naming the known groups if there is none."""
    row = param_index(name)
    if row < 0:
        raise BadInputError(f"unknown model parameter {name!r} (parameters: "
                            f"{', '.join(GROUPS)}, with indices as in p[3] or f[1,3])")
    return PARAMS[row]


def group_names(group: str) -> list[str]:
    """The names of one group's scalars in table order ("kt" -> ["kt[1]", "kt[2]", "kt[3]"])."""
    return [p.name for p in PARAMS if p.group == group]


def group_shape(group: str) -> tuple[int, ...]:
    """The array shape of a group: () for a scalar, (16,) for p, (3, 3) for f."""
    rows = [p for p in PARAMS if p.group == group]
    if not rows:
        raise BadInputError(f"unknown parameter group {group!r} (groups: {', '.join(GROUPS)})")
    return tuple(max(p.index[k] for p in rows) for k in range(len(rows[0].index)))


class _HasRaw(Protocol):
    @property
    def raw(self) -> _lib.RawModel: ...


def values(raw: _lib.RawModel) -> dict[str, float]:
    """Every parameter of a C model struct under its name, in table order."""
    return {p.name: _lib.param_get(raw, p.row) for p in PARAMS}


def set_values(raw: _lib.RawModel, changes: Mapping[str, float]) -> _lib.RawModel:
    """A copy of ``raw`` with the named parameters replaced (not validated: Model(raw) does);
    BadInputError for an unknown name or a non-finite value."""
    out = copy.deepcopy(raw)
    for name, value in changes.items():
        info = param(name)
        try:
            _lib.param_set(out, info.row, value)
        except BadInputError as exc:
            raise BadInputError(f"{name} must be a finite number, got {value!r}") from exc
    return out


def model_fmu_values(model: _HasRaw) -> dict[str, float]:
    """The model's parameters under the FMUs' variable names (same for plant and controller)."""
    return values(model.raw)
