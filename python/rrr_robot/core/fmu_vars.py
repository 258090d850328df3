"""The FMUs' variables by name, from the C variable tables: no module spells an FMU variable
name, a value reference or the joint numbers by hand.

The three FMUs' model descriptions are generated from their C variable tables
(``fmu/*/config.h`` and ``model.c``, ``fmu/common/rrr_model_vars.h``); ``tools/gen_fmu_vars.py``
reads the packaged FMI 2.0 model descriptions into ``rrr_robot.core._fmu_table``, and
``tests/python/unit/test_fmu_vars.py`` proves that regenerating gives the committed table (FMI 3.0
has the same variables, plus ``time``) and that no module of the package spells an FMU variable
name or ``(1, 2, 3)``.

:func:`names` lists the scalars of a vector ("controller", "q_ref" -> ``q_ref[1]``, ``q_ref[2]``,
``q_ref[3]``; "plant", "tip" -> ``tip.x``, ``tip.y``, ``tip.z``), :func:`variable` and
:func:`value_reference` give one variable's row. :data:`JOINTS` are the joint numbers of the
FMUs' vectors (1-based), :data:`AXES` the components of their tip vectors; :func:`joint_names`
and :func:`axis_names` name columns derived from them (e.g. a sweep's ``rms_u_n[1]``) the same
way.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import BadInputError, RrrError
from ._fmu_table import VARIABLES

__all__ = [
    "AXES",
    "FMUS",
    "JOINTS",
    "FmuVariable",
    "axis_names",
    "group",
    "joint_names",
    "names",
    "value_reference",
    "variable",
    "variables",
]

#: A name: group, then a 1-based index "[i]" / "[i,k]", or a component ".x".
_NAME = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+(?:,\d+)*)\]|\.([A-Za-z_][A-Za-z0-9_]*))?$")


@dataclass(frozen=True)
class FmuVariable:
    """One variable of an FMU's model description."""

    name: str                   # e.g. "q_ref[2]", "tip.x", "lead"
    value_reference: int
    causality: str              # "input", "output", "parameter", ...
    variability: str            # "continuous", "fixed", ...
    type: str                   # "Real", "Boolean", ...
    unit: str                   # "" when it has none
    group: str                  # the name without its index or component: "q_ref", "tip"
    index: str                  # "2", "1,3", "x"; "" for a scalar


def _row(row: tuple[str, int, str, str, str, str]) -> FmuVariable:
    name, vr, causality, variability, typ, unit = row
    m = _NAME.match(name)
    if m is None:
        raise RrrError(f"FMU variable name {name!r} does not follow the naming convention")
    return FmuVariable(name, vr, causality, variability, typ, unit, m[1], m[2] or m[3] or "")


_TABLE: dict[str, tuple[FmuVariable, ...]] = {
    fmu: tuple(_row(r) for r in rows) for fmu, rows in VARIABLES.items()}
_BY_NAME = {fmu: {v.name: v for v in rows} for fmu, rows in _TABLE.items()}
#: The FMUs, by role, in the order of fmu/CMakeLists.txt's RRR_FMU_NAMES (the one list).
FMUS = tuple(_TABLE)


def variables(fmu: str) -> tuple[FmuVariable, ...]:
    """Every variable of one FMU (one of :data:`FMUS`), in model-description order."""
    try:
        return _TABLE[fmu]
    except KeyError:
        raise BadInputError(f"unknown FMU {fmu!r}: expected one of {list(FMUS)}") from None


def variable(fmu: str, name: str) -> FmuVariable:
    """The variable ``name`` of ``fmu`` (BadInputError naming the FMU when it has none)."""
    variables(fmu)  # BadInputError for an unknown FMU
    found = _BY_NAME[fmu].get(name)
    if found is None:
        raise BadInputError(f"the {fmu} FMU has no variable {name!r}")
    return found


def value_reference(fmu: str, name: str) -> int:
    """The value reference of the variable ``name`` of ``fmu``."""
    return variable(fmu, name).value_reference


def group(fmu: str, name: str) -> tuple[FmuVariable, ...]:
    """The scalars of vector ``name`` of ``fmu`` (its variables named ``name[...]`` or
    ``name.<c>``), in model-description order; BadInputError when it has none."""
    found = tuple(v for v in variables(fmu) if v.group == name and v.index)
    if not found:
        raise BadInputError(f"the {fmu} FMU has no vector {name!r}")
    return found


def names(fmu: str, name: str) -> list[str]:
    """The names of the scalars of vector ``name`` of ``fmu``: names("controller", "q_ref") ->
    ["q_ref[1]", "q_ref[2]", "q_ref[3]"], names("plant", "tip") -> ["tip.x", "tip.y", "tip.z"]."""
    return [v.name for v in group(fmu, name)]


def _vectors(digits: bool) -> set[tuple[str, ...]]:
    """The indices of every input and output vector of every FMU indexed by a number (digits)
    or by a component (not digits)."""
    found = set()
    for fmu in FMUS:
        io = [v for v in _TABLE[fmu] if v.index and v.causality in ("input", "output")]
        for g in dict.fromkeys(v.group for v in io):
            index = tuple(v.index for v in io if v.group == g)
            if all(i.isdigit() for i in index) == digits:
                found.add(index)
    return found


def _joints() -> tuple[int, ...]:
    """The joints: the index of every input and output vector of every FMU, the same for all."""
    found = _vectors(digits=True)
    if len(found) != 1:
        raise RrrError(f"the FMUs' joint vectors disagree on the joints: {sorted(found)}")
    joints = tuple(int(i) for i in found.pop())
    if joints != tuple(range(1, len(joints) + 1)):
        raise RrrError(f"the FMUs' joints are not numbered 1..n: {joints}")
    return joints


def _axes() -> tuple[str, ...]:
    """The components of every Cartesian input and output vector, the same for all."""
    found = _vectors(digits=False)
    if len(found) != 1:
        raise RrrError(f"the FMUs' Cartesian vectors disagree on the axes: {sorted(found)}")
    return found.pop()


#: The joints (1-based) as the FMUs number them: the index of each joint vector (q[i], u[i], ...).
JOINTS: tuple[int, ...] = _joints()
#: The components of the FMUs' Cartesian vectors (tip.x, ...; x_ref.x, ...).
AXES: tuple[str, ...] = _axes()


def joint_names(base: str) -> list[str]:
    """``base`` indexed by joint, the FMUs' convention: joint_names("rms_u_n") ->
    ["rms_u_n[1]", "rms_u_n[2]", "rms_u_n[3]"] (for columns derived from the FMUs' vectors)."""
    return [f"{base}[{j}]" for j in JOINTS]


def axis_names(base: str) -> list[str]:
    """``base`` with each axis, the FMUs' convention: axis_names("xd_ref") -> ["xd_ref.x", ...]."""
    return [f"{base}.{a}" for a in AXES]
