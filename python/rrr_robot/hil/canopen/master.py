"""A CANopen master of the three simulated CiA 402 drives (``rrr hil canopen``, docs/canopen.md),
built on the unmodified ``canopen`` package: NMT, SDO configuration, the PDO mapping read back,
``BaseNode402`` to OPERATION ENABLED, then the computed-torque law of eq 15 (``Model.ctc``) in
lockstep, one explicit SYNC per period, or in real time (:mod:`.realtime`: python-can's
periodic SYNC sender), against ``rrr_hil_plant --profile canopen`` (:mod:`.drives`). The C
controller node as the master is :mod:`.c_master`; the run's files, :mod:`.results`.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...core.control import CtcGains
from ...core.model import Model
from ...errors import BadInputError, EmcyError, HilError, TamperedError, one_line
from ..nodes import NodeProcess, Progress, open_bus, quiet_bus_threads
from ..results import BenchRun
from .drives import (
    DEFAULT_NODE_IDS,
    EDS_PATH,
    EXPECTED_MAPPING,
    MASTER_NODE_ID,
    MODE_CST,
    DriveInfo,
    inc_to_rad,
    start_drives,
    torque_per_mille,
)
from .realtime import CanopenRealTime, decode_feedback, realtime_process, run_periods

__all__ = ["MasterRun", "check_run", "run_canopen_master"]

#: Over SocketCAN, seconds to wait for the plant node's power-on boot-ups (at least).
POWER_ON_S = 60.0
#: The length of each TPDO by its mapping (bytes): what a drive sends, and all it sends.
TPDO_BYTES = {name: sum(bits for _, bits in EXPECTED_MAPPING[name]) // 8
              for name in ("TPDO1", "TPDO2")}


@dataclass(frozen=True)
class MasterRun:
    """A run of the master: the signals (BenchRun: measured q, qd as decoded, u, u_n, u_c), the
    target torques sent (per mille), the drives, and the plant node's summary."""

    run: BenchRun
    torque_pm: np.ndarray[Any, np.dtype[np.int64]]
    drives: list[DriveInfo]
    plant_summary: dict[str, Any]
    realtime: CanopenRealTime | None = None  # None: lockstep
    master_setup: str | None = None  # the Python master in real time: what was applied


def _sdo(what: str, node: Any, fn: Callable[[], Any]) -> Any:
    """fn() (an SDO transfer of ``node``), its failures as HilError naming the drive."""
    import canopen

    try:
        return fn()
    except canopen.SdoAbortedError as exc:
        raise HilError(f"drive {node.id}: {what}: SDO abort 0x{exc.code:08X} ({exc})") from exc
    except canopen.SdoCommunicationError as exc:
        raise HilError(f"drive {node.id}: {what}: no SDO answer ({exc})") from exc


def _read(node: Any, index: int, sub: int | None = None) -> int:
    """An object's value by SDO upload."""
    what = f"read 0x{index:04X}" + ("" if sub is None else f" sub {sub}")

    def get() -> Any:
        var = node.sdo[index] if sub is None else node.sdo[index][sub]
        return var.raw

    return int(_sdo(what, node, get))


def _write(node: Any, index: int, value: int) -> None:
    """An object's value by SDO download."""

    def put() -> None:
        node.sdo[index].raw = value

    _sdo(f"write 0x{index:04X} = {value}", node, put)


def _mapping(node: Any) -> dict[str, list[tuple[int, int]]]:
    got = {"RPDO1": node.rpdo[1], "TPDO1": node.tpdo[1], "TPDO2": node.tpdo[2]}
    return {name: [(v.index, v.length) for v in m] for name, m in got.items()}


@contextlib.contextmanager
def _quiet_p402() -> Iterator[None]:
    """BaseNode402 warns at every statusword read without TPDO: the enabling is done by SDO."""
    lg = logging.getLogger("canopen.profiles.p402")
    level = lg.level
    lg.setLevel(logging.ERROR)
    try:
        yield
    finally:
        lg.setLevel(level)


class _Master:
    def __init__(self, bus: Any, plant: NodeProcess | None, node_ids: Sequence[int],
                 timeout: float) -> None:
        """On the python-can ``bus``; ``plant``: the node whose end stops a wait (set later
        when the bus is opened before the plant starts, as SocketCAN needs)."""
        import canopen

        self.plant, self.timeout = plant, timeout
        self.bus = bus
        self._hb: Any = None  # the master's heartbeat producer (real time)
        self._sync: Any = None  # the SYNC producer (real time)
        self.syncs = 0  # SYNCs sent
        self.tpdos: dict[int, int] = {}  # TPDOs received, by COB-ID
        self.network = canopen.Network(self.bus)
        drive: Any = canopen.BaseNode402
        self.nodes: list[Any] = [drive(i, str(EDS_PATH)) for i in node_ids]
        self.frames: queue.Queue[tuple[int, bytes]] = queue.Queue()
        for node in self.nodes:
            self.network.add_node(node)
            for cob in (0x180 + node.id, 0x280 + node.id, 0x700 + node.id, 0x80 + node.id):
                self.network.subscribe(cob, self._on_frame)
        # the receive thread starts here, once every subscriber is in: over SocketCAN the
        # power-on boot-ups may be waiting in the socket already
        self.network.connect()

    def _on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self.frames.put((can_id, bytes(data)))

    def _next(self, deadline: float, what: str) -> tuple[int, bytes] | None:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                return self.frames.get(timeout=min(left, 0.2))
            except queue.Empty:
                if self.plant is not None and not self.plant.running():
                    raise HilError(f"the plant node ended while the master waited for {what}: "
                                   f"{self.plant.how_it_ended()}") from None
                failed = getattr(self.network.notifier, "exception", None)
                if failed is not None:  # the bus's receive thread ended (quiet_bus_threads)
                    raise HilError(f"the bus failed while the master waited for {what}: "
                                   f"{' '.join(str(failed).split())}") from None

    def check_tpdo(self, cob: int, data: bytes, k: int) -> None:
        """A TPDO (COB-ID ``cob``) received while the master waits for those of SYNC ``k``:
        each drive sends one TPDO1 and one TPDO2 per SYNC, of their mapped lengths, so one of
        another length, or more of one than SYNCs were sent (a second in a SYNC: forged or
        replayed), is tampered input: TamperedError naming the drive and the frame."""
        name = "TPDO1" if cob & 0x780 == 0x180 else "TPDO2"
        drive = cob & 0x7F
        if len(data) != TPDO_BYTES[name]:
            raise TamperedError(f"drive {drive}: {name} of {len(data)} bytes, "
                                f"{TPDO_BYTES[name]} mapped: a frame the drives never send "
                                "(tampered input?)")
        self.tpdos[cob] = self.tpdos.get(cob, 0) + 1
        if self.tpdos[cob] > self.syncs:
            raise TamperedError(f"drive {drive}: two {name} in SYNC {k}: a frame the drives "
                                "never send (tampered input?)")

    def boot(self, power_on: bool = False) -> None:
        """NMT reset node (a socketcand server drops the power-on boot-up): every drive must
        send its boot-up within the timeout. ``power_on`` (SocketCAN, the bus opened before the
        plant started): first the power-on boot-ups, which tell that the plant listens (a frame
        sent before it has bound its socket is lost to it)."""
        if power_on:  # the plant node's start (unzipping its FMU) is not bounded by timeout
            self._boot_ups("after the plant node started", max(self.timeout, POWER_ON_S))
        self.network.nmt.send_command(0x81)
        self._boot_ups("after NMT reset node", self.timeout)

    def _boot_ups(self, when: str, timeout: float) -> None:
        want = {0x700 + n.id for n in self.nodes}
        deadline = time.monotonic() + timeout
        while want:
            ids = ", ".join(str(c - 0x700) for c in sorted(want))
            got = self._next(deadline, f"the boot-up of drive(s) {ids} {when}")
            if got is None:
                raise HilError(f"drive(s) {ids} sent no boot-up within {timeout:g} s {when}"
                               ": no such node id on the bus?")
            if got[1] == b"\0":
                want.discard(got[0])

    def configure(self) -> list[DriveInfo]:
        """SDO: the mode CST, the rated torque, the encoder resolution, the PDO mapping."""
        drives = []
        for node in self.nodes:
            _write(node, 0x6060, MODE_CST)
            shown = _read(node, 0x6061)
            if shown != MODE_CST:
                raise HilError(f"drive {node.id}: mode of operation display 0x6061 = {shown}, "
                               f"not {MODE_CST} (cyclic synchronous torque)")
            rated, inc, rev = _read(node, 0x6076), _read(node, 0x608F, 1), _read(node, 0x608F, 2)
            _sdo("read the PDO mapping", node, node.pdo.read)
            mapping = _mapping(node)
            if mapping != EXPECTED_MAPPING:
                raise HilError(f"drive {node.id}: PDO mapping {mapping} is not the one this "
                               f"master decodes ({EXPECTED_MAPPING})")
            if rated <= 0 or inc <= 0 or rev != 1:
                raise HilError(f"drive {node.id}: rated torque {rated} mN m, encoder "
                               f"{inc}/{rev}: not a configuration this master handles")
            drives.append(DriveInfo(node.id, rated, inc, mapping))
        return drives

    def enable(self) -> None:
        """BaseNode402 to OPERATION ENABLED (by SDO, in pre-operational: no SYNC, so the plant
        is held at its initial state), then NMT start."""
        for node in self.nodes:
            self._enable(node)
        self.network.nmt.send_command(0x01)  # all nodes operational

    @staticmethod
    def _enable(node: Any) -> None:
        def go() -> None:
            node.state = "OPERATION ENABLED"  # controlword / statusword by SDO

        with _quiet_p402():
            try:
                _sdo("the 402 state machine (controlword by SDO)", node, go)
            except (RuntimeError, ValueError) as exc:
                sw, code = _read(node, 0x6041), _read(node, 0x603F)
                raise HilError(f"drive {node.id} did not reach OPERATION ENABLED ({exc}): "
                               f"statusword 0x{sw:04X}, error code 0x{code:04X}") from exc

    def _bus_failed(self, k: int, exc: Exception) -> HilError:
        if self.plant is None:
            return HilError(f"SYNC {k}: the bus failed ({one_line(exc)})")
        self.plant.died(1.0)  # a plant that was killed: give it the time to be reaped
        lost = ("the plant node " + self.plant.how_it_ended() if not self.plant.running()
                else "the bus failed")
        return HilError(f"SYNC {k}: {lost} ({one_line(exc)})")

    def send_rpdos(self, torques: Sequence[int], k: int) -> None:
        """RPDO1 of each drive: controlword 0x0F (enable operation), the target torque."""
        import can

        try:
            for node, t in zip(self.nodes, torques, strict=True):
                node.rpdo[1]["Controlword"].raw = 0x0F
                node.rpdo[1]["Target torque"].raw = int(t)
                node.rpdo[1].transmit()
        except (can.CanError, OSError) as exc:
            raise self._bus_failed(k, exc) from exc

    def send_sync(self, k: int) -> None:
        """One SYNC."""
        import can

        try:
            self.network.sync.transmit()
        except (can.CanError, OSError) as exc:
            raise self._bus_failed(k, exc) from exc
        self.syncs += 1

    def start_sync(self, period: float) -> None:
        """A SYNC every ``period`` s from python-can's periodic sender (a thread with absolute
        due times and a sleep only: the one canopen's SyncProducer starts), each counted before
        it is sent."""
        import can

        def count(msg: Any) -> None:
            self.syncs += 1

        sync = can.Message(arbitration_id=0x080, data=b"", is_extended_id=False)
        self._sync = self.bus.send_periodic(sync, period, modifier_callback=count)

    def stop_sync(self) -> None:
        task, self._sync = self._sync, None
        if task is not None:
            task.stop()

    def next_frame(self, timeout: float, what: str) -> tuple[int, bytes] | None:
        """The next frame of the drives within ``timeout`` s (None after it)."""
        return self._next(time.monotonic() + timeout, what)

    def start_heartbeat(self, master_id: int, period_ms: int, consumer_ms: int) -> None:
        """The master's heartbeat producer (0x700 + ``master_id``, NMT state operational, every
        ``period_ms``) and each drive's consumer 0x1016 sub 1 of it (``consumer_ms``)."""
        self._hb = self.network.send_periodic(0x700 + master_id, bytes([0x05]),
                                              period_ms * 1e-3)
        for node in self.nodes:
            def put(node: Any = node) -> None:
                node.sdo[0x1016][1].raw = (master_id << 16) | consumer_ms

            _sdo(f"write 0x1016 sub 1 (consumer of node {master_id}, {consumer_ms} ms)", node,
                 put)

    def set_rpdo_timeout(self, periods: int) -> None:
        """Each drive's RPDO timeout 0x2001: SYNC periods without an RPDO before it faults."""
        for node in self.nodes:
            _write(node, 0x2001, periods)

    def stop_heartbeat(self) -> None:
        """The master's heartbeat stops (fault injection: the drives' consumer must fault)."""
        hb = self._hb
        if hb is not None:
            hb.stop()
            self._hb = None

    def period(self, torques: Sequence[int], k: int) -> list[tuple[int, int, int]]:
        """The RPDOs (controlword 0x0F, target torque), one SYNC, the six TPDOs: per drive
        (statusword, position, velocity)."""
        self.send_rpdos(torques, k)
        self.send_sync(k)
        got: dict[int, bytes] = {}
        deadline = time.monotonic() + self.timeout
        while len(got) < 2 * len(self.nodes):
            f = self._next(deadline, f"the TPDOs of SYNC {k}")
            if f is None:
                raise HilError(f"SYNC {k}: TPDOs of {len(got)} of {2 * len(self.nodes)} within "
                               f"{self.timeout:g} s")
            cob, data = f
            if 0x80 < cob < 0x100:
                raise EmcyError(k, cob - 0x80, int.from_bytes(data[:2], "little"))
            if (cob & 0x780) in (0x180, 0x280):
                self.check_tpdo(cob, data, k)
                got[cob] = data
        return decode_feedback(k, [node.id for node in self.nodes], got)

    def finish(self) -> None:
        """Disable the drives (controlword 0 by SDO); with the master's heartbeat running, the
        drives' consumer 0x1016 off and then the heartbeat; NMT stop."""
        for node in self.nodes:
            _write(node, 0x6040, 0)  # disable voltage
        if self._hb is not None:
            for node in self.nodes:
                def off(node: Any = node) -> None:
                    node.sdo[0x1016][1].raw = 0

                _sdo("write 0x1016 sub 1 = 0 (consumer off)", node, off)
            self.stop_heartbeat()
        self.network.nmt.send_command(0x02)
        time.sleep(0.05)

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.stop_sync()
        with contextlib.suppress(Exception):
            self.stop_heartbeat()
        with contextlib.suppress(Exception):
            self.network.disconnect()


def check_run(t: FloatArray, q_ref: FloatArray, node_ids: Sequence[int], interface: str,
              realtime: CanopenRealTime | None) -> None:
    """BadInputError for a master run that cannot be: an unknown interface, a reference of
    fewer than 2 periods or not of 3 joints, other than three node ids, in real time a drive
    with the master's own node id."""
    if interface not in ("socketcand", "socketcan"):
        raise BadInputError(f"interface must be socketcand or socketcan, got {interface!r}")
    n = t.shape[0]
    if n < 2 or q_ref.shape != (n, 3):
        raise BadInputError(f"the reference needs at least 2 periods of 3 joints, got "
                            f"{q_ref.shape}")
    if len(node_ids) != 3:
        raise BadInputError(f"three node ids expected (one per axis), got {list(node_ids)}")
    if realtime is not None and MASTER_NODE_ID in node_ids:
        raise BadInputError(f"node id {MASTER_NODE_ID} is the master's own (its heartbeat) in "
                            "real time: give the drives others")


def run_canopen_master(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
                       qdd_ref: FloatArray, model: Model, gains: CtcGains, work: Path, *,
                       node_ids: Sequence[int] = DEFAULT_NODE_IDS, timeout: float = 5.0,
                       progress: Progress | None = None, interface: str = "socketcand",
                       channel: str = "vcan0", realtime: CanopenRealTime | None = None,
                       ) -> MasterRun:
    """Start ``rrr_hil_plant --profile canopen`` (logs ``work``/plant.csv and the frame log
    NODE_FRAMES, the arm at q_ref[0],
    qd_ref[0]) and master its drives ``node_ids`` along the reference with the computed-torque
    law of ``model`` (the controller's) and ``gains``: u_k = ctc(x_k decoded from the TPDOs of
    SYNC k), target torque = k_t u_k in per mille. ``interface``: ``socketcand`` (the plant
    is the server on loopback TCP) or ``socketcan`` (both on the SocketCAN interface
    ``channel``, python-can's socketcan interface under ``canopen.Network``; the plant ends
    STOP_END_MS_SOCKETCAN after the master's NMT stop). HilError when a drive does not boot or
    enable, on an SDO abort, a lost plant or a timeout (``timeout`` s per wait).

    ``realtime`` (:mod:`.realtime`): python-can's periodic SYNC sender every period instead of
    lockstep, the master's heartbeat watched by the drives (0x1016), the drives' RPDO timeout
    if given, the law on the newest TPDOs."""
    check_run(t, q_ref, node_ids, interface, realtime)
    n = t.shape[0]
    kt = [float(v) for v in model.kt]
    q_rec, qd_rec, out = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 9))
    pm = np.zeros((n, 3), dtype=np.int64)
    start = time.perf_counter()
    sc = interface == "socketcan"
    # SocketCAN: the master's socket first, so that the plant's power-on boot-ups reach it
    bus = open_bus("socketcan", channel=channel) if sc else None
    try:
        plant = start_drives(q_ref, qd_ref, Path(work), channel if sc else None,
                             None if realtime is None else realtime.fifo, timeout=timeout)
    except BaseException:
        if bus is not None:
            bus.shutdown()
        raise
    # real time from here (after the plant's start): the master's threads
    with plant, quiet_bus_threads(), (contextlib.nullcontext() if realtime is None
                                      else realtime_process(realtime)) as setup:
        master = _Master(bus if sc else open_bus("socketcand", port=int(plant.port or 0)),
                         plant, node_ids, timeout)
        try:
            master.boot(power_on=sc)
            drives = master.configure()
            master.enable()
            def law(k: int, fb: list[tuple[int, int, int]]) -> list[int]:
                """u_k of the newest TPDOs (SYNC k), the target torques in per mille; the
                rows of SYNCs the master did not answer (real time) hold the last values."""
                for j, d in enumerate(drives):
                    q_rec[k, j] = inc_to_rad(fb[j][1], d.increments)
                    qd_rec[k, j] = inc_to_rad(fb[j][2], d.increments)
                u, u_n, u_c = model.ctc(gains, q_ref[k], qd_ref[k], qdd_ref[k], q_rec[k],
                                        qd_rec[k])
                out[k, 0:3], out[k, 3:6], out[k, 6:9] = u, u_n, u_c
                pm[k] = [torque_per_mille(float(u[j]), kt[j], d.rated_torque_mNm)
                         for j, d in enumerate(drives)]
                first = filled[0] + 1
                if first < k:
                    for a in (q_rec, qd_rec, out, pm):
                        a[first:k] = a[first - 1] if first else a[k]
                filled[0] = k
                return [int(v) for v in pm[k]]

            filled = [-1]
            if realtime is None:
                every = max(1, n // 100)
                fb = master.period([0, 0, 0], 0)  # the first SYNC: the initial state, no step
                for k in range(n):
                    torques = law(k, fb)
                    if k < n - 1:
                        fb = master.period(torques, k + 1)
                    if progress is not None and (k % every == 0 or k == n - 1):
                        progress(k + 1, n)
            else:
                master.start_heartbeat(MASTER_NODE_ID, realtime.heartbeat_ms,
                                       realtime.consumer_ms)
                if realtime.rpdo_timeout is not None:
                    master.set_rpdo_timeout(realtime.rpdo_timeout)
                run_periods(master, n, law, realtime, progress)
            master.finish()
        finally:
            master.close()
        summary = plant.wait(30)
    if summary.get("exit") != 0:
        raise HilError(f"the plant node ended with exit {summary.get('exit')} "
                       f"(drive faults {summary.get('drive_faults')}): {plant.stderr.strip()}")
    run = BenchRun(t=t, q=q_rec, qd=qd_rec, u=out[:, 0:3], plant_summary=summary,
                   controller_summary={"exit": 0, "profile": "canopen", "transport": interface,
                                       "node_ids": list(node_ids)},
                   u_n=out[:, 3:6], u_c=out[:, 6:9], wall_time=time.perf_counter() - start)
    return MasterRun(run, pm, drives, summary, realtime, setup)
