"""The plant side of the CAN bench from Python (rrr_robot.hil.dbc.plant) against the C controller
node.

- The C controller (--listen, socketcand server) and the Python plant (plant FMU under FMPy,
  python-can socketcand client, the C supervisor through ctypes) in lockstep reproduce the
  FMPy loop with the DBC's quantisation for the whole writing task to < 1e-9 rad (measured:
  bit for bit), as the C plant node does (test_hil_bench.py).
- Faults injected between the bus and the Python plant go through the C supervisor: commands
  that stop arriving give 0 V at the 3rd period and a latched timeout, a corrupted CRC gives 0 V
  at once; PlantStatus reports the fault to the C controller. A controller that disappears
  latches a bus fault and ends the plant with exit status 3.

Plant log rows: row 0 is the initial state, row k + 1 the state after period k, with the voltage
applied during period k.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest
from rrr_robot.hil.dbc import _supervisor as _hil_lib
from rrr_robot.hil.dbc.bench import quantised_cosim
from rrr_robot.hil.dbc.plant import PythonPlant, RxFilter, drop_commands_from
from rrr_robot.hil.dbc.protocol import EXIT_SAFETY, FAULT_BITS, frame_id
from rrr_robot.hil.dbc.sides import Connection, run_plant_side
from rrr_robot.hil.nodes import export_reference, open_bus, start_listening_controller
from rrr_robot.writing.job import WritingJob, prepare

K0 = 200  # first faulty period
N_FAULT = 300  # periods of the fault runs


@pytest.fixture(scope="module")
def ref(tmp_path_factory: pytest.TempPathFactory):
    return prepare(WritingJob(out=tmp_path_factory.mktemp("w"), scenarios=["ctc"]))[3]


def test_supervisor_library_layout() -> None:
    # library() drives rrr_hil_sup through the C functions and checks the ctypes mirror
    assert _hil_lib.library() is not None
    sup = _hil_lib.Supervisor()
    assert sup.next_period() == ((0.0, 0.0, 0.0), False)  # one missed period: hold 0 V
    assert sup.counters()["cmd_missed"] == 1 and sup.faults == 0
    with pytest.raises(ValueError, match="max_missed"):
        _hil_lib.Supervisor(max_missed=0)


def test_c_controller_python_plant_equals_quantised_fmpy_loop(ref, tmp_path: Path) -> None:
    # the plant side of `rrr hil plant`: the C controller node started here, default gains
    side = run_plant_side(ref, {}, tmp_path, Connection())
    run, plant = side.run, side.plant
    assert plant is not None and side.rc == 0
    s, cs = plant.summary, run.controller_summary
    assert s["exit"] == 0 and s["periods"] == ref.t.size - 1
    assert s["faults"] == 0 and s["fault_events"] == 0 and s["cmd_missed"] == 0
    assert s["rx_bad_crc"] == 0 and s["rx_bad_dlc"] == 0 and s["state_out_of_range"] == 0
    assert cs["states"] == ref.t.size and cs["plant_faults"] == 0 and cs["rx_bad_crc"] == 0
    qc = quantised_cosim(ref.t, ref.q, ref.qd, ref.qdd)
    dq, dqd, du = (np.abs(a - b).max() for a, b in ((run.q, qc.q), (run.qd, qc.qd),
                                                      (run.u, qc.u)))
    print(f"C controller + Python plant vs quantised FMPy loop ({ref.t.size} periods): "
          f"max |dq| {dq:.3e} rad, |dqd| {dqd:.3e} rad/s, |du| {du:.3e} V")
    assert dq < 1e-9 and dqd < 1e-9 and du < 1e-9
    # the voltage the plant applied is the controller's, quantised to 1 mV by VoltageCmd
    assert np.abs(plant.u[1:] - qc.u[:-1]).max() <= 0.5e-3 + 1e-12


def _corrupt_crc_at(k0: int) -> RxFilter:
    def rx_filter(k: int, msg: Any) -> Any:
        if k == k0 and msg.arbitration_id == frame_id("VoltageCmd"):
            data = bytearray(msg.data)
            data[3] ^= 0x01
            return can.Message(arbitration_id=msg.arbitration_id, data=data,
                               is_extended_id=False)
        return msg

    return rx_filter


@pytest.mark.parametrize(("case", "first_zero", "fault"),
                         [("commands stop", K0 + 2, "timeout"), ("corrupted CRC", K0, "crc")])
def test_faults_go_through_the_c_supervisor(ref, case: str, first_zero: int,
                                            fault: str, tmp_path: Path) -> None:
    rx_filter = (drop_commands_from(K0) if case == "commands stop"
       else _corrupt_crc_at(K0))
    n = N_FAULT
    short = replace(ref, t=ref.t[:n], q=ref.q[:n], qd=ref.qd[:n], qdd=ref.qdd[:n], x=ref.x[:n],
                    xd=ref.xd[:n], xdd=ref.xdd[:n])
    side = run_plant_side(short, {}, tmp_path, Connection(), rx_filter=rx_filter, timeout=0.5)
    run, plant = side.run, side.plant
    assert plant is not None
    s, u, log = plant.summary, plant.u, plant.log
    # before the fault: the commands; a missing command is held for 2 periods
    assert np.all(log[1:K0 + 1, 11] == 0) and np.abs(u[1:K0 + 1]).min(axis=1).max() > 0
    for k in range(K0, first_zero):
        assert np.array_equal(u[k + 1], u[K0])
    # from first_zero on: 0 V, fault latched until the end (no ResetFault)
    assert first_zero <= K0 + 2
    assert np.all(u[first_zero + 1:] == 0.0) and np.all(log[first_zero + 1:, 11] == 1)
    bit = FAULT_BITS[fault]
    assert np.all(log[first_zero + 1:, 12] == bit) and np.all(log[:first_zero + 1, 12] == 0)
    # commands lost: the controller's StopCmd is out of sequence (stale), ignored; the plant
    # then loses the controller (bus fault, exit 3). A corrupted command: the stop is honoured.
    lost = case == "commands stop"
    assert s["exit"] == (3 if lost else EXIT_SAFETY) and s["stop_rejected"] == int(lost)
    assert s["faults"] == bit | (FAULT_BITS["bus"] if lost else 0) and s[fault] == 1
    assert s["fault_events"] == 1 + int(lost) and s["zero_periods"] == n - 1 - first_zero
    # reported: PlantStatus carried the latched fault to the C controller, which completed the
    # run and ends with the status of a run whose safety policy fired
    assert run.controller_summary["exit"] == EXIT_SAFETY
    assert run.controller_summary["plant_status_faulty"] > 0
    assert run.controller_summary["plant_faults"] == bit


def test_controller_lost_latches_bus_fault(ref, tmp_path: Path) -> None:
    ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, tmp_path / "reference.csv")
    with start_listening_controller(ref_csv) as ctrl:
        def kill_at(k: int, msg: Any) -> Any:
            if k == 50 and ctrl._proc.poll() is None:
                ctrl._proc.kill()  # the controller process dies mid-run (SIGKILL)
            return msg

        with open_bus("socketcand", port=ctrl.port or 0) as bus:
            plant = PythonPlant(bus, q0=ref.q[0], qd0=ref.qd[0], timeout=0.5,
                                rx_filter=kill_at)
            run = plant.run()
    s = run.summary
    assert s["exit"] == 3 and s["faults"] == FAULT_BITS["bus"] and s["bus"] == 1
    assert 50 <= s["periods"] <= 52
