"""The CSV logs of the CAN bench's nodes, specified once: every column's name, unit and meaning,
in order, for the controller log (``rrr_hil_controller --log``, and the Python side's
:func:`~rrr_robot.hil.results.write_controller_log`), the plant log (``rrr_hil_plant --log``
and :class:`~rrr_robot.hil.dbc.plant.PythonPlant`) and the latency log (``--latency-log`` of
both nodes).

The C nodes write the headers of c_src/hil/nodes/gen/rrr_hil_logs.h, GENERATED from this table by
tools/gen_hil_logs.py (tests/python/model/test_generated_code.py proves that regenerating gives the
committed header); every Python reader goes through :func:`read_log`, which checks the header
against the table, so a column added, removed or moved on one side is an error on the other,
not a silently shifted signal. (The frame log is binary: rrr_robot.hil.logs.frames.)

A log is a header row, then one row of numbers per period, every double with 17 significant
digits.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core import fmu_vars as fv
from ...core._arrays import FloatArray
from ...core.outputs import atomic_open
from ...errors import HilError, one_line

__all__ = [
    "CONTROLLER_LOG",
    "LATENCY_LOG",
    "LOGS",
    "PLANT_LOG",
    "Column",
    "LogSpec",
    "NodeLog",
    "parse_log",
    "read_log",
    "write_log",
]

_J = fv.JOINTS


@dataclass(frozen=True)
class Column:
    """One column of a node log."""

    name: str
    unit: str      # "" for a count or a flag
    meaning: str


@dataclass(frozen=True)
class LogSpec:
    """A node log: its name (also the C macros' prefix), what writes it and its columns."""

    name: str
    written_by: str
    columns: tuple[Column, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The column names, in order."""
        return tuple(c.name for c in self.columns)

    @property
    def header(self) -> str:
        """The header row, without the line end."""
        return ",".join(self.names)

    def index(self, name: str) -> int:
        """The position of the column ``name`` (ValueError naming the log otherwise)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise ValueError(f"the {self.name} log has no column {name!r}") from None

    def indices(self, names: Iterable[str]) -> list[int]:
        """The positions of the columns ``names``."""
        return [self.index(n) for n in names]


def _joints(group: str, unit: str, meaning: str) -> list[Column]:
    return [Column(name, unit, f"{meaning}, joint {i}")
            for i, name in zip(_J, fv.joint_names(group), strict=True)]


_K = Column("k", "", "control period, from 0")
#: rrr_hil_controller --log (and write_controller_log): one row per period k.
CONTROLLER_LOG = LogSpec("controller",
                         "rrr_hil_controller --log; hil.results.write_controller_log", (
    _K,
    Column("t", "s", "reference time of the period"),
    *_joints("q", "rad", "measured joint angle (JointState)"),
    *_joints("qd", "rad/s", "measured joint velocity (JointState)"),
    *(c for i, u, u_n, u_c in zip(_J, fv.joint_names("u"), fv.joint_names("u_n"),
                                  fv.joint_names("u_c"), strict=True) for c in (
        Column(u, "V", f"commanded voltage (saturated), joint {i}"),
        Column(u_n, "V", f"feedforward of eq 15, joint {i}"),
        Column(u_c, "V", f"PD part of eq 15, joint {i}"))),
    Column("enable", "", "1 when the command enabled the drives"),
))
#: rrr_hil_plant --log (and PythonPlant): row 0 is the initial state, row k + 1 the state after
#: period k with the voltage applied during period k.
PLANT_LOG = LogSpec("plant", "rrr_hil_plant --log; hil.dbc.plant.PythonPlant", (
    _K,
    Column("t", "s", "plant FMU time"),
    *_joints("q", "rad", "joint angle"),
    *_joints("qd", "rad/s", "joint velocity"),
    *_joints("u", "V", "voltage applied during the period"),
    Column("zero", "", "1 when the supervisor applied zero voltage"),
    Column("faults", "", "the supervisor's fault count so far"),
    *_joints("qdd", "rad/s2", "joint acceleration (plant FMU output)"),
    *(Column(name, "m", f"tip position {a} (plant FMU output)")
      for a, name in zip(fv.AXES, fv.axis_names("tip"), strict=True)),
))
#: --latency-log of both nodes (real time): one row per period.
LATENCY_LOG = LogSpec("latency", "rrr_hil_controller / rrr_hil_plant --latency-log", (
    _K,
    Column("latency_ns", "ns", "wake-up latency after the period's release"),
    Column("work_ns", "ns", "time the period's work took (-1: not measured)"),
))
#: Every CSV node log, by name.
LOGS = {spec.name: spec for spec in (CONTROLLER_LOG, PLANT_LOG, LATENCY_LOG)}


@dataclass(frozen=True)
class NodeLog:
    """The rows of a node log, with its spec to find columns by name."""

    spec: LogSpec
    rows: FloatArray

    def col(self, name: str) -> FloatArray:
        """One column, (n,)."""
        return self.rows[:, self.spec.index(name)]

    def cols(self, names: Sequence[str]) -> FloatArray:
        """Several columns, (n, len(names))."""
        return self.rows[:, self.spec.indices(names)]

    def group(self, group: str) -> FloatArray:
        """The three columns group[1..3] (joints) or group.x|y|z (tip), (n, 3)."""
        names = [n for n in self.spec.names if n.startswith((f"{group}[", f"{group}."))]
        if not names:
            raise ValueError(f"the {self.spec.name} log has no columns {group}[i] or {group}.x")
        return self.cols(names)


def parse_log(text: str, path: str | os.PathLike[str],
              spec: LogSpec | None = None) -> FloatArray:
    """The rows of a node log's text (a header row, then rows of numbers): with ``spec`` the
    header must be the spec's and every row have its columns. HilError naming the file when it
    is not numeric, has the wrong header or columns, or is cut short (a node that died while
    writing it)."""
    lines = text.splitlines()
    if spec is not None:
        got = lines[0].strip().split(",") if lines else []
        if tuple(got) != spec.names:
            pairs = enumerate(zip(got, spec.names, strict=False))
            where = next((k for k, (a, b) in pairs if a != b), min(len(got), len(spec.names)))
            found = f"'{got[where]}'" if where < len(got) else "nothing"
            want = f"'{spec.names[where]}'" if where < len(spec.names) else "nothing"
            raise HilError(f"the node log {path} is not a {spec.name} log: its column "
                           f"{where + 1} is {found}, the {spec.name} log has {want} there "
                           f"(rrr_robot.hil.logs.specs: {spec.header})")
    body = lines[1:]
    if body and not text.endswith("\n"):
        raise HilError(f"the node log {path} is cut short (its last line is incomplete: the "
                       "node ended while writing it)")
    width = len(spec.columns) if spec is not None else 0
    try:
        rows = np.loadtxt(body, delimiter=",", ndmin=2, dtype=np.float64) if body else \
            np.zeros((0, width))
    except ValueError as exc:
        raise HilError(f"the node log {path} is not a table of numbers: "
                       f"{one_line(exc)}") from exc
    if spec is not None and rows.size and rows.shape[1] != width:
        raise HilError(f"the node log {path} has {rows.shape[1]} columns, expected {width} "
                       f"(the {spec.name} log)")
    return rows


def read_log(path: str | os.PathLike[str], spec: LogSpec) -> NodeLog:
    """A node log written by a C node or the Python side, checked against ``spec``."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeError) as exc:
        raise HilError(f"cannot read the node log {path}: {exc}") from exc
    return NodeLog(spec, parse_log(text, path, spec))


def write_log(path: str | os.PathLike[str], spec: LogSpec, rows: FloatArray) -> Path:
    """Write rows (n, len(spec.columns)) as the log ``spec`` (every double exactly),
    atomically."""
    rows = np.asarray(rows, dtype=np.float64)
    if rows.ndim != 2 or rows.shape[1] != len(spec.columns):
        raise ValueError(f"the {spec.name} log has {len(spec.columns)} columns, got rows of "
                         f"shape {rows.shape}")
    with atomic_open(path) as fh:
        fh.write(spec.header + "\n")
        np.savetxt(fh, rows, delimiter=",", fmt="%.17g")
    return Path(path)
