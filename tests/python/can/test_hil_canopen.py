"""The plant as three CiA 402 drives (``rrr_hil_plant --profile canopen``, docs/canopen.md),
mastered by the unmodified ``canopen`` package over python-can's socketcand interface: boot-up,
identity by SDO, NMT start, ``BaseNode402`` to OPERATION ENABLED on the three axes, 1,000
lockstep SYNC periods of torque with position and velocity back (checked against the plant's own
log), the master's heartbeat lost -> FAULT with an EMCY, and ``reset_from_fault()``."""

from __future__ import annotations

import math
import queue
import subprocess
import time
from importlib.resources import files
from pathlib import Path
from typing import Any

import canopen
import numpy as np
import pytest
from rrr_robot.hil.nodes import node_executable, open_bus, start_plant

EDS = str(files("rrr_robot") / "data" / "rrr_cia402.eds")
IDS = (1, 2, 3)
MASTER_ID = 0x7F
KT = (12.0, 11.0, 4.7)  # the default robot's k_t (N m / V) and u_max (V): 0x6076 = k_t u_max
U_MAX = 10.0
INC = 1 << 20  # 0x608F: increments per revolution
#: The master's patience, s: every wait for the plant's answer is bounded by it, far above what
#: a quiet machine needs (milliseconds), so that a busy machine only makes the test slower.
PATIENCE = 30.0


def _inc(x: float) -> int:
    return round(x * INC / (2 * math.pi))


class Rig:
    def __init__(self, tmp_path: Path, extra: tuple[str, ...] = ()) -> None:
        self.log_path = tmp_path / "plant.csv"
        self.plant = start_plant(log_csv=self.log_path, extra=["--profile", "canopen", *extra])
        self.bus = open_bus("socketcand", port=self.plant.port)
        self.network = canopen.Network(self.bus)
        self.network.connect()
        self.nodes = [canopen.BaseNode402(i, EDS) for i in IDS]
        self.tpdos: queue.Queue[tuple[int, bytes]] = queue.Queue()
        for node in self.nodes:
            # the canopen package's own waits (0.2 to 0.8 s) are a master's on a quiet bus
            node.sdo.RESPONSE_TIMEOUT = PATIENCE
            node.TIMEOUT_SWITCH_STATE_FINAL = node.TIMEOUT_SWITCH_STATE_SINGLE = PATIENCE
            node.TIMEOUT_CHECK_TPDO = node.TIMEOUT_SWITCH_OP_MODE = PATIENCE
            self.network.add_node(node)
            for cob in (0x180 + node.id, 0x280 + node.id):
                self.network.subscribe(cob, self._on_tpdo)

    def _on_tpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self.tpdos.put((can_id, bytes(data)))

    def close(self) -> None:
        self.network.sync.stop()
        self.network.disconnect()  # stops the periodic PDOs
        self.plant.close()


@pytest.fixture
def rig(tmp_path: Path) -> Any:
    r = Rig(tmp_path)
    yield r
    r.close()


def _until(done: Any, what: str) -> None:
    """Wait until ``done()`` is true (at most PATIENCE s)."""
    deadline = time.monotonic() + PATIENCE
    while not done():
        assert time.monotonic() < deadline, f"still waiting for {what} after {PATIENCE} s"
        time.sleep(0.01)


def _stop_cycle(rig: Rig) -> None:
    rig.network.sync.stop()
    for node in rig.nodes:
        node.rpdo[1].stop()
    time.sleep(0.05)


def _boot_and_enable(rig: Rig) -> None:
    net = rig.network
    # a socketcand server sends nothing before its client's first frame: reset the nodes, as a
    # master starting up does, and wait for their boot-up messages
    booted: queue.Queue[int] = queue.Queue()
    for node in rig.nodes:
        net.subscribe(0x700 + node.id,
                      lambda can_id, data, ts: booted.put(can_id) if bytes(data) == b"\0" else None)
    net.nmt.send_command(0x81)
    assert sorted(booted.get(timeout=PATIENCE) for _ in IDS) == [0x700 + i for i in IDS]
    for node in rig.nodes:  # a heartbeat (0x1017: 100 ms) of each
        assert node.nmt.wait_for_heartbeat(timeout=PATIENCE) == "PRE-OPERATIONAL"
    for node in rig.nodes:
        assert node.sdo[0x1000].raw == 0x00020192
        assert node.sdo[0x1018][1].raw == 0 and node.sdo[0x1018][2].raw == 0x52525233
        assert node.sdo[0x1018][4].raw == node.id  # serial number: the node id
        assert node.sdo[0x1008].raw == "RRR simulated CiA 402 axis"  # segmented upload
        assert node.sdo[0x6076].raw == round(KT[node.id - 1] * U_MAX * 1000)
        with pytest.raises(canopen.SdoAbortedError) as err:
            node.sdo[0x6041].raw = 0
        assert err.value.code == 0x06010002
        node.sdo.download(0x1017, 0, (50).to_bytes(2, "little"), force_segment=True)
        assert node.sdo[0x1017].raw == 50  # a segmented download
        node.sdo[0x1017].raw = 100
        node.sdo[0x2001].raw = 0  # no RPDO timeout while BaseNode402 steps through the states
        node.setup_402_state_machine()  # reads the PDO mapping by SDO
    net.nmt.state = "OPERATIONAL"
    # a cyclic master: SYNC and the RPDOs (BaseNode402 writes the controlword into the RPDO of
    # transmission type 1 and leaves its sending to the cycle) every 5 ms; the RPDOs act, and
    # the TPDOs come, on SYNC
    net.sync.start(0.005)
    for node in rig.nodes:
        node.rpdo[1].start(0.005)
    for node in rig.nodes:
        node.state = "OPERATION ENABLED"
    for node in rig.nodes:
        assert node.state == "OPERATION ENABLED"
        assert node.op_mode == "CYCLIC SYNCHRONOUS TORQUE"
    _stop_cycle(rig)
    while not rig.tpdos.empty():
        rig.tpdos.get_nowait()


def _shut_down(rig: Rig) -> dict[str, Any]:
    """Disable voltage on every drive, NMT stop, hang up: the plant's summary."""
    for node in rig.nodes:
        node.sdo[0x6040].raw = 0x00
    rig.network.nmt.state = "STOPPED"
    time.sleep(0.1)
    rig.network.disconnect()
    return rig.plant.wait(30)


def _period(rig: Rig, torques: list[int]) -> dict[int, bytes]:
    """One lockstep period: the RPDOs (controlword 0x0F, target torque), one SYNC, the six
    TPDOs of that SYNC."""
    return _cycle(rig, torques, [0x0F] * 3)


def test_three_drives_mastered_by_canopen(rig: Rig) -> None:
    _boot_and_enable(rig)
    for node in rig.nodes:
        node.sdo[0x2001].raw = 3  # from now on an RPDO every period, else a fault
    n = 1000
    sent, feedback = [], []
    for k in range(n):
        torques = [round(300 * math.sin(0.05 * k + j)) for j in range(3)]
        got = _period(rig, torques)
        sent.append(torques)
        row = []
        for node in rig.nodes:
            sw, pos = int.from_bytes(got[0x180 + node.id][:2], "little"), \
                int.from_bytes(got[0x180 + node.id][2:6], "little", signed=True)
            vel = int.from_bytes(got[0x280 + node.id][:4], "little", signed=True)
            tq = int.from_bytes(got[0x280 + node.id][4:6], "little", signed=True)
            assert sw & 0x6F == 0x27  # OPERATION ENABLED
            row.append((pos, vel, tq))
        feedback.append(row)
    # stop cleanly: disable the drives, then NMT stop; the plant ends when the master hangs up
    for node in rig.nodes:
        node.sdo[0x6040].raw = 0x00
        assert node.sdo[0x6041].raw & 0x4F == 0x40  # SWITCH ON DISABLED
    rig.network.nmt.state = "STOPPED"
    time.sleep(0.1)
    rig.network.disconnect()
    summary = rig.plant.wait(30)
    assert summary["exit"] == 0, rig.plant.stderr
    assert summary["profile"] == "canopen" and summary["drive_faults"] == 0
    assert [d["node_id"] for d in summary["drives"]] == list(IDS)
    assert all(d["sdo_aborts"] == 1 for d in summary["drives"])  # the write to 0x6041
    # the plant's log: each period's voltage is the torque sent over k_t (eq 8), and the TPDOs
    # of the SYNC that closed the period carry its state in increments
    log = np.loadtxt(rig.log_path, delimiter=",", skiprows=1, ndmin=2)
    last = log[-n:]
    assert np.array_equal(last[:, 0], np.arange(log[-n, 0], log[-n, 0] + n))
    for k in range(n):
        for j in range(3):
            u = last[k, 8 + j]
            assert u == pytest.approx(sent[k][j] * U_MAX / 1000, abs=1e-12)  # t/1000 u_max
            pos, vel, tq = feedback[k][j]
            assert pos == _inc(last[k, 2 + j]) and vel == _inc(last[k, 5 + j])
            assert tq == sent[k][j]
    assert np.ptp(last[:, 2:5], axis=0).min() > 1e-3  # the torques moved every axis


def test_master_heartbeat_lost_then_reset_from_fault(rig: Rig) -> None:
    """The master's heartbeat every 20 ms, the consumer's time 1 s (50 periods: a thread of
    this process late on a busy machine is no lost master), then no heartbeat: EMCY 0x8130."""
    _boot_and_enable(rig)
    hb = rig.network.send_periodic(0x700 + MASTER_ID, b"\x05", 0.02)
    node = rig.nodes[1]
    node.sdo[0x1016][1].raw = (MASTER_ID << 16) | 1000  # 1 s
    node.emcy.reset()
    time.sleep(1.5)
    assert node.sdo[0x6041].raw & 0x6F == 0x27  # still enabled while the heartbeat comes
    hb.stop()
    emcy = node.emcy.wait(0x8130, timeout=PATIENCE)
    assert emcy is not None and emcy.register & 0x11 == 0x11
    assert node.sdo[0x6041].raw & 0x4F == 0x08  # FAULT
    assert node.sdo[0x1001].raw == 0x11 and node.sdo[0x603F].raw == 0x8130
    for other in (rig.nodes[0], rig.nodes[2]):
        assert other.sdo[0x6041].raw & 0x6F == 0x27  # the other axes are not affected
    node.sdo[0x1016][1].raw = 0  # the master is not monitored any more
    rig.network.sync.start(0.005)
    node.rpdo[1].start(0.005)
    node.check_statusword()  # a fresh TPDO
    node.check_statusword()
    assert node.state == "FAULT"
    node.reset_from_fault()
    assert node.state == "OPERATION ENABLED"
    assert node.sdo[0x1001].raw == 0 and node.sdo[0x603F].raw == 0
    _until(lambda: any(e.code == 0x0000 for e in node.emcy.log), "the error-reset EMCY")
    assert not node.emcy.active
    _stop_cycle(rig)


def test_end_after_stop_ends_a_silent_bus_only_once_the_drives_are_stopped(
        tmp_path: Path) -> None:
    """--end-after-stop-ms (a bus with no hang-up): a silent master whose drives are still
    operational is waited for (here past 5 x N), one that stopped them ends the run, exit 0."""
    rig = Rig(tmp_path, ("--idle-timeout-ms", "600000", "--end-after-stop-ms", "200"))
    try:
        _boot_and_enable(rig)
        _period(rig, [0, 0, 0])
        time.sleep(1.0)  # silent, the drives operational: the plant goes on
        assert rig.plant.running(), "the plant ended while its drives were operational"
        _period(rig, [0, 0, 0])  # it still answers
        for node in rig.nodes:
            node.sdo[0x6040].raw = 0x00
        rig.network.nmt.state = "STOPPED"  # then silent, connected: no hang-up
        summary = rig.plant.wait(PATIENCE)
    finally:
        rig.close()
    assert summary["exit"] == 0, rig.plant.stderr
    assert "the master stopped the drives and fell silent" in rig.plant.stderr
    assert all(d["nmt"] == 0x04 for d in summary["drives"])  # stopped


@pytest.mark.parametrize(("args", "message"), [
    (["--profile", "cia402"], "--profile: expected 'dbc' or 'canopen', got 'cia402'"),
    (["--profile", "canopen", "--node-ids", "1,1,2"], "--node-ids: expected three distinct"),
    (["--profile", "canopen", "--node-ids", "1,2,128"], "--node-ids: expected three distinct"),
    (["--profile", "canopen", "--node-ids", "1,2.5,3"], "--node-ids: expected three distinct"),
    (["--profile", "canopen", "--realtime", "--duration", "1"],
     "with --realtime it takes --fifo, --mlock and --cpu only (no --duration"),
    (["--profile", "canopen", "--realtime", "--latency-log", "x.csv"],
     "no --latency-log: the SYNC times are in the frame log"),
    (["--profile", "canopen", "--end-after-stop-ms", "0"],
     "--end-after-stop-ms: expected milliseconds 1..3600000, got '0'"),
    (["--profile", "canopen", "--end-after-stop-ms", "1s"],
     "--end-after-stop-ms: expected milliseconds 1..3600000, got '1s'"),
    (["--end-after-stop-ms", "1000"], "--end-after-stop-ms is for --profile canopen"),
])
def test_bad_canopen_options_are_refused(args: list[str], message: str) -> None:
    result = subprocess.run([str(node_executable("plant")), "--fmu", "unused",
                             "--listen", "127.0.0.1:0", *args],
                            capture_output=True, text=True, timeout=30)
    assert result.returncode == 1 and message in result.stderr, result.stderr


def test_hostile_frames_are_refused_and_counted(rig: Rig) -> None:
    """Frames a broken master sends: an SDO request with a wrong DLC, a bad command
    specifier, unknown objects, an NMT command with a wrong DLC or an unknown code, a SYNC
    with 2 data bytes, a short RPDO: each gets its abort or EMCY, or is counted; the drives go
    on answering."""
    import can

    _boot_and_enable(rig)
    answers: queue.Queue[bytes] = queue.Queue()
    rig.network.subscribe(0x581, lambda can_id, data, ts: answers.put(bytes(data)))
    node = rig.nodes[0]
    node.emcy.reset()

    def send(can_id: int, data: bytes) -> None:
        rig.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))

    def abort_code() -> int:
        data = answers.get(timeout=PATIENCE)
        assert data[0] == 0x80, data.hex()
        return int.from_bytes(data[4:8], "little")

    send(0x601, bytes([0x40, 0x00, 0x10, 0x00, 0x00]))  # DLC 5
    assert abort_code() == 0x05040001
    send(0x601, bytes([0xE0, 0x00, 0x10, 0, 0, 0, 0, 0]))  # command specifier 7
    assert abort_code() == 0x05040001
    send(0x601, bytes([0x40, 0x34, 0x12, 0, 0, 0, 0, 0]))  # no object 0x1234
    assert abort_code() == 0x06020000
    send(0x601, bytes([0x40, 0x18, 0x10, 7, 0, 0, 0, 0]))  # no sub-index 7 of 0x1018
    assert abort_code() == 0x06090011
    send(0x601, bytes([0x2B, 0x17, 0x10, 0, 0x64, 0, 0, 0]))  # 0x1017 as 4 bytes: n says 2
    assert answers.get(timeout=PATIENCE)[0] == 0x60  # n = 2: a 2-byte write, accepted
    send(0x601, bytes([0x23, 0x17, 0x10, 0, 0x64, 0, 0, 0]))  # 4 bytes into 2
    assert abort_code() == 0x06070012  # length too high
    send(0x601, bytes([0x2F, 0x17, 0x10, 0, 0x64, 0, 0, 0]))  # 1 byte into 2
    assert abort_code() == 0x06070013  # length too low
    with pytest.raises(canopen.SdoAbortedError) as err:
        _ = node.sdo[0x2000].raw  # write-only
    assert err.value.code == 0x06010001
    send(0x000, bytes([0x02, 0x00, 0x00]))  # NMT stop with DLC 3: ignored
    send(0x000, bytes([0x07, 0x00]))  # unknown NMT command: ignored
    send(0x080, bytes([1, 2]))  # SYNC with 2 bytes: EMCY 0x8240, no fault
    _until(lambda: node.emcy.log, "EMCY 0x8240")
    assert [e.code for e in node.emcy.log] == [0x8240]
    rig.network.sync.start(0.005)
    node.rpdo[1].start(0.005)
    send(0x201, bytes([0x0F, 0x00, 0x10]))  # RPDO of 3 bytes: EMCY 0x8210, dropped
    _until(lambda: len(node.emcy.log) >= 2, "EMCY 0x8210")
    assert [e.code for e in node.emcy.log] == [0x8240, 0x8210]
    node.check_statusword()
    assert node.state == "OPERATION ENABLED"  # none of it is a fault
    _stop_cycle(rig)
    summary = _shut_down(rig)
    assert summary["exit"] == 0 and summary["drive_faults"] == 0, rig.plant.stderr
    drive1 = summary["drives"][0]
    assert drive1["nmt_ignored"] == 2 and drive1["sync_bad"] == 1 and drive1["rpdo_short"] == 1
    assert drive1["sdo_aborts"] == 8  # the seven above and the write to 0x6041 in the set-up
    assert all(d["nmt_ignored"] == 2 and d["sync_bad"] == 1 for d in summary["drives"])


def test_a_segmented_transfer_left_hanging_is_aborted_by_the_server(rig: Rig) -> None:
    """A master that starts a segmented upload (the device name 0x1008) and asks for no
    segment: after the server's timeout (1 s, wall-clock time of the plant; not before it, later
    on a busy machine) the drive aborts it with 0x05040000 (SDO protocol timed out), counted;
    the next transfer works."""
    import can

    _boot_and_enable(rig)
    answers: queue.Queue[tuple[float, bytes]] = queue.Queue()
    rig.network.subscribe(0x582, lambda can_id, data, ts: answers.put((time.monotonic(),
                                                                         bytes(data))))
    start = time.monotonic()
    rig.bus.send(can.Message(arbitration_id=0x602, data=bytes([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]),
                             is_extended_id=False))
    _, init = answers.get(timeout=PATIENCE)
    assert init[0] == 0x41  # segmented upload, size indicated
    when, abort = answers.get(timeout=PATIENCE)
    assert abort[0] == 0x80 and abort[1:4] == bytes([0x08, 0x10, 0x00]), abort.hex()
    assert int.from_bytes(abort[4:8], "little") == 0x05040000
    assert when - start >= 0.9  # not before the server's 1 s timeout
    print(f"the abort came {when - start:.3f} s after the request")
    node = rig.nodes[1]
    assert node.sdo[0x1008].raw == "RRR simulated CiA 402 axis"  # the next transfer works
    assert node.state == "OPERATION ENABLED"  # an SDO timeout is no drive fault
    summary = _shut_down(rig)
    assert summary["exit"] == 0 and summary["drive_faults"] == 0, rig.plant.stderr
    drive2 = summary["drives"][1]
    assert drive2["sdo_timeouts"] == 1
    assert all(d["sdo_timeouts"] == 0 for d in summary["drives"][::2])


def _cycle(rig: Rig, torques: list[int], cws: list[int]) -> dict[int, bytes]:
    """One lockstep period with the controlword ``cws[j]`` of each drive: the RPDOs, one SYNC,
    the TPDOs of that SYNC (of the drives in NMT operational)."""
    for node, t, cw in zip(rig.nodes, torques, cws, strict=True):
        node.rpdo[1]["Controlword"].raw = cw
        node.rpdo[1]["Target torque"].raw = t
        node.rpdo[1].transmit()
    return _sync(rig)


def _sync(rig: Rig) -> dict[int, bytes]:
    """One SYNC, and the six TPDOs it makes the drives send."""
    rig.network.sync.transmit()
    got: dict[int, bytes] = {}
    while len(got) < 6:
        cob, data = rig.tpdos.get(timeout=PATIENCE)
        got[cob] = data
    return got


def _sw(got: dict[int, bytes], node_id: int) -> int:
    return int.from_bytes(got[0x180 + node_id][:2], "little")


# each fault on drive 2 while all three run: (how it is caused, its EMCY code)
FAULTS = {"rpdo_timeout": 0x8250, "nmt_stop_in_operation": 0x8100, "torque_out_of_range": 0x6320}


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_a_drive_fault_latches_0_V_until_the_402_fault_reset(fault: str, rig: Rig) -> None:
    """A fault of drive 2 in OPERATION ENABLED: its EMCY (the code, error register 0x1001), the
    statusword FAULT, 0 V to joint 2 while the other axes go on, counted by the plant; a
    controlword of enable operation does not clear it; the 402 fault reset (rising edge of bit
    7) and shutdown, switch on, enable operation bring the drive back to torque."""
    _boot_and_enable(rig)
    node = rig.nodes[1]
    node.sdo[0x2001].raw = 3 if fault == "rpdo_timeout" else 0
    node.emcy.reset()
    on, t = [0x0F] * 3, [200, 300, 100]
    for _ in range(3):
        assert _sw(_cycle(rig, t, on), 2) & 0x6F == 0x27
    if fault == "rpdo_timeout":  # drive 2's RPDO missing for 3 SYNC periods
        for _ in range(3):
            for other, tq in ((rig.nodes[0], t[0]), (rig.nodes[2], t[2])):
                other.rpdo[1]["Controlword"].raw, other.rpdo[1]["Target torque"].raw = 0x0F, tq
                other.rpdo[1].transmit()
            _sync(rig)
    elif fault == "nmt_stop_in_operation":
        node.nmt.send_command(0x02)  # NMT stop of drive 2 alone
        node.nmt.send_command(0x01)  # and start again: it stays in FAULT
    else:
        _cycle(rig, [200, 1500, 100], on)  # beyond +-1000 per mille of 0x6076
    # the EMCY may come before a wait() would start: the log is polled
    _until(lambda: any(e.code == FAULTS[fault] for e in node.emcy.log), f"EMCY {fault}")
    emcy = [e for e in node.emcy.log if e.code == FAULTS[fault]]
    assert len(emcy) == 1 and emcy[0].register & 0x01, (fault, node.emcy.log)
    assert rig.tpdos.empty()  # every SYNC's TPDOs were taken in its period
    latched = [_sw(_cycle(rig, t, on), 2) for _ in range(3)]  # enable operation: no effect
    assert all(sw & 0x4F == 0x08 for sw in latched), [hex(s) for s in latched]  # FAULT
    assert node.sdo[0x603F].raw == FAULTS[fault] and node.sdo[0x1001].raw & 0x01
    for other in (rig.nodes[0], rig.nodes[2]):
        assert other.sdo[0x6041].raw & 0x6F == 0x27  # the other axes are not affected
    # the 402 fault reset, then the enabling sequence, all in the RPDOs
    for cw in (0x80, 0x06, 0x07, 0x0F):
        got = _cycle(rig, t, [0x0F, cw, 0x0F])
    assert _sw(got, 2) & 0x6F == 0x27 and node.sdo[0x1001].raw == 0
    assert any(e.code == 0x0000 for e in node.emcy.log)  # the error-reset EMCY
    for _ in range(3):
        _cycle(rig, t, on)
    summary = _shut_down(rig)
    assert summary["exit"] == 7, rig.plant.stderr  # completed, but the safety policy fired
    d = summary["drives"][1]
    assert d["faults"] == 1 and d["fault_resets"] == 1 and summary["drive_faults"] == 1, d
    assert [x["faults"] for x in summary["drives"]] == [0, 1, 0]
    log = np.loadtxt(rig.log_path, delimiter=",", skiprows=1, ndmin=2)
    u2 = log[:, 9]  # the voltage applied to joint 2 per period
    run = np.abs(log[:, 8] - 200 * U_MAX / 1000) < 1e-12  # joint 1 commanded
    assert run.sum() >= 12
    # 0 V to joint 2 while latched (and through the reset sequence), joint 1 unaffected
    assert np.count_nonzero(run & (u2 == 0.0)) >= 6
    assert u2[-1] == pytest.approx(300 * U_MAX / 1000, abs=1e-12)  # torque again after reset


def test_quick_stop_holds_0_V_until_enable_operation(rig: Rig) -> None:
    """Controlword quick stop (0x02) in OPERATION ENABLED: QUICK STOP ACTIVE (statusword
    0x07 under mask 0x6F), 0 V; no EMCY, no fault; enable operation (0x0F) leaves it."""
    _boot_and_enable(rig)
    node = rig.nodes[2]
    node.emcy.reset()
    t = [200, 300, 100]
    _cycle(rig, t, [0x0F] * 3)
    got = _cycle(rig, t, [0x0F, 0x0F, 0x02])
    assert _sw(got, 3) & 0x6F == 0x07  # QUICK STOP ACTIVE
    got = _cycle(rig, t, [0x0F, 0x0F, 0x02])
    assert _sw(got, 3) & 0x6F == 0x07
    got = _cycle(rig, t, [0x0F] * 3)
    assert _sw(got, 3) & 0x6F == 0x27  # enable operation: back to OPERATION ENABLED
    _cycle(rig, t, [0x0F] * 3)
    assert not node.emcy.log
    summary = _shut_down(rig)
    assert summary["exit"] == 0 and summary["drive_faults"] == 0, rig.plant.stderr
    log = np.loadtxt(rig.log_path, delimiter=",", skiprows=1, ndmin=2)
    u3 = log[-4:, 10]
    assert u3[0] == 0.0 and u3[1] == 0.0  # the two quick-stop periods
    assert u3[-1] == pytest.approx(100 * U_MAX / 1000, abs=1e-12)


def _rows(log: np.ndarray, u1: float) -> np.ndarray:
    """The log rows of the periods whose joint 1 voltage is u1 (a phase's marker)."""
    return log[np.abs(log[:, 8] - u1) < 1e-12]


def test_quick_stop_option_and_max_torque_written_by_sdo(rig: Rig) -> None:
    """0x605A and 0x6072 written by SDO with the ``canopen`` package: an unsupported quick stop
    option code is aborted with 0x06090030; with code 0 a quick stop ends in SWITCH ON DISABLED
    at once (0 V, no EMCY, enable operation alone does not bring it back); a target torque
    beyond a lowered max torque in an RPDO is a fault (EMCY 0x6320, FAULT, 0 V) that enable
    operation does not clear and the 402 fault reset does."""
    _boot_and_enable(rig)
    n2, n3 = rig.nodes[1], rig.nodes[2]
    for node in rig.nodes:
        node.emcy.reset()
    for code in (3, 7, -1):
        with pytest.raises(canopen.SdoAbortedError) as err:
            n3.sdo[0x605A].raw = code
        assert err.value.code == 0x06090030, code
    assert n3.sdo[0x605A].raw == 6 and n3.sdo[0x6072].raw == 1000  # the defaults
    n3.sdo[0x605A].raw = 0  # disable drive function
    assert n3.sdo[0x605A].raw == 0
    # phase A (joint 1 at 200 per mille): drive 3 quick-stopped with code 0
    t = [200, 240, 100]
    states = [_sw(_cycle(rig, t, [0x0F, 0x0F, cw]), 3) for cw in (0x0F, 0x02, 0x0F, 0x06, 0x07,
                                                                    0x0F)]
    assert [s & 0x6F for s in states] == [0x27, 0x40, 0x40, 0x21, 0x23, 0x27], \
        [hex(s) for s in states]  # SWITCH ON DISABLED at once, then the 402 sequence
    assert not n3.emcy.log  # a quick stop is not a fault
    # phase B (joint 1 at 210): drive 2's max torque lowered to 250 per mille, 300 commanded
    with pytest.raises(canopen.SdoAbortedError) as err:
        n2.sdo[0x6072].raw = 200  # below the target torque in force (240)
    assert err.value.code == 0x06090032
    n2.sdo[0x6072].raw = 250
    t = [210, 300, 100]
    got = _cycle(rig, t, [0x0F] * 3)
    _until(lambda: n2.emcy.log, "EMCY 0x6320")
    assert [(e.code, e.register) for e in n2.emcy.log] == [(0x6320, 0x21)]
    t = [210, 200, 100]  # within the limit now: enable operation still does not clear it
    latched = [_sw(_cycle(rig, t, [0x0F] * 3), 2) for _ in range(3)]
    assert all(s & 0x4F == 0x08 for s in [_sw(got, 2), *latched])  # FAULT throughout
    assert n2.sdo[0x603F].raw == 0x6320 and n2.sdo[0x1001].raw == 0x21
    with pytest.raises(canopen.SdoAbortedError) as err:
        n2.sdo[0x6071].raw = 251  # by SDO: refused, not a fault
    assert err.value.code == 0x06090031
    # phase C (joint 1 at 220): the 402 fault reset, the sequence, 200 per mille <= 250
    t = [220, 200, 100]
    states = [_sw(_cycle(rig, t, [0x0F, cw, 0x0F]), 2) for cw in (0x80, 0x06, 0x07, 0x0F, 0x0F)]
    assert [s & 0x6F for s in states] == [0x40, 0x21, 0x23, 0x27, 0x27], [hex(s) for s in states]
    assert n2.sdo[0x1001].raw == 0 and [e.code for e in n2.emcy.log] == [0x6320, 0x0000]
    summary = _shut_down(rig)
    assert summary["exit"] == 7, rig.plant.stderr  # drive 2 latched a fault
    d1, d2, d3 = summary["drives"]
    assert (d2["faults"], d2["fault_resets"], d2["zero_periods"]) == (1, 1, 4), d2  # B, below
    assert (d3["faults"], d3["fault_resets"], d3["zero_periods"]) == (0, 0, 0), d3  # no QSA
    assert d1["faults"] == 0 and d1["zero_periods"] == 0
    assert d2["sdo_aborts"] == 3 and d3["sdo_aborts"] == 4  # the set-up's 0x6041 write too
    log = np.loadtxt(rig.log_path, delimiter=",", skiprows=1, ndmin=2)
    a, b, c = _rows(log, 2.0), _rows(log, 2.1), _rows(log, 2.2)
    assert a[:, 10].tolist() == pytest.approx([1.0, 0.0, 0.0, 0.0, 0.0, 1.0], abs=1e-12)
    assert len(b) == 4 and np.all(b[:, 9] == 0.0)  # 0 V to joint 2 while latched
    assert c[:, 9].tolist() == pytest.approx([0.0, 0.0, 0.0, 2.0, 2.0], abs=1e-12)
    assert np.all(np.abs(a[:, 9] - 2.4) < 1e-12) and np.all(c[:, 10] == 1.0)  # the other axes go on


#: (communication, mapping, base COB-ID of cob_id "auto") of each PDO of the drives.
PDOS = {("rpdo", 1): (0x1400, 0x1600, 0x200), ("tpdo", 1): (0x1800, 0x1A00, 0x180),
        ("tpdo", 2): (0x1801, 0x1A01, 0x280)}


def _bus_yml() -> dict[str, Any]:
    """The ros2_canopen bus description of docs/canopen.md (its one yaml block that names the
    CiA 402 driver)."""
    import yaml
    from support.doc_blocks import ROOT, blocks_of

    blocks = [b for b in blocks_of(ROOT / "docs" / "canopen.md")
              if b.lang == "yaml" and "Cia402Driver" in b.text]
    assert len(blocks) == 1
    conf: dict[str, Any] = yaml.safe_load(blocks[0].text)
    return conf


def _sdo_var(node: Any, index: int, sub: int) -> Any:
    """The canopen package's SDO variable of (index, sub) (a VAR object is sub-index 0)."""
    if isinstance(node.object_dictionary[index], canopen.objectdictionary.ODVariable):
        assert sub == 0
        return node.sdo[index]
    return node.sdo[index][sub]


def test_ros2_canopen_bus_yml_replayed(rig: Rig) -> None:
    """The bus.yml of docs/canopen.md replayed as ros2_canopen's master configures the drives at
    boot (each PDO in CiA 301's order, the heartbeat time, the SDO init list), with the canopen
    package: every write accepted and read back; then the PDOs as configured on SYNC, and 0x6098
    reading 0 (a master's homing completes at once)."""
    conf = _bus_yml()
    assert conf["master"]["node_id"] == MASTER_ID and conf["master"]["sync_period"] == 1000
    drives = {n["node_id"]: {**conf["defaults"], **n} for n in conf["nodes"].values()}
    assert sorted(drives) == list(IDS)
    assert all(d["dcf"] == Path(EDS).name for d in drives.values())
    booted: queue.Queue[int] = queue.Queue()
    for i in IDS:
        rig.network.subscribe(0x700 + i, lambda can_id, data, ts: booted.put(can_id)
                              if bytes(data) == b"\0" else None)
    rig.network.nmt.send_command(0x81)
    assert sorted(booted.get(timeout=5) for _ in IDS) == [0x700 + i for i in IDS]
    written = 0
    for node in rig.nodes:
        d = drives[node.id]
        writes: list[tuple[int, int, int]] = []
        for kind in ("rpdo", "tpdo"):
            for number, pdo in d[kind].items():
                comm, mapping, base = PDOS[(kind, int(number))]
                cob = base + node.id if pdo["cob_id"] == "auto" else int(pdo["cob_id"])
                entries = []
                for e in pdo["mapping"]:
                    var = _sdo_var(node, e["index"], e["sub_index"]).od
                    entries.append(e["index"] << 16 | e["sub_index"] << 8
                                   | 8 * len(var.encode_raw(0)))
                writes += [(comm, 1, 0x80000000 | cob), (comm, 2, pdo["transmission"]),
                           (mapping, 0, 0)]
                writes += [(mapping, i, m) for i, m in enumerate(entries, 1)]
                writes += [(mapping, 0, len(entries))]
                if pdo["enabled"]:
                    writes.append((comm, 1, cob))
        writes.append((0x1017, 0, d["heartbeat_producer"]))
        writes += [(e["index"], e["sub_index"], e["value"]) for e in d["sdo"]]
        for index, sub, value in writes:
            _sdo_var(node, index, sub).raw = value
            written += 1
        final = {(index, sub): value for index, sub, value in writes}
        for (index, sub), value in final.items():
            assert _sdo_var(node, index, sub).raw == value, (hex(index), sub)
        node.pdo.read()  # the canopen package reads the mapping back as the drive holds it
        assert [(v.index, v.length) for v in node.tpdo[1]] == [(0x6041, 16), (0x6064, 32),
                                                               (0x6061, 8)]
        assert node.sdo[0x6098].raw == 0  # ros2_canopen's homing: method 0, done at once
    assert written >= 3 * 20
    rig.network.nmt.state = "OPERATIONAL"
    while not rig.tpdos.empty():
        rig.tpdos.get_nowait()
    for _ in range(3):
        rig.network.sync.transmit()
        got = dict(rig.tpdos.get(timeout=5) for _ in range(6))
        for i in IDS:
            t1, t2 = got[0x180 + i], got[0x280 + i]
            assert len(t1) == 7 and t1[6] == 10 and len(t2) == 6
            assert int.from_bytes(t2[4:6], "little", signed=True) == 0  # not enabled: no torque
    summary = _shut_down(rig)
    assert summary["drive_faults"] == 0
    assert all(d["sdo_aborts"] == 0 for d in summary["drives"])
