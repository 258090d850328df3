"""Signal tables (rrr_robot.core.tables): CSV written through numpy with every value exact, the
same table as Parquet (pyarrow) with the same columns and values, both atomic; the writing
task's ``--format csv|parquet``; the identification logs."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from rrr_robot.cli import main
from rrr_robot.core import tables
from rrr_robot.core.tables import read_csv_table, write_csv, write_parquet, write_table
from rrr_robot.errors import BadInputError
from rrr_robot.identify.logs import Log, read_log
from rrr_robot.sim.cosim import CosimResult

pq = pytest.importorskip("pyarrow.parquet")

COSIM_COLUMNS = (
    ["t"]
    + [f"{s}[{i}]" for s in ("q_ref", "qd_ref", "q", "qd", "qdd", "u", "u_n", "u_c")
       for i in (1, 2, 3)]
    + [f"{s}.{a}" for s in ("x_ref", "tip") for a in "xyz"]
)

# values that a short decimal format would not give back: round-off tails, extremes, subnormals,
# signed zero, non-finite
HARD = np.array([0.1, 1 / 3, -2 / 3, np.pi, 1e-300, 5e-324, -0.0, 0.0, 1.7976931348623157e308,
                 -1e-17, 123456789.12345678, 0.30000000000000004, np.nan, np.inf, -np.inf])


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit (NaN equal to NaN, -0.0 different from 0.0)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    return bool(np.all((a.view(np.uint64) == b.view(np.uint64)) | (np.isnan(a) & np.isnan(b))))


def random_result(n: int = 257, seed: int = 0) -> CosimResult:
    rng = np.random.default_rng(seed)

    def block() -> np.ndarray:  # every exponent range, not just numbers near 1
        return rng.standard_normal((n, 3)) * 10.0 ** rng.integers(-12, 12, (n, 3))

    return CosimResult(t=np.arange(n) * 1e-3, q_ref=block(), qd_ref=block(), x_ref=block(),
                       q=block(), qd=block(), qdd=block(), tip=block(), u=block(), u_n=block(),
                       u_c=block(), wall_time=0.01)


def test_csv_values_round_trip_exactly(tmp_path: Path) -> None:
    cols = {"hard": HARD, "random": np.random.default_rng(1).standard_normal(HARD.size) * 1e7}
    path = write_csv(tmp_path / "x.csv", cols, comment="two\nlines")
    text = path.read_text()
    assert text.startswith("# two\n# lines\nhard,random\n")
    back = read_csv_table(path)
    assert list(back) == ["hard", "random"]
    for name, values in cols.items():
        assert same_bits(back[name], values), name


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.integers(1, 40), elements=st.floats(allow_nan=True,
                                                                  allow_infinity=True)))
def test_csv_round_trip_any_float64(tmp_path_factory: pytest.TempPathFactory,
                                    values: np.ndarray) -> None:
    path = tmp_path_factory.mktemp("csv") / "v.csv"
    write_csv(path, {"v": values, "w": values[::-1]})
    back = read_csv_table(path)
    assert same_bits(back["v"], values) and same_bits(back["w"], values[::-1])


def test_csv_long_table_in_blocks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Rows go out in blocks of _BLOCK_ROWS: the block boundaries lose or repeat nothing."""
    monkeypatch.setattr(tables, "_BLOCK_ROWS", 7)
    values = np.random.default_rng(2).standard_normal((100, 3))
    write_csv(tmp_path / "x.csv", {"a": values[:, 0], "b": values[:, 1], "c": values[:, 2]})
    back = read_csv_table(tmp_path / "x.csv")
    assert same_bits(np.column_stack(list(back.values())), values)
    assert len((tmp_path / "x.csv").read_text().splitlines()) == 101


def test_cosim_csv_columns_and_exact_values(tmp_path: Path) -> None:
    res = random_result()
    res.to_csv(tmp_path / "ctc.csv")
    header = (tmp_path / "ctc.csv").read_text().splitlines()[0].split(",")
    assert header == COSIM_COLUMNS
    back = read_csv_table(tmp_path / "ctc.csv")
    for name, values in res.columns().items():
        assert same_bits(back[name], values), name
    assert same_bits(back["q[2]"], res.q[:, 1]) and same_bits(back["tip.z"], res.tip[:, 2])


def test_parquet_has_the_csv_columns_and_values(tmp_path: Path) -> None:
    res = random_result(seed=3)
    res.write(tmp_path / "ctc.csv", "csv")
    res.write(tmp_path / "ctc.parquet", "parquet")
    table = pq.read_table(tmp_path / "ctc.parquet")
    csv_cols = read_csv_table(tmp_path / "ctc.csv")
    assert table.column_names == list(csv_cols) == COSIM_COLUMNS
    assert table.num_rows == res.t.size
    for name in COSIM_COLUMNS:
        assert str(table.schema.field(name).type) == "double"
        assert same_bits(table[name].to_numpy(), csv_cols[name]), name


def test_parquet_keeps_non_finite_values_and_the_comment(tmp_path: Path) -> None:
    write_parquet(tmp_path / "x.parquet", {"v": HARD}, comment="simulated")
    table = pq.read_table(tmp_path / "x.parquet")
    assert same_bits(table["v"].to_numpy(), HARD)
    assert table.schema.metadata[b"comment"] == b"simulated"


def test_tables_are_written_atomically(tmp_path: Path) -> None:
    """Only the finished file appears (no temporary name left behind), and a table that cannot
    be built leaves the previous file as it was."""
    for fmt in ("csv", "parquet"):
        target = tmp_path / f"t.{fmt}"
        target.write_text("previous")
        with pytest.raises(ValueError, match="different lengths"):
            write_table(target, {"a": np.zeros(3), "b": np.zeros(4)}, fmt)
        assert target.read_text() == "previous"
        write_table(target, {"a": np.arange(3.0)}, fmt)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "t.parquet"]


def test_unknown_format_and_missing_pyarrow_are_input_errors(
        monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(BadInputError, match="unknown table format 'xlsx'"):
        tables.check_table_format("xlsx")
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # as if not installed
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(BadInputError, match=r"rrr_robot\[parquet\]"):
        tables.check_table_format("parquet")
    assert tables.check_table_format("csv") == "csv"


def test_identification_log_round_trips_exactly(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    n = 300
    lg = Log(t=np.arange(n) * 1e-3, q=rng.standard_normal((n, 3)) / 3,
             u=rng.standard_normal((n, 3)) * 1e-3, qd=rng.standard_normal((n, 3)) * 1e-9,
             qdd=None, joint=rng.integers(0, 4, n))
    lg.to_csv(tmp_path / "log.csv", "a note")
    back = read_log(tmp_path / "log.csv", friction=True)
    for name in ("t", "q", "u", "qd"):
        assert same_bits(getattr(back, name), getattr(lg, name)), name
    assert back.qdd is None and np.array_equal(back.joint, lg.joint)


def test_rrr_writing_format_parquet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``rrr writing --format parquet``: <scenario>.parquet instead of <scenario>.csv, with the
    same columns and values as the CSV of the same run (the co-simulation is deterministic)."""
    base = ["writing", "--scenario", "ctc", "--no-figures", "--quiet"]
    assert main([*base, "--out", str(tmp_path / "csv")]) == 0
    assert main([*base, "--out", str(tmp_path / "pq"), "--format", "parquet"]) == 0
    assert "<scenario>.parquet" in capsys.readouterr().out
    summary = json.loads((tmp_path / "pq" / "summary.json").read_text())
    assert summary["files"] == ["ctc.parquet", "summary.json"]
    assert sorted(p.name for p in (tmp_path / "pq").iterdir() if not p.name.startswith(".")) \
        == ["ctc.parquet", "summary.json"]
    csv_cols = read_csv_table(tmp_path / "csv" / "ctc.csv")
    table = pq.read_table(tmp_path / "pq" / "ctc.parquet")
    assert table.column_names == list(csv_cols) == COSIM_COLUMNS
    for name in COSIM_COLUMNS:
        assert same_bits(table[name].to_numpy(), csv_cols[name]), name


def test_rrr_writing_parquet_without_pyarrow_fails_before_running(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    out = tmp_path / "out"
    assert main(["writing", "--out", str(out), "--format", "parquet", "--no-figures"]) == 2
    assert "pip install 'rrr_robot[parquet]'" in capsys.readouterr().err
    assert not out.exists()


# ---- the text of the numbers (format_rows) -------------------------------------------------------

def test_format_rows_writes_the_17_digit_text() -> None:
    """The file format: ``%.17g`` of every value, NaN as ``nan`` whatever its sign bit (and
    payload), ``-0`` kept, infinities as ``inf``; ``,`` between values, ``\\n`` after rows."""
    nan_payload = np.frombuffer(b"\x01\x00\x00\x00\x00\x00\xf8\xff", dtype=np.float64)[0]
    assert tables.format_rows(np.array([[np.nan, -np.nan, nan_payload, -0.0, 0.1],
                                        [np.inf, -np.inf, 1e17, 5e-324, 1 / 3]])) == (
        "nan,nan,nan,-0,0.10000000000000001\n"
        "inf,-inf,1e+17,4.9406564584124654e-324,0.33333333333333331\n")
    assert tables.format_rows(np.zeros((0, 4))) == tables.format_rows(np.zeros((5, 0))) == ""


def test_format_rows_refuses_what_is_not_a_table() -> None:
    with pytest.raises(ValueError, match="2-D"):
        tables.format_rows(np.zeros(3))
