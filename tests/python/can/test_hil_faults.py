"""Fault injection against the C plant node, with python-can's socketcand interface as the
controller: dropped frames, a silent controller, corrupted CRC, repeated counter, out-of-range
voltage, wrong DLC, unknown ids, malformed socketcand input, a disconnect. The plant must apply
0 V within 3 periods and latch the fault (PlantStatus), count every event, and never crash; a
run in which a fault latched or 0 V was forced ends with EXIT_SAFETY (7), one in which frames were
only counted and ignored with 0.

Plant log rows: row 0 is the initial state, row k + 1 the state after period k, with the voltage
applied during period k.
"""

from __future__ import annotations

import socket
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest
from rrr_robot.hil.dbc.protocol import DATA_IDS, EXIT_SAFETY, FAULT_BITS, database, decode, encode
from rrr_robot.hil.logs.specs import PLANT_LOG, read_log
from rrr_robot.hil.nodes import NMT_OPERATIONAL, NMT_STOPPED, open_bus, start_plant

Q0 = (0.2, 0.8, -1.2)
U = (1.0, -0.5, 0.25)
F = FAULT_BITS


class Rig:
    """A plant node plus a python-can controller stepping it period by period."""

    def __init__(self, tmp_path: Path, extra: tuple[str, ...] = ()) -> None:
        self.log_path = tmp_path / "plant.csv"
        self.plant = start_plant(q0=Q0, log_csv=self.log_path, extra=extra)
        self.bus = open_bus("socketcand", port=self.plant.port)
        self.k = 0
        self.bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_OPERATIONAL, "Counter": 0}))
        self.status = self.read_status(0)

    def read_status(self, k: int) -> dict[str, float]:
        while True:
            msg = self.bus.recv(timeout=5.0)
            assert msg is not None, f"no PlantStatus for period {k}"
            name, sig = decode(msg)
            if name == "PlantStatus" and sig["AliveCounter"] == k & 15:
                return sig

    def cmd(self, u: tuple[float, ...] = U, counter: int | None = None, **kw: Any) -> can.Message:
        sig = {"AliveCounter": self.k & 15 if counter is None else counter, "Enable": 1,
               "ResetFault": 0, **{f"U{i + 1}": v for i, v in enumerate(u)}}
        return encode("VoltageCmd", sig | {k: v for k, v in kw.items() if k != "corrupt_crc"},
                      corrupt_crc=kw.get("corrupt_crc", False))

    def period(self, *frames: can.Message) -> dict[str, float]:
        """Send frames (default: a valid command), then Sync(k); the status after period k."""
        for f in frames or (self.cmd(),):
            self.bus.send(f)
        self.bus.send(encode("Sync", {"Cycle": self.k}))
        self.k += 1
        self.status = self.read_status(self.k)
        return self.status

    def finish(self, stop_counter: int | None = None) -> tuple[dict[str, Any], np.ndarray]:
        # the authenticated stop: the next alive counter of the command sequence
        counter = self.k & 15 if stop_counter is None else stop_counter
        self.bus.send(encode("StopCmd", {"AliveCounter": counter, "Reason": 0}))
        self.bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_STOPPED, "Counter": 1}))
        self.bus.shutdown()
        summary = self.plant.wait(30)
        return summary, read_log(self.log_path, PLANT_LOG).rows


@pytest.fixture
def rig(tmp_path: Path):
    r = Rig(tmp_path)
    yield r
    r.bus.shutdown()
    r.plant.close()


def applied(log: np.ndarray, k: int) -> np.ndarray:
    return log[k + 1, PLANT_LOG.indices(["u[1]", "u[2]", "u[3]"])]


def test_normal_run_and_one_dropped_frame(rig: Rig) -> None:
    for _ in range(5):
        assert rig.period()["Faults"] == 0
    st = rig.period(encode("HeartbeatCtrl", {"NmtState": 5, "Counter": 2}))  # no command
    assert st["Faults"] == 0 and st["ZeroVoltage"] == 0 and st["CmdMissed"] == 1
    st = rig.period()  # counter jumps by 2: accepted
    assert st["Faults"] == 0
    summary, log = rig.finish()
    assert summary["exit"] == 0 and summary["fault_events"] == 0 and summary["cmd_missed"] == 1
    np.testing.assert_allclose(applied(log, 5), U)  # held over the dropped period
    np.testing.assert_allclose(applied(log, 6), U)


def test_silent_controller_zero_volts_within_three_periods(rig: Rig) -> None:
    for _ in range(3):
        rig.period()
    sync_only = encode("HeartbeatCtrl", {"NmtState": 5, "Counter": 3})
    statuses = [rig.period(sync_only) for _ in range(6)]
    assert [s["ZeroVoltage"] for s in statuses] == [0, 0, 1, 1, 1, 1]
    assert all(s["Faults"] == F["timeout"] for s in statuses[2:])
    assert statuses[-1]["State"] == 2
    # latched: the controller's return is not enough (its counter jumped by 7: flagged as well)
    assert rig.period()["Faults"] == F["timeout"] | F["counter"]
    summary, log = rig.finish()
    assert summary["exit"] == EXIT_SAFETY  # completed, but the safety policy fired
    assert summary["timeout"] == 1 and summary["counter"] == 1
    assert summary["cmd_missed"] == 7  # 6 silent periods + the rejected command
    np.testing.assert_allclose(applied(log, 3), U)
    np.testing.assert_allclose(applied(log, 4), U)
    assert not applied(log, 5).any() and not applied(log, 9).any()


@pytest.mark.parametrize("fault", ["crc", "counter", "range", "format"])
def test_bad_command_latches_at_once(rig: Rig, fault: str) -> None:
    for _ in range(3):
        rig.period()
    if fault == "crc":
        bad = rig.cmd(corrupt_crc=True)
    elif fault == "counter":
        bad = rig.cmd(counter=(rig.k - 1) & 15)  # repeated
    elif fault == "range":
        msg = database().get_message_by_name("VoltageCmd")
        data = bytearray(msg.encode({"Crc": 0, "AliveCounter": rig.k & 15, "Enable": 1,
                                     "ResetFault": 0, "U1": 31.0, "U2": 0, "U3": 0},
                                    strict=False))
        from cantools.autosar.end_to_end import compute_profile2_crc

        data[0] = compute_profile2_crc(bytes(data), DATA_IDS["VoltageCmd"])
        bad = can.Message(arbitration_id=0x100, data=data, is_extended_id=False)
    else:
        good = rig.cmd()
        bad = can.Message(arbitration_id=0x100, data=bytes(good.data)[:7], is_extended_id=False)
    st = rig.period(bad)
    assert st["Faults"] == F[fault] and st["ZeroVoltage"] == 1 and st["State"] == 2
    assert rig.period()["Faults"] == F[fault]  # latched
    # reset (CiA 402 style): the request alone only arms it (State 3, still latched, 0 V) ...
    st = rig.period(rig.cmd(Enable=0, ResetFault=1))
    assert st["Faults"] == F[fault] and st["State"] == 3 and st["ZeroVoltage"] == 1
    # ... the latch clears with the 3rd enabling command of consecutive alive counters
    for _ in range(2):
        st = rig.period()
        assert st["Faults"] == F[fault] and st["ZeroVoltage"] == 1
    st = rig.period()
    assert st["Faults"] == 0 and st["State"] == 1 and st["ZeroVoltage"] == 0
    summary, log = rig.finish()
    # completed, and the fault was reset: still the status of a run whose safety policy fired
    assert summary["exit"] == EXIT_SAFETY and summary["resets"] == 1
    assert summary[fault] == 1 and summary["fault_events"] == 1
    assert not applied(log, 3).any() and not applied(log, 7).any()
    np.testing.assert_allclose(applied(log, 8), U)


def test_reset_with_a_counter_gap_does_not_clear(rig: Rig) -> None:
    for _ in range(3):
        rig.period()
    rig.period(rig.cmd(corrupt_crc=True))
    st = rig.period(rig.cmd(Enable=0, ResetFault=1))
    assert st["State"] == 3
    for _ in range(3):  # the enabling commands skip one alive counter
        st = rig.period(rig.cmd(counter=(rig.k + 1) & 15))
    assert st["Faults"] == F["crc"] | F["counter"] and st["ZeroVoltage"] == 1
    summary, _ = rig.finish(stop_counter=(rig.k + 1) & 15)
    assert summary["exit"] == EXIT_SAFETY and summary["resets"] == 0 and summary["counter"] == 1


def test_unauthenticated_stop_is_ignored(rig: Rig) -> None:
    for _ in range(3):
        rig.period()
    stale = encode("StopCmd", {"AliveCounter": (rig.k - 1) & 15, "Reason": 0})
    bad_crc = encode("StopCmd", {"AliveCounter": rig.k & 15, "Reason": 0}, corrupt_crc=True)
    heartbeat = encode("HeartbeatCtrl", {"NmtState": NMT_STOPPED, "Counter": 1})
    st = rig.period(stale, bad_crc, heartbeat, rig.cmd())
    assert st["Faults"] == 0  # the plant ran this period: none of them stopped it
    summary, _ = rig.finish()
    assert summary["exit"] == 0 and summary["stop_rejected"] == 2
    assert summary["fault_events"] == 0 and summary["periods"] == 4


def test_unknown_ids_and_extended_frames_are_counted_not_faults(rig: Rig) -> None:
    junk = [can.Message(arbitration_id=0x123, data=bytes(8), is_extended_id=False),
            can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=True)]
    st = rig.period(*junk, rig.cmd())
    assert st["Faults"] == 0
    summary, _ = rig.finish()
    assert summary["rx_unknown_id"] == 2 and summary["fault_events"] == 0
    assert summary["exit"] == 0  # counted and ignored: the status of a clean run


def test_malformed_socketcand_input_and_disconnect(tmp_path: Path) -> None:
    with start_plant(q0=Q0) as plant:
        s = socket.create_connection(("127.0.0.1", plant.port), timeout=5)
        assert s.recv(64) == b"< hi >"
        s.sendall(b"< open wrongbus >")
        assert s.recv(64).startswith(b"< error")
        s.sendall(b"< open bench0 >")
        assert s.recv(64) == b"< ok >"
        s.sendall(b"< rawmode >")
        assert s.recv(64) == b"< ok >"
        s.sendall(b"garbage< send 100 >< send 100 9 1 2 3 4 5 6 7 8 9 >< send zz 1 1 >"
                  + b"< " + b"x" * 400 + b" >")
        s.sendall(b"< send 701 2 5 0 >")  # heartbeat: the plant answers with period 0
        s.settimeout(5)
        assert b"< frame 201 " in s.recv(4096)
        s.close()  # the controller disappears in the middle of the run
        summary = plant.wait(30)
    assert summary["exit"] == 3  # controller lost
    assert summary["bus"] == 1 and summary["faults"] == F["bus"]
    assert summary["rx_malformed"] >= 5 and summary["disconnects"] == 1


def test_socketcan_interface_fails_clearly_where_it_cannot_open() -> None:
    """Without AF_CAN (this CI) the socketcan bus cannot open; with AF_CAN, an interface that
    does not exist cannot either. Either way a clear error, no crash."""
    channel = "vcan0"
    try:
        socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
        channel = "rrrnosuchif0"  # AF_CAN exists: name an interface that does not
    except (AttributeError, OSError):
        pass
    with pytest.raises((OSError, can.CanError)):
        open_bus("socketcan", channel=channel)
