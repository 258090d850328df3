"""Tables of numbers written fast and exactly, atomically (:mod:`rrr_robot.core.outputs`).

- CSV: one header row of column names (optionally after ``# `` comment lines), then one row per
  sample; every value is formatted by Python's ``%``-formatting with ``%.17g`` (17 significant
  digits: every float64 reads back bit for bit, ``nan`` and ``inf`` included; the decimal point
  is ``.`` whatever the locale), a block of rows per format operation, so a table costs about
  half of what ``csv.writer`` took.
- Parquet (``pip install 'rrr_robot[parquet]'``, pyarrow): the same columns, float64, a comment
  in the schema metadata (key ``comment``); for tools that read columnar files (pandas, polars,
  DuckDB, Arrow) without parsing text.

Both write a temporary file beside the target and rename it into place: a reader sees the old
file or the new one, never a part.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from .outputs import atomic_open, atomic_path

__all__ = [
    "CSV_FLOAT_FORMAT",
    "TABLE_FORMATS",
    "check_table_format",
    "format_rows",
    "read_csv_table",
    "read_table",
    "write_csv",
    "write_parquet",
    "write_table",
]

#: The table formats of :func:`write_table` (also the file suffixes).
TABLE_FORMATS = ("csv", "parquet")
#: printf format of every CSV value: 17 significant digits round-trip every float64 exactly.
CSV_FLOAT_FORMAT = "%.17g"
_BLOCK_ROWS = 4096  # rows per format operation: fast, with bounded memory for long tables


def _stack(columns: Mapping[str, ArrayLike]) -> tuple[list[str], np.ndarray]:
    names = [str(n) for n in columns]
    if not names:
        raise ValueError("a table needs at least one column")
    cols = [np.asarray(c, dtype=np.float64).reshape(-1) for c in columns.values()]
    n = cols[0].size
    bad = [name for name, c in zip(names, cols, strict=True) if c.size != n]
    if bad:
        raise ValueError(f"columns of different lengths: {', '.join(bad)} (expected {n} rows)")
    return names, np.column_stack(cols)


def check_table_format(fmt: str) -> str:
    """``fmt`` if this installation can write it; BadInputError otherwise (before a run)."""
    if fmt not in TABLE_FORMATS:
        raise BadInputError(f"unknown table format {fmt!r}: expected one of "
                            f"{', '.join(TABLE_FORMATS)}")
    if fmt == "parquet":
        _pyarrow()
    return fmt


def _pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise BadInputError("writing Parquet needs pyarrow: pip install 'rrr_robot[parquet]' "
                            f"({exc})") from exc
    return pa, pq


def format_rows(data: np.ndarray) -> str:
    """The rows of a 2-D float64 array as CSV text: every value as ``CSV_FLOAT_FORMAT`` (``%.17g``)
    (NaN as ``nan`` whatever its sign, infinities as ``inf`` and ``-inf``), ``,`` between values,
    a newline after each row."""
    block = np.asarray(data, dtype=np.float64)
    if block.ndim != 2:
        raise ValueError(f"format_rows: a 2-D array expected, got shape {block.shape}")
    if block.size == 0:
        return ""
    row = ",".join([CSV_FLOAT_FORMAT] * block.shape[1]) + "\n"
    # one format operation per block: tolist() gives Python floats, the fast path
    rows: str = (row * block.shape[0]) % tuple(block.ravel().tolist())
    return rows


def write_csv(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike],
              comment: str = "") -> Path:
    """Write ``columns`` (name -> 1-D values, all of one length) as CSV, atomically: ``# ``
    lines of ``comment``, the header row, then the rows with :data:`CSV_FLOAT_FORMAT`
    (:func:`format_rows`)."""
    names, data = _stack(columns)
    header = io.StringIO()
    for line in comment.splitlines():
        header.write(f"# {line}\n")
    csv.writer(header, lineterminator="\n").writerow(names)
    with atomic_open(path, newline="") as fh:  # complete or not at all
        fh.write(header.getvalue())
        for start in range(0, data.shape[0], _BLOCK_ROWS):
            fh.write(format_rows(data[start:start + _BLOCK_ROWS]))
    return Path(path)


def write_parquet(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike],
                  comment: str = "") -> Path:
    """Write ``columns`` as a Parquet file (float64 columns, ``comment`` in the schema's
    metadata), atomically. Needs pyarrow (BadInputError without it)."""
    pa, pq = _pyarrow()
    names, data = _stack(columns)
    table = pa.table({name: data[:, k] for k, name in enumerate(names)})
    if comment:
        table = table.replace_schema_metadata({"comment": comment})
    with atomic_path(path) as tmp:  # the name ends in .part: pyarrow is told nothing by it
        pq.write_table(table, str(tmp))
    return Path(path)


def write_table(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike],
                fmt: str = "csv", comment: str = "") -> Path:
    """Write ``columns`` in the table format ``fmt`` (:data:`TABLE_FORMATS`)."""
    check_table_format(fmt)
    writer = write_parquet if fmt == "parquet" else write_csv
    return writer(path, columns, comment)


def read_csv_table(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """A CSV written by :func:`write_csv` as name -> float64 column (``#`` lines skipped)."""
    with open(path, newline="", encoding="utf-8") as fh:
        skip = 0
        for line in fh:
            if not line.startswith("#"):
                names = next(csv.reader([line]))
                break
            skip += 1
        else:
            raise BadInputError(f"{path}: no header row")
    data = np.loadtxt(path, delimiter=",", skiprows=skip + 1, ndmin=2, dtype=np.float64)
    if data.size == 0:
        data = data.reshape(0, len(names))
    return {name: data[:, k] for k, name in enumerate(names)}


def read_table(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """A table written by ``write_table``, by its suffix (``.parquet``: pyarrow; otherwise
    CSV), as name -> float64 column; BadInputError for a file that is not such a table."""
    if Path(path).suffix == ".parquet":
        _, pq = _pyarrow()
        try:
            table = pq.read_table(str(path))
        except (OSError, ValueError) as exc:
            raise BadInputError(f"{path}: not a Parquet table ({exc})") from None
        return {name: table.column(name).to_numpy().astype(np.float64)
                for name in table.column_names}
    try:
        return read_csv_table(path)
    except ValueError as exc:
        raise BadInputError(f"{path}: not a table of numbers ({exc})") from None
