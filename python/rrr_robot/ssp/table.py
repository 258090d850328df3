"""The reference FMU's table (``resources/reference.csv`` inside ``rrr_reference.fmu``): the
writing task's sampled reference, one row per sample, the columns below.

The tip reference is written here, not computed in the FMU: it is the path the writing task
plans (the letters' curve, of which the joint reference is the closed-form IK), the one
``rrr writing`` measures the tip error against, with its exact velocity and acceleration for the
FMU's interpolation. The FMU then needs no robot parameters (no forward kinematics), so a robot
file never has to be kept equal in two FMUs for the tip reference to be right.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..core._arrays import FloatArray
from ..core.tables import write_csv
from ..writing.reference_table import REFERENCE_COLUMNS
from ..writing.trajectory import Reference

__all__ = [
    "TABLE_COLUMNS",
    "TABLE_FILE",
    "placeholder_columns",
    "reference_columns",
    "write_reference_table",
]

#: The table's file name in the FMU's resources/ folder (REF_TABLE_FILE in fmu/reference).
TABLE_FILE = "reference.csv"

#: The header of the table, in its order (the FMU checks it: fmu/reference/model.c): t, the
#: reference FMU's joint outputs, its tip output x_ref and the tip's velocity and acceleration.
TABLE_COLUMNS = REFERENCE_COLUMNS  # one format: rrr_robot.writing.reference_table


def reference_columns(ref: Reference) -> dict[str, FloatArray]:
    """The table's columns of a writing reference: t, q, qd, qdd of the joints, x, xd, xdd of the
    tip (SI units, rad)."""
    arrays = (ref.q, ref.qd, ref.qdd, ref.x, ref.xd, ref.xdd)
    cols: dict[str, FloatArray] = {"t": ref.t}
    names = iter(TABLE_COLUMNS[1:])
    for arr in arrays:
        for k in range(3):
            cols[next(names)] = arr[:, k]
    return cols


def write_reference_table(path: str | os.PathLike[str], ref: Reference) -> Path:
    """Write the table of ``ref`` (every value with 17 significant digits: the FMU reads back the
    float64 samples bit for bit), atomically."""
    return write_csv(path, reference_columns(ref))


def placeholder_columns(ref: Reference, duration: float = 1.0) -> dict[str, FloatArray]:
    """The table the packaged reference FMU ships (fmu/reference/resources/reference.csv, written
    by tools/make_reference_table.py): the first sample of ``ref`` (the default writing task's
    start pose and tip position) held at rest from t = 0 to ``duration``, so that the FMU on its
    own simulates its default experiment; ``rrr ssp`` replaces it with the whole reference."""
    cols = reference_columns(ref)
    out: dict[str, FloatArray] = {"t": np.array([0.0, duration])}
    for name in TABLE_COLUMNS[1:]:
        at_rest = name.startswith(("qd", "xd"))  # qd_ref, qdd_ref, xd_ref, xdd_ref
        out[name] = np.zeros(2) if at_rest else np.full(2, cols[name][0])
    return out
