"""The reference table: one format for the reference FMU (``resources/reference.csv`` inside
``rrr_reference.fmu``, fmu/reference/model.c) and the CAN bench's controller node
(``rrr_hil_controller --reference``, c_src/hil/nodes/hil_reference.c, which the LS-BUS
controller FMU reads too), described once in docs/fmus.md
(rrr_reference, "The table").

A CSV of 19 columns, one row per sample, every value with 17 significant digits: ``t`` (s), the
joints' ``q_ref[i]`` (rad), ``qd_ref[i]`` (rad/s), ``qdd_ref[i]`` (rad/s^2), the tip's
``x_ref.x|y|z`` (m), ``xd_ref.*`` (m/s), ``xdd_ref.*`` (m/s^2). The FMU needs the header exactly
in this order; the bench's readers (C and :func:`read_reference_table`) find the columns they
need by name and name a missing one.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.tables import write_csv
from ..errors import BadInputError

__all__ = [
    "JOINT_COLUMNS",
    "REFERENCE_COLUMNS",
    "TIP_COLUMNS",
    "UNITS",
    "read_reference_table",
    "reference_table_columns",
    "write_reference_table",
]

#: t and the joint columns: what the bench's controller node reads (the reference FMU's
#: outputs' names).
JOINT_COLUMNS: tuple[str, ...] = (
    "t", *(n for s in ("q_ref", "qd_ref", "qdd_ref") for n in fv.names("reference", s)))
#: The tip's columns (the reference FMU's x_ref output and its derivatives).
TIP_COLUMNS: tuple[str, ...] = (*fv.names("reference", "x_ref"), *fv.axis_names("xd_ref"),
                                 *fv.axis_names("xdd_ref"))
#: The header of the table, in its order (the reference FMU checks it).
REFERENCE_COLUMNS: tuple[str, ...] = JOINT_COLUMNS + TIP_COLUMNS
#: The unit of each column's group.
UNITS = {"t": "s", "q_ref": "rad", "qd_ref": "rad/s", "qdd_ref": "rad/s2", "x_ref": "m",
         "xd_ref": "m/s", "xdd_ref": "m/s2"}


def reference_table_columns(t: FloatArray, q: FloatArray, qd: FloatArray, qdd: FloatArray,
                            tip: tuple[FloatArray, FloatArray, FloatArray] | None = None,
                            model: Model | None = None) -> dict[str, FloatArray]:
    """The table's columns: t (n,), q, qd, qdd (n, 3) and the tip's x, xd, xdd (n, 3) when
    given (a writing reference's planned path), else the forward kinematics of ``model``
    (default: the default robot) along q."""
    arrays = [np.asarray(a, dtype=np.float64) for a in (q, qd, qdd)]
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    for name, arr in zip(("q", "qd", "qdd"), arrays, strict=True):
        if arr.shape != (t.size, 3):
            raise BadInputError(f"reference table: {name} has the shape {arr.shape}, expected "
                                f"({t.size}, 3) (one row per sample of t)")
    if tip is None:
        m = Model.default() if model is None else model
        # the one-state calls' numbers, as tip_motion's (the batch kernels: within 1e-13 m)
        x = np.asarray(m.fk(arrays[0], simd="scalar")[0], dtype=np.float64).reshape(t.size, 3)
        xd, xdd = m.tip_motion(arrays[0], arrays[1], arrays[2])
        tip = (x, np.asarray(xd, dtype=np.float64).reshape(t.size, 3),
               np.asarray(xdd, dtype=np.float64).reshape(t.size, 3))
    arrays += [np.asarray(a, dtype=np.float64).reshape(t.size, 3) for a in tip]
    cols: dict[str, FloatArray] = {"t": t}
    names = iter(REFERENCE_COLUMNS[1:])
    for arr in arrays:
        for k in range(3):
            cols[next(names)] = arr[:, k]
    return cols


def write_reference_table(path: str | os.PathLike[str], t: FloatArray, q: FloatArray,
                          qd: FloatArray, qdd: FloatArray,
                          tip: tuple[FloatArray, FloatArray, FloatArray] | None = None,
                          model: Model | None = None) -> Path:
    """Write the table (:func:`reference_table_columns`; every float64 exactly), atomically."""
    return write_csv(path, reference_table_columns(t, q, qd, qdd, tip, model))


def read_reference_table(path: str | os.PathLike[str],
                         columns: Sequence[str] = JOINT_COLUMNS) -> dict[str, FloatArray]:
    """The ``columns`` of a reference table, found by name in its header (any order, other
    columns ignored), as name -> float64 array; BadInputError naming the file and the missing
    column, or the line that is not a row of finite numbers."""
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeError) as exc:
        raise BadInputError(f"cannot read the reference table {path}: {exc}") from None
    if not lines:
        raise BadInputError(f"{path}: empty (expected a header naming the columns)")
    header = [h.strip() for h in lines[0].split(",")]
    for name in columns:
        if name not in header:
            raise BadInputError(f"{path}:1: the reference table has no column {name!r} (its "
                                f"columns: {', '.join(REFERENCE_COLUMNS)})")
        if header.count(name) > 1:
            raise BadInputError(f"{path}:1: the column {name!r} appears twice")
    rows = np.zeros((0, len(header)))
    body = [(k, line) for k, line in enumerate(lines[1:], start=2) if line.strip()]
    if body:
        out = np.empty((len(body), len(header)))
        for r, (k, line) in enumerate(body):
            fields = line.split(",")
            if len(fields) != len(header):
                raise BadInputError(f"{path}:{k}: {len(fields)} values, the header has "
                                    f"{len(header)} columns")
            try:
                out[r] = [float(f) for f in fields]
            except ValueError:
                raise BadInputError(f"{path}:{k}: not a row of numbers") from None
            if not np.all(np.isfinite(out[r])):
                c = int(np.flatnonzero(~np.isfinite(out[r]))[0])
                raise BadInputError(f"{path}:{k}: column {header[c]} is not a finite number")
        rows = out
    return {name: rows[:, header.index(name)] for name in columns}
