"""The CAN bench against the FMPy co-simulation of the writing task (scenario ctc), over the
socketcand transport (both C nodes on the task's first 3000 periods, over each transport, and
their difference to the unquantised task: test_bench_transports.py).

- python-can's built-in socketcand interface drives the C plant node with the controller FMU
  (FMPy): the C bench's numbers (the FMPy loop with the DBC's quantisation) again.
- The C controller node takes a scenario's model and gains, and refuses bad values and
  reference tables naming what is wrong.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rrr_robot.errors import HilError
from rrr_robot.hil.dbc.bench import quantised_cosim, run_c_bench
from rrr_robot.hil.dbc.controller import run_fmu_controller
from rrr_robot.hil.logs.specs import PLANT_LOG, read_log
from rrr_robot.hil.nodes import controller_node_args, open_bus, start_plant
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare
from support import REPO


@pytest.fixture(scope="module")
def writing(tmp_path_factory: pytest.TempPathFactory):
    model, robot, scenarios, ref = prepare(
        WritingJob(out=tmp_path_factory.mktemp("w"), scenarios=["ctc"]))
    return model, robot, scenarios[0], ref


def test_python_can_controller_fmu_against_c_plant(writing, tmp_path: Path) -> None:
    ref = writing[3]
    n = 1500
    t, q, qd, qdd = ref.t[:n], ref.q[:n], ref.qd[:n], ref.qdd[:n]
    with start_plant(q0=q[0], qd0=qd[0], log_csv=tmp_path / "plant.csv") as plant:
        with open_bus("socketcand", port=plant.port) as bus:
            run = run_fmu_controller(bus, t, q, qd, qdd)
        summary = plant.wait(60)
    assert summary["exit"] == 0 and summary["faults"] == 0 and summary["periods"] == n - 1
    assert summary["rx_bad_crc"] == 0 and summary["rx_malformed"] == 0
    assert run.controller_summary["rejected"] == {}
    log = read_log(tmp_path / "plant.csv", PLANT_LOG)
    qc = quantised_cosim(t, q, qd, qdd)
    assert np.abs(log.group("q") - qc.q).max() < 1e-9
    # what the controller received is the plant state quantised by the DBC
    assert np.abs(run.q - qc.q).max() <= 0.5e-6 + 1e-12


def test_c_controller_takes_a_scenario_model(writing, tmp_path: Path) -> None:
    """The mismatch scenario on the bench: the C controller node runs with the perturbed model
    and PD gains of the scenario (--set, --kp, --kd), and again equals the quantised FMPy loop
    with the same controller FMU values."""
    from rrr_robot.writing.scenarios import load_scenario

    model, robot, _, ref = writing
    values = controller_fmu_values(load_scenario("mismatch"), model, robot.control)
    n = 1500
    t, q, qd, qdd = ref.t[:n], ref.q[:n], ref.qd[:n], ref.qdd[:n]
    bench = run_c_bench(t, q, qd, qdd, workdir=tmp_path, controller_values=values)
    qc = quantised_cosim(t, q, qd, qdd, controller_values=values)
    exact = quantised_cosim(t, q, qd, qdd)
    assert np.abs(bench.q - qc.q).max() < 1e-9
    assert np.abs(bench.u - qc.u).max() < 1e-9
    assert np.abs(bench.u - exact.u).max() > 1e-3  # the perturbed model does change u


def test_controller_node_rejects_bad_model_values(writing, tmp_path: Path) -> None:
    ref = writing[3]
    with pytest.raises(HilError, match=r"parameter kt\[2\]"):
        run_c_bench(ref.t[:10], ref.q[:10], ref.qd[:10], ref.qdd[:10], workdir=tmp_path,
                    controller_values={"kt[2]": -1.0})
    with pytest.raises(ValueError, match="give all three"):
        controller_node_args({"kp[1]": 1.0})


def test_controller_node_reads_the_reference_fmu_table_by_column_name(tmp_path: Path) -> None:
    """The C controller reads the reference FMU's table format: the packaged table (1 s steps)
    is refused only for its step, a table without a column it needs names the column."""
    import subprocess

    from rrr_robot.hil.nodes import node_executable

    root = REPO
    packaged = root / "fmu" / "reference" / "resources" / "reference.csv"
    header = packaged.read_text().splitlines()[0].split(",")
    short = tmp_path / "short.csv"
    short.write_text(",".join(header[:9]) + "\n" + ",".join(["0"] * 9) + "\n")
    for table, message in ((packaged, "reference.csv:3: t steps by 1 s; the bench needs 0.001 s"),
                           (short, "short.csv:1: the reference table has no column "
                                   "'qdd_ref[3]'")):
        proc = subprocess.run([str(node_executable("controller")), "--reference", str(table),
                               "--connect", "127.0.0.1:1"], capture_output=True, text=True,
                              timeout=30)
        assert proc.returncode == 2 and message in proc.stderr, proc.stderr
