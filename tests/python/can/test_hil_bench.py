"""The CAN bench against the FMPy co-simulation of the writing task (scenario ctc).

- Both C nodes in lockstep over the socketcand transport reproduce the FMPy loop with the DBC's
  quantisation (q to 1e-6 rad and qd to 1e-4 rad/s in JointState, u to 1 mV in VoltageCmd)
  to < 1e-9 rad: same plant FMU binary, same rrr_ctc, same rounding (measured: bit for bit).
- Against the unquantised FMPy run (rrr_robot.writing's ctc) the only difference is that
  quantisation: |dq| stays below 1e-5 rad (measured 3.0e-6 rad, |du| 4.0e-4 V), which is small
  against the tracking error itself (1.8e-4 rad), and the tip error metric agrees to 5 %.
- python-can's built-in socketcand interface drives the C plant node with the controller FMU
  (FMPy): the same numbers again.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rrr_robot.core.param_names import model_fmu_values
from rrr_robot.errors import HilError
from rrr_robot.hil.dbc.bench import quantised_cosim, run_c_bench
from rrr_robot.hil.dbc.controller import run_fmu_controller
from rrr_robot.hil.logs.specs import PLANT_LOG, read_log
from rrr_robot.hil.nodes import controller_node_args, open_bus, start_plant
from rrr_robot.hil.results import BenchRun
from rrr_robot.sim.cosim import CosimOptions, run_cosim
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare
from support import REPO


@pytest.fixture(scope="module")
def writing(tmp_path_factory: pytest.TempPathFactory):
    model, robot, scenarios, ref = prepare(
        WritingJob(out=tmp_path_factory.mktemp("w"), scenarios=["ctc"]))
    return model, robot, scenarios[0], ref


@pytest.fixture(scope="module")
def c_bench(writing, tmp_path_factory: pytest.TempPathFactory) -> BenchRun:
    ref = writing[3]
    return run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=tmp_path_factory.mktemp("b"))


def test_c_bench_equals_quantised_fmpy_loop(writing, c_bench: BenchRun) -> None:
    ref = writing[3]
    assert c_bench.q.shape == ref.q.shape
    assert c_bench.plant_summary["faults"] == 0 and c_bench.plant_summary["fault_events"] == 0
    assert c_bench.plant_summary["periods"] == ref.t.size - 1
    assert c_bench.controller_summary["states"] == ref.t.size
    qc = quantised_cosim(ref.t, ref.q, ref.qd, ref.qdd)
    assert np.abs(c_bench.q - qc.q).max() < 1e-9
    assert np.abs(c_bench.qd - qc.qd).max() < 1e-9
    assert np.abs(c_bench.u - qc.u).max() < 1e-9


def test_c_bench_vs_writing_task_differs_by_quantisation_only(writing, c_bench) -> None:
    model, robot, scn, ref = writing
    opts = CosimOptions(step=robot.sample_time, plant_values=model_fmu_values(model),
                        controller_values=controller_fmu_values(scn, model, robot.control))
    r = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)
    dq = np.abs(c_bench.q - r.q).max()
    du = np.abs(c_bench.u - r.u).max()
    tracking = np.abs(r.q - ref.q).max()
    print(f"bench vs FMPy writing task: max |dq| {dq:.3e} rad, max |du| {du:.3e} V, "
          f"tracking error {tracking:.3e} rad")
    assert dq < 1e-5
    # voltage quantisation 0.5 mV plus Kp * 0.5 urad + Kd * 0.5e-4 rad/s (max Kd 4 V s/rad)
    assert du < 2e-3
    assert dq < 0.05 * tracking
    tip = model.fk(c_bench.q)[0]
    e_bench = np.linalg.norm(tip - ref.x, axis=1).max()
    e_fmpy = np.linalg.norm(r.tip - ref.x, axis=1).max()
    assert e_bench == pytest.approx(e_fmpy, rel=0.05)


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
