"""Identification logs: CSV files with documented columns, read and validated.

Format (one header row of column names, then one row per sample; lines starting with ``#``
are comments; extra columns are ignored):

==========  =======  ==========================================================================
column      unit     meaning
==========  =======  ==========================================================================
t           s        sample time, strictly increasing, uniform sampling (1 kHz typical)
q[1..3]     rad      measured joint positions (encoder), unwrapped
u[1..3]     V        motor voltages commanded to the current inverters (eq 10), not saturated
qd[1..3]    rad/s    optional: measured joint velocities (used only with derivatives="log")
qdd[1..3]   rad/s^2  optional: measured joint accelerations (likewise)
joint       -        friction logs only: the joint (1, 2 or 3) driven at constant velocity in
                     this row while the other two are held still; 0 marks rows to ignore
==========  =======  ==========================================================================

Bounds: a log has at most :data:`MAX_LOG_ROWS` data rows (1000 s at 1 kHz, the longest
experiment of ``rrr identify-experiment``), at most :data:`MAX_LOG_BYTES` bytes and lines of at
most :data:`MAX_LINE_CHARS` characters; it is read in blocks of rows (never whole as text), only
its known columns kept, so reading takes about the memory of those columns as float64 (at most
about 100 MB). A log beyond a bound is refused with the numbers, before or while it is read.
"""

from __future__ import annotations

import csv
import itertools
import logging
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.tables import write_csv
from ..errors import BadInputError

log = logging.getLogger(__name__)

J = fv.JOINTS
REQUIRED = ("t", *fv.names("plant", "q"), *fv.names("plant", "u"))
OPTIONAL = (*fv.names("plant", "qd"), *fv.names("plant", "qdd"), "joint")
MIN_SAMPLES = 200
#: Most data rows of a log, bytes of a log file, and characters of one line.
MAX_LOG_ROWS = 1_000_000
MAX_LOG_BYTES = 400_000_000
MAX_LINE_CHARS = 65_536
_BLOCK_ROWS = 65_536  # rows parsed at a time


@dataclass(frozen=True)
class Log:
    """One experiment: uniformly sampled time, positions and voltages (+ optional columns)."""

    t: FloatArray                      # (n,)
    q: FloatArray                      # (n, 3)
    u: FloatArray                      # (n, 3)
    qd: FloatArray | None = None       # (n, 3) if logged
    qdd: FloatArray | None = None
    joint: np.ndarray | None = None    # (n,) int, friction logs
    source: str = field(default="log", compare=False)

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def select(self, mask: np.ndarray) -> Log:
        """The rows where mask is true (sampling becomes non-uniform only if mask has gaps)."""
        def pick(a: FloatArray | None) -> FloatArray | None:
            return None if a is None else a[mask]

        joint = None if self.joint is None else self.joint[mask]
        return Log(self.t[mask], self.q[mask], self.u[mask], pick(self.qd), pick(self.qdd),
                   joint, self.source)

    def to_csv(self, path: str | Path, comment: str = "") -> None:
        """Write in the documented format (optional columns only if present), atomically."""
        cols: dict[str, FloatArray] = {"t": self.t}
        for name in ("q", "u", "qd", "qdd"):
            arr = getattr(self, name)
            if arr is not None:
                cols |= {n: arr[:, k] for k, n in enumerate(fv.names("plant", name))}
        if self.joint is not None:
            cols["joint"] = self.joint.astype(float)
        write_csv(path, cols, comment)  # complete or not at all; every value exact


def _header(path: Path) -> tuple[list[str], int]:
    _check_size(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            for lineno in itertools.count():
                line = fh.readline(MAX_LINE_CHARS + 1)
                if not line:
                    break
                if len(line) > MAX_LINE_CHARS:
                    raise BadInputError(f"{path}: line {lineno + 1} is longer than "
                                        f"{MAX_LINE_CHARS:,} characters")
                if line.strip() and not line.lstrip().startswith("#"):
                    names = [c.strip() for c in next(csv.reader([line]))]
                    duplicated = sorted(n for n, k in Counter(names).items() if k > 1)
                    if duplicated:
                        raise BadInputError(f"{path}: duplicated column(s) {', '.join(duplicated)}")
                    return names, lineno
    except UnicodeDecodeError as exc:
        raise BadInputError(f"{path}: not a text (CSV) file: {exc}") from exc
    raise BadInputError(f"{path}: no header row (expected columns {', '.join(REQUIRED)})")


def _check_size(path: Path) -> None:
    size = path.stat().st_size
    if size > MAX_LOG_BYTES:
        raise BadInputError(f"log {path} has {size:,} bytes: at most {MAX_LOG_BYTES:,} "
                            f"({MAX_LOG_ROWS:,} rows; decimate or split the log)")


def _parse(lines: list[str], first: int, n_names: int, cols: list[int], path: Path) -> FloatArray:
    """One block of data lines (``first``: the line number of the first) as float64 rows of
    the columns ``cols``."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # a block of comments only
            block = np.loadtxt(lines, delimiter=",", comments="#", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise BadInputError(f"{path}: not a numeric CSV table (lines {first} to "
                            f"{first + len(lines) - 1}): {exc}") from exc
    if block.size == 0:
        return np.empty((0, len(cols)))
    if block.shape[1] != n_names:
        raise BadInputError(f"{path}: {block.shape[1]} values per row but {n_names} columns "
                            f"(lines {first} to {first + len(lines) - 1})")
    out: FloatArray = np.ascontiguousarray(block[:, cols])
    return out


def _read_rows(path: Path, skip: int, names: list[str], cols: list[int]) -> FloatArray:
    """The data rows after the header (line ``skip``), in blocks, within the bounds."""
    _check_size(path)
    blocks: list[FloatArray] = []
    rows = 0
    lineno = 0
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            lines: list[str] = []
            first = 0
            while True:
                line = fh.readline(MAX_LINE_CHARS + 1)
                if line:
                    lineno += 1
                if len(line) > MAX_LINE_CHARS:
                    raise BadInputError(f"{path}: line {lineno} is longer than "
                                        f"{MAX_LINE_CHARS:,} characters")
                if lineno <= skip + 1 and line:
                    continue  # the comments before the header, and the header
                if line:
                    if not lines:
                        first = lineno
                    lines.append(line)
                if len(lines) >= _BLOCK_ROWS or (not line and lines):
                    block = _parse(lines, first, len(names), cols, path)
                    rows += block.shape[0]
                    if rows > MAX_LOG_ROWS:
                        raise BadInputError(f"log {path} has more than {MAX_LOG_ROWS:,} data "
                                            f"rows (at line {lineno}): decimate or split it")
                    blocks.append(block)
                    lines = []
                if not line:
                    break
    except UnicodeDecodeError as exc:
        raise BadInputError(f"{path}: not a text (CSV) file: {exc}") from exc
    if rows == 0:
        raise BadInputError(f"{path}: no data rows after the header")
    return np.concatenate(blocks) if len(blocks) > 1 else blocks[0]


def read_log(path: str | Path, *, friction: bool = False) -> Log:
    """Read and validate a CSV log; BadInputError names the file and the problem."""
    path = Path(path)
    if not path.is_file():
        what = "is a directory, not a CSV file" if path.is_dir() else "does not exist"
        raise BadInputError(f"log {path} {what}")
    names, skip = _header(path)
    need = REQUIRED + (("joint",) if friction else ())
    missing = [c for c in need if c not in names]
    if missing:
        raise BadInputError(f"{path}: missing column(s) {', '.join(missing)} "
                            f"(required: {', '.join(need)})")
    keep = [n for n in names if n in REQUIRED or n in OPTIONAL]
    data = _read_rows(path, skip, names, [names.index(n) for n in keep])
    col = {n: data[:, k] for k, n in enumerate(keep)}

    def stack(s: str) -> FloatArray:
        return np.column_stack([col[n] for n in fv.names("plant", s)])

    def optional(s: str) -> FloatArray | None:
        return stack(s) if all(n in col for n in fv.names("plant", s)) else None

    joint = col["joint"].astype(int) if "joint" in col else None
    return validate(Log(col["t"], stack("q"), stack("u"), optional("qd"), optional("qdd"), joint,
                        str(path)))


def validate(lg: Log) -> Log:
    """Check NaN/Inf, length, monotonic uniform time; raises BadInputError naming the problem."""
    n = len(lg)
    for name in ("t", "q", "u", "qd", "qdd"):
        arr = getattr(lg, name)
        if arr is None:
            continue
        bad = ~np.isfinite(arr).reshape(n, -1).all(axis=1)
        if bad.any():
            rows = np.flatnonzero(bad)
            raise BadInputError(f"{lg.source}: {bad.sum()} row(s) with NaN or Inf in {name} "
                                f"(first at data row {rows[0] + 1}, t = {lg.t[rows[0]]})")
    if n < MIN_SAMPLES:
        raise BadInputError(f"{lg.source}: too short: {n} samples, need at least {MIN_SAMPLES}")
    dt = np.diff(lg.t)
    if np.any(dt <= 0):
        raise BadInputError(f"{lg.source}: time column t is not strictly increasing")
    if not np.allclose(dt, dt[0], rtol=1e-3, atol=1e-9):
        raise BadInputError(f"{lg.source}: non-uniform sampling (dt from {dt.min():.3g} to "
                            f"{dt.max():.3g} s); resample the log first")
    if lg.joint is not None and not np.isin(lg.joint, (0, *J)).all():
        raise BadInputError(f"{lg.source}: column joint must hold 0, 1, 2 or 3")
    return lg
