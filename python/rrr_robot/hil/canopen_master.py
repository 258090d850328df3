"""A CANopen master of the three simulated CiA 402 drives (``rrr hil canopen``, docs/canopen.md),
built on the unmodified ``canopen`` package: NMT, SDO configuration, the PDO mapping read back,
``BaseNode402`` to OPERATION ENABLED, then the computed-torque law of eq 15 (``Model.ctc``) in
lockstep, one explicit SYNC per period, against ``rrr_hil_plant --profile canopen``.

The PDO units (docs/canopen.md, "Units"): position and velocity in increments (2^20 per
revolution, 0x608F), target torque in per mille of the rated torque 0x6076 (mN m). The same
quantisation as co-simulation hooks (:func:`pdo_quantisation`) gives the run's exact reference.
"""

from __future__ import annotations

import contextlib
import logging
import math
import queue
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.control import CtcGains
from ..core.model import Model
from ..core.outputs import ResultSet
from ..errors import BadInputError
from ..writing.trajectory import Reference
from .bench import BenchRun, LogProgress, boot_up_watch, wait_node
from .canopen_rt import (
    CONSUMER_MS,
    HEARTBEAT_MS,
    MASTER_ID,
    CanopenRealTime,
    RtRecord,
    decode_feedback,
    realtime_process,
    run_periods,
)
from .cia402 import DEFAULT_NODE_IDS, EDS_PATH
from .logspec import CONTROLLER_LOG, read_log
from .nodes import (
    NodeProcess,
    controller_node_args,
    export_reference,
    failure_folder,
    open_bus,
    start_controller,
    start_plant,
    wait_for_boot_up,
)
from .protocol import HilError

__all__ = ["DEFAULT_NODE_IDS", "DriveInfo", "MasterRun", "WritingController", "inc_to_rad",
           "pdo_quantisation", "rad_to_inc", "run_c_master", "run_canopen_master",
           "torque_per_mille", "write_master_results", "writing_controller"]

#: CiA 402 mode of operation: cyclic synchronous torque.
MODE_CST = 10
#: The PDO mapping the master expects (read back by SDO): RPDO1, TPDO1, TPDO2 as (index, bits).
EXPECTED_MAPPING = {"RPDO1": [(0x6040, 16), (0x6071, 16)],
                    "TPDO1": [(0x6041, 16), (0x6064, 32)],
                    "TPDO2": [(0x606C, 32), (0x6077, 16)]}
#: The plant node's own frame log (hil_framelog.h: every frame it sent and received), and the
#: standard frame log written from it.
NODE_FRAMES = "frames.rrrcan"
CAN_LOG = "frames.blf"

Progress = Callable[[int, int], None]
#: Over SocketCAN there is no hang-up: the plant ends when the master is silent this long (ms).
IDLE_MS_SOCKETCAN = 1000
#: Over SocketCAN, seconds to wait for the plant node's power-on boot-ups (at least).
POWER_ON_S = 60.0


def _lround(x: float) -> int:
    """C's lround: halves away from zero (Python's round goes to even)."""
    a = abs(x)
    r = math.floor(a)
    if a - r >= 0.5:
        r += 1
    return int(r) if x >= 0 else -int(r)


def rad_to_inc(x: float, increments: int) -> int:
    """rad (or rad/s) to increments (per s) as the drive computes them (rrr_co_rad_to_inc)."""
    v = x * float(increments) / (2.0 * math.pi)
    if v != v:
        return 0
    return max(-(1 << 31), min((1 << 31) - 1, _lround(v)))


def inc_to_rad(n: int, increments: int) -> float:
    """Increments (per s) to rad (rad/s): n 2 pi / increments."""
    return n * (2.0 * math.pi) / float(increments)


def torque_per_mille(u: float, kt: float, rated_mNm: int) -> int:
    """The target torque 0x6071 of the voltage ``u``: tau = k_t u (N m), in per mille of the
    rated torque (mN m), rounded, within -1000..1000."""
    return max(-1000, min(1000, _lround(kt * u * 1e6 / float(rated_mNm))))


def pdo_quantisation(kt_master: Sequence[float], kt_plant: Sequence[float],
                     rated_mNm: Sequence[int], increments: int = 1 << 20,
                     ) -> tuple[Callable[[FloatArray], FloatArray],
                                Callable[[FloatArray], FloatArray]]:
    """(measure, actuate) of a co-simulation (CosimOptions) with the PDOs' resolutions: the
    master sees q, qd through increments; the plant applies u = t rated 1e-6 / k_t of the
    target torque t the master computes from its u (the drive's arithmetic)."""

    def measure(x: FloatArray) -> FloatArray:
        return np.array([inc_to_rad(rad_to_inc(float(v), increments), increments) for v in x])

    def actuate(u: FloatArray) -> FloatArray:
        return np.array([torque_per_mille(float(u[i]), kt_master[i], rated_mNm[i])
                         * float(rated_mNm[i]) * 1e-6 / kt_plant[i] for i in range(3)])

    return measure, actuate


@dataclass(frozen=True)
class DriveInfo:
    """What the master read of one drive by SDO."""

    node_id: int
    rated_torque_mNm: int
    increments: int  # per revolution (0x608F sub 1 / sub 2)
    mapping: dict[str, list[tuple[int, int]]]


@dataclass(frozen=True)
class MasterRun:
    """A run of the master: the signals (BenchRun: measured q, qd as decoded, u, u_n, u_c), the
    target torques sent (per mille), the drives, and the plant node's summary."""

    run: BenchRun
    torque_pm: np.ndarray[Any, np.dtype[np.int64]]
    drives: list[DriveInfo]
    plant_summary: dict[str, Any]
    realtime: CanopenRealTime | None = None  # None: lockstep
    rt_record: RtRecord | None = None  # the Python master's own timing in real time


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
            got = self._next(deadline, "the boot-up messages")
            if got is None:
                ids = ", ".join(str(c - 0x700) for c in sorted(want))
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
            return HilError(f"SYNC {k}: the bus failed ({' '.join(str(exc).split())})")
        self.plant.died(1.0)  # a plant that was killed: give it the time to be reaped
        lost = ("the plant node " + self.plant.how_it_ended() if not self.plant.running()
                else "the bus failed")
        return HilError(f"SYNC {k}: {lost} ({' '.join(str(exc).split())})")

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
                raise HilError(f"SYNC {k}: EMCY 0x{int.from_bytes(data[:2], 'little'):04X} "
                               f"from drive {cob - 0x80}")
            if (cob & 0x780) in (0x180, 0x280):
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
            self.stop_heartbeat()
        with contextlib.suppress(Exception):
            self.network.disconnect()


def _start_drives(q_ref: FloatArray, qd_ref: FloatArray, work: Path,
                  socketcan: str | None, fifo: int | None = None) -> NodeProcess:
    """``rrr_hil_plant --profile canopen`` at (q_ref[0], qd_ref[0]), logging ``work``/plant.csv
    and NODE_FRAMES; on the SocketCAN interface ``socketcan``, or as socketcand server.
    ``fifo`` (real time): ``--realtime --mlock`` and SCHED_FIFO ``fifo`` (0: none)."""
    idle = ["--idle-timeout-ms", str(IDLE_MS_SOCKETCAN)] if socketcan else []
    rt = [] if fifo is None else ["--realtime", "--mlock", *(["--fifo", str(fifo)] if fifo
                                                             else [])]
    return start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=work / "plant.csv",
                       frame_log=work / NODE_FRAMES, socketcan=socketcan,
                       extra=["--profile", "canopen", *idle, *rt])


def _check_run(t: FloatArray, q_ref: FloatArray, node_ids: Sequence[int], interface: str) -> None:
    """BadInputError for a master run that cannot be: an unknown interface, a reference of
    fewer than 2 periods or not of 3 joints, other than three node ids."""
    if interface not in ("socketcand", "socketcan"):
        raise BadInputError(f"interface must be socketcand or socketcan, got {interface!r}")
    n = t.shape[0]
    if n < 2 or q_ref.shape != (n, 3):
        raise BadInputError(f"the reference needs at least 2 periods of 3 joints, got "
                            f"{q_ref.shape}")
    if len(node_ids) != 3:
        raise BadInputError(f"three node ids expected (one per axis), got {list(node_ids)}")


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
    IDLE_MS_SOCKETCAN after the master's NMT stop). HilError when a drive does not boot or
    enable, on an SDO abort, a lost plant or a timeout (``timeout`` s per wait).

    ``realtime`` (canopen_rt): SYNC by the clock every period instead of lockstep, the master's
    heartbeat watched by the drives (0x1016), the law on the newest TPDOs and the RPDOs before
    the next SYNC; the run's timing in ``MasterRun.realtime``."""
    _check_run(t, q_ref, node_ids, interface)
    if realtime is not None and MASTER_ID in node_ids:
        raise BadInputError(f"node id {MASTER_ID} is the master's own (its heartbeat) in real "
                            "time: give the drives others")
    rec: RtRecord | None = None
    n = t.shape[0]
    kt = [float(v) for v in model.kt]
    q_rec, qd_rec, out = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 9))
    pm = np.zeros((n, 3), dtype=np.int64)
    start = time.perf_counter()
    sc = interface == "socketcan"
    # SocketCAN: the master's socket first, so that the plant's power-on boot-ups reach it
    bus = open_bus("socketcan", channel=channel) if sc else None
    try:
        plant = _start_drives(q_ref, qd_ref, Path(work), channel if sc else None,
                              None if realtime is None else realtime.fifo)
    except BaseException:
        if bus is not None:
            bus.shutdown()
        raise
    # real time from here (after the plant's start): the master's threads
    rec = None if realtime is None else RtRecord()
    with plant, (contextlib.nullcontext() if rec is None or realtime is None
                 else realtime_process(realtime, rec)):
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
                assert rec is not None
                master.start_heartbeat(MASTER_ID, realtime.heartbeat_ms, realtime.consumer_ms)
                run_periods(master, n, law, realtime, rec, progress)
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
    return MasterRun(run, pm, drives, summary, realtime, rec)


def run_c_master(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                 model: Model, controller_values: Mapping[str, float | bool], work: Path, *,
                 node_ids: Sequence[int] = DEFAULT_NODE_IDS, timeout: float = 5.0,
                 progress: Progress | None = None, interface: str = "socketcand",
                 channel: str = "vcan0", realtime: CanopenRealTime | None = None) -> MasterRun:
    """As :func:`run_canopen_master`, with the C controller node as the master
    (``rrr_hil_controller --profile canopen``: the same NMT, SDO and 402 sequence, the core's
    computed-torque law with the controller FMU's ``controller_values``, one SYNC per period).
    ``model`` is the same controller model (its k_t give the target torques of the log's u).
    HilError when a node fails: the C master's exit status and its reason. ``realtime``: the C
    master's ``--realtime`` (its rrr_hil_rt clock, SCHED_FIFO ``realtime.fifo`` and mlockall
    when permitted, the spin; the SYNC source is its clock, the heartbeat and consumer times are
    the C master's RRR_COM_HEARTBEAT_MS / RRR_COM_CONSUMER_MS, the same 20 ms and 100 ms), and
    the plant's."""
    _check_run(t, q_ref, node_ids, interface)
    if realtime is not None and (realtime.sync_source != "clock"
                                 or realtime.heartbeat_stop_at is not None
                                 or (realtime.heartbeat_ms, realtime.consumer_ms)
                                 != (HEARTBEAT_MS, CONSUMER_MS)):
        raise BadInputError("the C master in real time: SYNC by its own clock, heartbeat "
                            f"{HEARTBEAT_MS} ms and consumer {CONSUMER_MS} ms only")
    if realtime is not None and MASTER_ID in node_ids:
        raise BadInputError(f"node id {MASTER_ID} is the master's own (its heartbeat) in real "
                            "time: give the drives others")
    n = t.shape[0]
    sc = interface == "socketcan"
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="rrr_co_") as tmp:
        ref_csv = export_reference(t, q_ref, qd_ref, qdd_ref, Path(tmp) / "reference.csv")
        ctrl_log = Path(tmp) / "controller.csv"
        with contextlib.ExitStack() as stack:
            boot = 0x700 + DEFAULT_NODE_IDS[0]  # the plant's first drive
            watch = stack.enter_context(boot_up_watch(channel, boot_id=boot)) if sc else None
            plant = stack.enter_context(_start_drives(
                q_ref, qd_ref, Path(work), channel if sc else None,
                None if realtime is None else realtime.fifo))
            if watch is not None:
                wait_for_boot_up(watch, plant, boot_id=boot)
            extra = ["--profile", "canopen", "--node-ids", ",".join(str(i) for i in node_ids),
                     "--timeout-ms", str(round(timeout * 1000)),
                     *controller_node_args(controller_values)]
            if realtime is not None:
                extra += ["--realtime", "--mlock", "--spin-us", str(realtime.spin_us),
                          *(["--fifo", str(realtime.fifo)] if realtime.fifo else [])]
            ctrl = stack.enter_context(start_controller(
                ref_csv, connect=f"127.0.0.1:{plant.port}", log_csv=ctrl_log, extra=extra,
                socketcan=channel if sc else None))
            cs = wait_node(ctrl, 60.0 + n * 0.01, LogProgress(ctrl_log, n, progress))
            if cs.get("exit") != 0:
                dead = plant if plant.died() else ctrl
                plant.close()
                raise dead.failure("the CANopen bench (C master) failed", failure_folder(work))
            ps = plant.wait(30)
        if ps.get("exit") != 0:
            raise HilError(f"the plant node ended with exit {ps.get('exit')} "
                           f"(drive faults {ps.get('drive_faults')}): {plant.stderr.strip()}")
        c = read_log(ctrl_log, CONTROLLER_LOG)
    u = c.group("u")
    drives = [DriveInfo(int(i), int(r), int(inc), EXPECTED_MAPPING)
              for i, r, inc in zip(cs["node_ids"], cs["rated_torque_mNm"],
                                   cs["increments_per_revolution"], strict=True)]
    kt = [float(v) for v in model.kt]
    pm = np.array([[torque_per_mille(float(row[j]), kt[j], d.rated_torque_mNm)
                    for j, d in enumerate(drives)] for row in u], dtype=np.int64)
    run = BenchRun(t=t, q=c.group("q"), qd=c.group("qd"), u=u, plant_summary=ps,
                   controller_summary={**cs, "transport": interface, "master": "c"},
                   u_n=c.group("u_n"), u_c=c.group("u_c"), wall_time=time.perf_counter() - start)
    return MasterRun(run, pm, drives, ps, realtime)


@dataclass(frozen=True)
class WritingController:
    """The writing task's reference and a scenario's controller, as ``rrr hil bench`` runs
    them (writing.job.prepare): the true model (the plant's), the controller's model and gains,
    and the controller FMU's start values of the same (the co-simulations')."""

    ref: Reference
    model: Model
    controller_model: Model
    gains: CtcGains
    controller_values: dict[str, float | bool]


def writing_controller(text: str | None = None, scenario: str = "ctc") -> WritingController:
    """The writing reference and the controller of ``scenario`` (pd, ctc, mismatch or a
    scenario .toml) on the default robot."""
    from ..writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), text=text,
                                                      scenarios=[scenario]))
    scn, control = scenarios[0], robot.require_control()
    gains = CtcGains(kp=scn.kp or control.kp, kd=scn.kd or control.kd,
                     feedforward=scn.feedforward)
    return WritingController(ref, model, scn.controller_model(model), gains,
                             controller_fmu_values(scn, model, control))


def write_master_results(rs: ResultSet, wc: WritingController, mrun: MasterRun, *,
                         scenario: str, figures: bool = True) -> dict[str, Any]:
    """The run's files into the result set: controller.csv (the master's log), plant.csv and
    the frame log NODE_FRAMES (already there: the plant node's), frames.blf (the same frames),
    summary.json (results.bench_summary, core.summary) and the figures. Returns the summary."""
    from ..core.summary import write_summary
    from . import framelog as fl
    from .bench import write_controller_log
    from .busload import canopen_load, measured_load
    from .results import bench_result, bench_summary, read_plant_log, unquantised_cosim

    work = rs.staging
    write_controller_log(mrun.run, work / "controller.csv")
    bench = bench_result(wc.ref, mrun.run, read_plant_log(work / "plant.csv"))
    if bench.t.shape[0] != wc.ref.t.shape[0]:
        raise HilError(f"the plant logged {bench.t.shape[0]} periods of {wc.ref.t.shape[0]}")
    unq = unquantised_cosim(wc.ref, wc.model, wc.controller_values)
    n = bench.t.shape[0]
    records = fl.read_node_log(work / NODE_FRAMES)
    fl.write_can_log(records, rs.path(CAN_LOG))
    bus = {"profile": "canopen", "node_log": NODE_FRAMES, "can_log": CAN_LOG,
           "view": "the C plant node's (Tx: the drives' frames, Rx: the master's)",
           **fl.rates(records), "measured_1mbit": measured_load(fl.frames(records), n),
           "node_ids": [d.node_id for d in mrun.drives],
           "sync_periods": n, "frames_per_period": 1 + 3 * len(mrun.drives),
           "schedule_worst_percent_1mbit": canopen_load(1_000_000).worst_percent,
           "drives": [{"node_id": d.node_id, "rated_torque_mNm": d.rated_torque_mNm,
                       "increments_per_revolution": d.increments,
                       "pdo_mapping": {k: [f"0x{i:04X}:{b}" for i, b in v]
                                       for k, v in d.mapping.items()}}
                      for d in mrun.drives],
           "target_torque_per_mille_max_abs": np.abs(mrun.torque_pm).max(axis=0).tolist()}
    drives = mrun.plant_summary.get("drives", [])
    # the drives' faults and missed commands (RPDO timeouts), in the DBC plant's keys
    plant = {**mrun.plant_summary, "faults": mrun.plant_summary.get("drive_faults"),
             "cmd_missed": sum(int(d.get("rpdo_timeouts", 0)) for d in drives)}
    realtime, latencies = None, None
    if mrun.realtime is not None:
        from .canopen_rt import frame_log_timing, realtime_summary

        realtime = realtime_summary(mrun.realtime, mrun.rt_record,
                                    frame_log_timing(records, [d.node_id for d in mrun.drives]),
                                    mrun.run.controller_summary
                                    if mrun.run.controller_summary.get("master") == "c" else None,
                                    mrun.plant_summary.get("rt_setup"))
        bus["sync_periods"] = realtime["drives"]["syncs"]
        wake = realtime.get("master", {}).get("wake_up")
        if mrun.rt_record is not None and mrun.rt_record.latency_ns:
            latencies = {"master": np.asarray(mrun.rt_record.latency_ns, dtype=float)}
    summary = bench_summary(side="canopen", mode="lockstep" if realtime is None else "realtime",
                            scenario=scenario, ref=wc.ref, bench=bench, unquantised=unq,
                            plant=plant, controller=mrun.run.controller_summary, bus=bus,
                            realtime=realtime)
    if figures:
        from .figures import write_bench_figures

        write_bench_figures(work, wc.ref, bench, unq, latencies,
                            {"master": wake} if latencies and wake else None,
                            scenario=scenario)
    return write_summary(rs, summary)
