"""One format per file: the reference table the reference FMU and the bench read, the node logs'
column spec (rrr_robot.hil.logs.specs) that the C writers' generated header and every Python
reader share, and the one builder of summary.json.

The bus tests read the logs the C nodes wrote through the spec (test_hil_results.py,
test_hil_bench.py, test_hil_faults.py); test_generated_code.py proves the C header is the
spec's; the C reader of the reference table is tested in tests/c/test_hil_rt.c.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.core.model import Model
from rrr_robot.errors import BadInputError, HilError
from rrr_robot.hil.logs.specs import CONTROLLER_LOG, LATENCY_LOG, PLANT_LOG, read_log, write_log
from rrr_robot.hil.nodes import PERIOD, export_reference
from rrr_robot.hil.results import BenchRun, write_controller_log
from rrr_robot.ssp.table import TABLE_COLUMNS
from rrr_robot.writing.reference_table import (
    JOINT_COLUMNS,
    REFERENCE_COLUMNS,
    read_reference_table,
)
from support import REPO

ROOT = REPO
PACKAGED_TABLE = ROOT / "fmu" / "reference" / "resources" / "reference.csv"


# ---- the reference table ---------------------------------------------------------------------


def test_one_reference_format_for_the_fmu_and_the_bench() -> None:
    # the header the reference FMU checks (ssp.table) is the one the bench writes and reads
    assert REFERENCE_COLUMNS == TABLE_COLUMNS and len(REFERENCE_COLUMNS) == 19
    assert REFERENCE_COLUMNS[:10] == JOINT_COLUMNS
    header = PACKAGED_TABLE.read_text(encoding="utf-8").splitlines()[0]
    assert tuple(header.split(",")) == REFERENCE_COLUMNS
    table = read_reference_table(PACKAGED_TABLE, REFERENCE_COLUMNS)
    assert table["t"].tolist() == [0.0, 1.0]


def _motion(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) * PERIOD
    w = 2.0 * np.pi
    q = np.column_stack([0.3 * np.sin(w * t), 0.8 + 0.1 * np.cos(w * t), -1.2 + 0.05 * t])
    qd = np.column_stack([0.3 * w * np.cos(w * t), -0.1 * w * np.sin(w * t), 0.05 + 0 * t])
    qdd = np.column_stack([-0.3 * w * w * np.sin(w * t), -0.1 * w * w * np.cos(w * t), 0 * t])
    return t, q, qd, qdd


def test_export_reference_writes_the_fmu_format(tmp_path: Path) -> None:
    t, q, qd, qdd = _motion(50)
    path = export_reference(t, q, qd, qdd, tmp_path / "reference.csv")
    assert tuple(path.read_text().splitlines()[0].split(",")) == REFERENCE_COLUMNS
    table = read_reference_table(path, REFERENCE_COLUMNS)
    assert np.array_equal(table["t"], t)  # every double exactly
    assert np.array_equal(np.column_stack([table[f"qd_ref[{i}]"] for i in (1, 2, 3)]), qd)
    # without a writing reference, the tip columns are the default robot's kinematics
    model = Model.default()
    x = np.column_stack([table[f"x_ref.{a}"] for a in "xyz"])
    xd = np.column_stack([table[f"xd_ref.{a}"] for a in "xyz"])
    assert np.array_equal(x, model.fk(q, simd="scalar")[0])  # the one-state calls
    assert np.array_equal(xd, model.tip_motion(q, qd, qdd)[0])
    # a writing reference's planned tip path is written as it is
    tip = (x + 1.0, xd, xd * 0.0)
    table = read_reference_table(export_reference(t, q, qd, qdd, tmp_path / "r2.csv", tip),
                                 REFERENCE_COLUMNS)
    assert np.array_equal(table["x_ref.z"], x[:, 2] + 1.0)
    with pytest.raises(HilError, match=r"run at 0\.001 s"):
        export_reference(t * 2, q, qd, qdd, tmp_path / "r3.csv")


def test_reading_a_reference_table_by_column_name(tmp_path: Path) -> None:
    path = tmp_path / "ref.csv"
    path.write_text("x_ref.x,t," + ",".join(JOINT_COLUMNS[1:]) + "\n"
                    "9,0," + ",".join(str(k) for k in range(9)) + "\n")
    table = read_reference_table(path)
    assert table["t"].tolist() == [0.0] and table["qdd_ref[3]"].tolist() == [8.0]
    cases = {
        "t," + ",".join(JOINT_COLUMNS[1:-1]) + "\n0" + ",0" * 8 + "\n": "no column 'qdd_ref[3]'",
        ",".join(JOINT_COLUMNS) + "\n0" + ",0" * 8 + "\n": ":2: 9 values, the header has 10",
        ",".join(JOINT_COLUMNS) + "\n0" + ",0" * 8 + ",nan\n": "column qdd_ref[3] is not a finite",
        ",".join(JOINT_COLUMNS) + "\n0" + ",x" * 9 + "\n": ":2: not a row of numbers",
        "": "empty",
    }
    for text, message in cases.items():
        path.write_text(text)
        with pytest.raises(BadInputError, match=message.replace("[", r"\[")):
            read_reference_table(path)


# ---- the node logs -----------------------------------------------------------------------------


def test_the_generated_header_is_the_spec() -> None:
    header = (ROOT / "c_src" / "hil" / "nodes" / "gen" / "rrr_hil_logs.h").read_text()
    for spec in (CONTROLLER_LOG, PLANT_LOG, LATENCY_LOG):
        macro = f"RRR_HIL_{spec.name.upper()}_LOG"
        assert f'#define {macro}_HEADER "{spec.header}\\n"' in header
        assert f"#define {macro}_COLUMNS {len(spec.columns)}" in header
    # the C writers print the generated headers, not their own
    for source in ("rrr_hil_controller.c", "hil_controller_law.c", "rrr_hil_plant.c", "hil_plant.c",
                   "hil_node.c"):
        text = (ROOT / "c_src" / "hil" / "nodes" / source).read_text()
        assert "rrr_hil_logs.h" in text and "\"k,t," not in text and "\"k,latency" not in text


def test_python_controller_log_reads_back_through_the_spec(tmp_path: Path) -> None:
    n = 7
    rng = np.random.default_rng(3)
    q, qd, u, u_n, u_c = (rng.normal(size=(n, 3)) for _ in range(5))
    run = BenchRun(t=np.arange(n) * PERIOD, q=q, qd=qd, u=u, plant_summary={},
                   controller_summary={}, u_n=u_n, u_c=u_c)
    log = read_log(write_controller_log(run, tmp_path / "controller.csv"), CONTROLLER_LOG)
    assert log.rows.shape == (n, 18)
    for group, want in (("q", q), ("qd", qd), ("u", u), ("u_n", u_n), ("u_c", u_c)):
        assert np.array_equal(log.group(group), want), group
    assert log.col("k").tolist() == list(range(n)) and np.all(log.col("enable") == 1)


def test_a_log_that_is_not_the_spec_is_refused(tmp_path: Path) -> None:
    rows = np.arange(2.0 * 19).reshape(2, 19)
    path = write_log(tmp_path / "plant.csv", PLANT_LOG, rows)
    assert np.array_equal(read_log(path, PLANT_LOG).rows, rows)
    with pytest.raises(HilError, match="not a controller log: its column 10 is 'u\\[2\\]', the "
                       "controller log has 'u_n\\[1\\]' there"):
        read_log(path, CONTROLLER_LOG)
    moved = PLANT_LOG.header.replace("zero,faults", "faults,zero")
    path.write_text(moved + "\n" + "0," * 18 + "0\n")
    with pytest.raises(HilError, match="column 12 is 'faults'"):
        read_log(path, PLANT_LOG)
    path.write_text(PLANT_LOG.header + "\n" + "0," * 17 + "0\n")
    with pytest.raises(HilError, match="has 18 columns, expected 19"):
        read_log(path, PLANT_LOG)
    path.write_text(PLANT_LOG.header + "\n" + "0," * 18 + "0")
    with pytest.raises(HilError, match="cut short"):
        read_log(path, PLANT_LOG)
    with pytest.raises(HilError, match="cannot read the node log"):
        read_log(tmp_path / "missing.csv", LATENCY_LOG)
    with pytest.raises(ValueError, match="has 19 columns"):
        write_log(path, PLANT_LOG, rows[:, :5])
    # an empty latency log (no period ran) is a log of no rows
    path.write_text(LATENCY_LOG.header + "\n")
    assert read_log(path, LATENCY_LOG).cols(["latency_ns", "work_ns"]).shape == (0, 2)


def test_summary_files_are_listed_and_strict(tmp_path: Path) -> None:
    from rrr_robot.core.outputs import ResultSet
    from rrr_robot.core.summary import write_summary

    with ResultSet(tmp_path / "out", kind="writing") as rs:
        rs.write_text("a.csv", "x\n")
        written = write_summary(rs, {"reference": {"duration": float("nan")}, "engine": "e"})
    on_disk = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert on_disk == written
    assert on_disk["files"] == ["a.csv", "summary.json"]
    assert on_disk["reference"]["duration"] is None and next(iter(on_disk)) == "reference"
