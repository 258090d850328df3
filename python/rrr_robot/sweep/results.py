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

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.outputs import atomic_path, is_temporary
from ..errors import BadInputError, one_line
from .runs import METRICS, STATUSES
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
    """The Arrow schema of a sweep's rows (BadInputError when two varied keys are one)."""
    import pyarrow as pa

    keys = [v.key for v in vary]
    if len(set(keys)) != len(keys):
        twice = sorted({k for k in keys if keys.count(k) > 1})
        raise BadInputError(f"the sweep varies {twice[0]} twice")

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


_PART = re.compile(r"^part-(\d{7,})-(\d+)\.parquet$")


def _parts(folder: Path) -> list[Path]:
    """The part files of the dataset ``folder``; BadInputError for anything else in it (a
    folder named like a part, a file that is not one of ours) but the hidden temporary files
    of a write (rrr_robot.core.outputs)."""
    if not folder.exists():
        return []
    if not folder.is_dir():
        raise BadInputError(f"{folder} is not a folder: it must be the dataset folder of this "
                            "sweep's results; move it away or choose another --out")
    parts = []
    for entry in sorted(folder.iterdir()):
        if is_temporary(entry):
            continue
        if _PART.match(entry.name) is None:
            raise BadInputError(f"{entry}: not a part of this sweep's results (part-<first "
                                "run>-<runs>.parquet); move it away")
        if not entry.is_file():
            raise BadInputError(f"{entry} is not a file: a part of the results must be a "
                                "Parquet file; move it away")
        parts.append(entry)
    return parts


def _check_part(part: Path, t: Any, arrow_schema: Any, seeds: Sequence[int] | None) -> None:
    """A part must be this sweep's exactly: its columns and their types, run ids within the
    sweep and as its name says, statuses, and each run's seed."""
    import pyarrow.compute as pc

    if t.schema.names != arrow_schema.names:
        raise BadInputError(f"{part}: its columns are not those of this sweep's spec "
                            f"({', '.join(t.schema.names[:6])}, ...)")
    for f in arrow_schema:
        got = t.schema.field(f.name).type
        if got != f.type:
            raise BadInputError(f"{part}: column {f.name} holds {got}, this sweep's holds "
                                f"{f.type}")
    for name in ("run", "status", "seed"):
        if t.column(name).null_count:
            raise BadInputError(f"{part}: column {name} has empty values")
    if t.num_rows == 0:
        raise BadInputError(f"{part}: no rows")
    runs = t.column("run").to_pylist()
    m = _PART.match(part.name)
    assert m is not None
    if int(m.group(1)) != min(runs) or int(m.group(2)) != len(runs):
        raise BadInputError(f"{part}: holds {len(runs)} runs from run {min(runs)}, its name "
                            "says otherwise (not a part this sweep wrote)")
    if seeds is not None:
        bad = [r for r in runs if not 0 <= r < len(seeds)]
        if bad:
            raise BadInputError(f"{part}: run {bad[0]} is not a run of this sweep (runs 0 to "
                                f"{len(seeds) - 1})")
        wrong = [r for r, sd in zip(runs, t.column("seed").to_pylist(), strict=True)
                 if seeds[r] != sd]
        if wrong:
            raise BadInputError(f"{part}: run {wrong[0]} has the seed of another sweep "
                                "(not this sweep's run)")
    statuses = set(pc.unique(t.column("status")).to_pylist())
    if not statuses <= set(STATUSES):
        odd = sorted(statuses - set(STATUSES))
        raise BadInputError(f"{part}: status {odd[0]!r} is none of {', '.join(STATUSES)}")


def read_results(folder: Path, arrow_schema: Any, seeds: Sequence[int] | None = None) -> Any:
    """The dataset's rows as one pyarrow Table in run order (an empty table when there are
    none). BadInputError naming the part when one is not this sweep's exactly (its columns and
    types, its runs within 0..len(seeds)-1 with their ``seeds``, its statuses) or two parts hold
    the same run."""
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    tables = []
    for part in _parts(folder):
        try:
            t = pq.read_table(part)
        except (OSError, pa.ArrowException) as exc:
            raise BadInputError(f"{part}: not a Parquet file of this sweep: "
                                f"{one_line(exc)}") from exc
        _check_part(part, t, arrow_schema, seeds)
        tables.append(t.cast(arrow_schema))
    if not tables:
        return arrow_schema.empty_table()
    table = pa.concat_tables(tables)
    runs = table.column("run")
    if pc.count_distinct(runs).as_py() != len(runs):
        raise BadInputError(f"{folder}: the same run appears in two part files (not one "
                            "sweep's results)")
    return table.sort_by("run")


def finished_runs(folder: Path, arrow_schema: Any, seeds: Sequence[int] | None = None,
                  ) -> set[int]:
    """The runs already recorded in the dataset ``folder`` (checked as by read_results)."""
    return {int(r) for r in read_results(folder, arrow_schema, seeds).column("run").to_pylist()}
