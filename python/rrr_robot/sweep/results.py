"""The results of a sweep: ``DIR/results.parquet``, a Parquet dataset folder that grows by one
part file per finished batch, each written atomically (a temporary hidden name, then a rename:
rrr_robot.core.outputs), so a crash keeps every finished batch and never leaves a part that
looks complete. ``pandas.read_parquet(DIR / "results.parquet")`` (or pyarrow, polars, DuckDB)
reads the folder as one table; readers skip the hidden temporary files.

One row per run: ``run`` (int64), ``seed`` (int64), ``status``, ``error`` (strings; error null
when the run ran), one column per varied key named as the key (float64 for a number, a list of
float64 for an array, a list of lists for a matrix, string for text, bool for a flag), then
:data:`~rrr_robot.sweep.runs.METRICS` (float64, null when not finite or not run). Part files are
named ``part-<first run>-<runs>.parquet`` (runs of a part are consecutive in run order only
within a batch); sort by ``run`` to get the run order.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.outputs import atomic_path
from ..errors import BadInputError
from .runs import METRICS
from .spec import Vary

__all__ = ["RESULTS", "finished_runs", "read_results", "schema", "write_part"]

#: The dataset folder in the sweep's output folder.
RESULTS = "results.parquet"


def _key_type(v: Vary) -> Any:
    import pyarrow as pa

    t = v.target
    if t.kind == "text":
        return pa.string()
    if t.kind == "flag":
        return pa.bool_()
    array = v.dist.per_element or (v.dist.kind == "values" and isinstance(v.dist.values[0], tuple))
    if not array:
        return pa.float64()
    if len(t.shape) == 2:
        return pa.list_(pa.list_(pa.float64()))
    return pa.list_(pa.float64())


def schema(vary: Sequence[Vary]) -> Any:
    """The Arrow schema of a sweep's rows."""
    import pyarrow as pa

    fields = [pa.field("run", pa.int64(), nullable=False), pa.field("seed", pa.int64()),
              pa.field("status", pa.string(), nullable=False), pa.field("error", pa.string())]
    fields += [pa.field(v.key, _key_type(v)) for v in vary]
    fields += [pa.field(m, pa.float64()) for m in METRICS]
    return pa.schema(fields)


def _plain(value: Any) -> Any:
    return [_plain(v) for v in value] if isinstance(value, tuple | list) else value


def write_part(folder: Path, rows: Sequence[dict[str, Any]], arrow_schema: Any) -> Path:
    """Write a batch's rows as one part file of the dataset ``folder`` (created if needed),
    atomically; returns its path."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not rows:
        raise ValueError("write_part: no rows")
    folder.mkdir(parents=True, exist_ok=True)
    columns = {name: [_plain(r[name]) for r in rows] for name in arrow_schema.names}
    table = pa.table(columns, schema=arrow_schema)
    first = min(int(r["run"]) for r in rows)
    path = folder / f"part-{first:07d}-{len(rows)}.parquet"
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return path


def _parts(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("part-*.parquet") if p.is_file())


def read_results(folder: Path, arrow_schema: Any) -> Any:
    """The dataset's rows as one pyarrow Table in run order (an empty table when there are
    none). BadInputError when a part does not have the sweep's columns or two parts hold the
    same run (not the results of this sweep)."""
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    tables = []
    for part in _parts(folder):
        try:
            t = pq.read_table(part)
        except (OSError, pa.ArrowException) as exc:
            raise BadInputError(f"{part}: not a Parquet file of this sweep: {exc}") from exc
        if t.schema.names != arrow_schema.names:
            raise BadInputError(f"{part}: its columns are not those of this sweep's spec "
                                f"({', '.join(t.schema.names[:6])}, ...)")
        tables.append(t.cast(arrow_schema))
    if not tables:
        return arrow_schema.empty_table()
    table = pa.concat_tables(tables)
    runs = table.column("run")
    if pc.count_distinct(runs).as_py() != len(runs):
        raise BadInputError(f"{folder}: the same run appears in two part files (not one "
                            "sweep's results)")
    return table.sort_by("run")


def finished_runs(folder: Path, arrow_schema: Any) -> set[int]:
    """The runs already recorded in the dataset ``folder``."""
    if not folder.is_dir():
        return set()
    return {int(r) for r in read_results(folder, arrow_schema).column("run").to_pylist()}
