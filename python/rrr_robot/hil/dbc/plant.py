"""The DBC profile's plant side from Python (run by ``rrr hil plant``).

The plant FMU runs under FMPy (:class:`~rrr_robot.sim.fmu_slave.FmuSlave`) and speaks the lockstep
protocol of ``c_src/hil/dbc/hil_dbc_plant.c`` over a python-can bus: ``socketcand`` as client of the
C controller node started with ``--listen``, or ``socketcan`` where the kernel has AF_CAN.
Outgoing frames (JointState1..3, PlantStatus, HeartbeatPlant) are encoded with cantools from the
shipped DBC; Sync and HeartbeatCtrl are decoded with cantools.

The safety policy is NOT implemented here: every VoltageCmd frame goes to the C decoder and the
C supervisor (``hil_supervisor.c`` through :mod:`rrr_robot.hil.dbc._supervisor`), exactly the
calls the C plant node makes, so CRC, alive-counter, range and DLC checks, the hold / timeout /
0 V rule, the latch and the reset are the C code's. Python only moves frames and steps the FMU.

Lockstep only (deterministic): after the controller's first frame the plant publishes the state
of period 0; each Sync(k) closes period k (the supervisor decides the voltage), the FMU advances
exactly one period and the plant publishes the state of k + 1; the controller's heartbeat
"stopped" ends the run. There is no real-time mode for the Python plant (use the C plant node,
``rrr_hil_plant --realtime``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...core import fmu_vars as fv
from ...core._arrays import FloatArray
from ...errors import BusLost, FrameError, one_line
from ...sim.cosim import PLANT_IN, initial_state_values
from ...sim.fmu_slave import FmuSlave
from ...sim.fmus import fmu_path
from ..logs.specs import PLANT_LOG, NodeLog, write_log
from ..nodes import NMT_BOOT, NMT_OPERATIONAL, PERIOD
from . import _supervisor as hl
from .protocol import EXIT_SAFETY, decode, encode, frame_id

log = logging.getLogger(__name__)

__all__ = ["LOG_HEADER", "PlantRun", "PythonPlant", "drop_commands_from"]

HEARTBEAT_PERIODS = 100
#: The plant FMU's state outputs (q, qd) sent in the JointState frames.
STATE_OUTPUTS = fv.names("plant", "q") + fv.names("plant", "qd")
#: Columns of the plant log (specs.PLANT_LOG, the C plant node's --log): row 0 is the initial
#: state, row k + 1 the state after period k with the voltage applied during period k.
LOG_HEADER = list(PLANT_LOG.names)
#: The FMU outputs logged beside the state (the last six columns).
LOGGED_OUTPUTS = list(PLANT_LOG.names[PLANT_LOG.index(fv.names("plant", "qdd")[0]):])

#: Fault injection between the bus and the plant: (period k, frame) -> the frame to deliver
#: (possibly modified), or None to drop it.
RxFilter = Callable[[int, Any], Any | None]


def drop_commands_from(k0: int) -> RxFilter:
    """Fault injection: VoltageCmd frames of periods >= k0 never reach the plant (the controller
    "stops commanding" while Sync keeps the lockstep going)."""

    voltage_cmd = frame_id("VoltageCmd")

    def rx_filter(k: int, msg: Any) -> Any | None:
        return None if k >= k0 and msg.arbitration_id == voltage_cmd else msg

    return rx_filter


@dataclass(frozen=True)
class PlantRun:
    """One Python plant run: the log rows (see LOG_HEADER) and the summary (the same keys as the
    C plant node's RRR_HIL_SUMMARY, node 'python-plant')."""

    log: FloatArray
    summary: dict[str, Any]

    @property
    def q(self) -> FloatArray:
        return NodeLog(PLANT_LOG, self.log).group("q")

    @property
    def qd(self) -> FloatArray:
        return NodeLog(PLANT_LOG, self.log).group("qd")

    @property
    def u(self) -> FloatArray:
        """Row k + 1: the voltage applied during period k."""
        return NodeLog(PLANT_LOG, self.log).group("u")


@dataclass
class _Counters:
    rx: list[int] = field(default_factory=lambda: [0] * hl.RX_COUNT)
    rx_ignored: int = 0
    state_out_of_range: int = 0


class PythonPlant:
    """The plant node in Python (see module docstring); ``run()`` once per instance."""

    def __init__(self, bus: Any, *, q0: Sequence[float] = (0.0, 0.0, 0.0),
                 qd0: Sequence[float] = (0.0, 0.0, 0.0), values: Mapping[str, float] = {},
                 max_missed: int = 3, max_delta_counter: int = 3, timeout: float = 5.0,
                 start_timeout: float = 30.0, rx_filter: RxFilter | None = None,
                 fmu: Path | None = None, progress: Callable[[int, int], None] | None = None,
                 periods: int = 0) -> None:
        self.bus = bus
        self.values = initial_state_values(q0, qd0) | dict(values)
        self.sup = hl.Supervisor(max_missed, max_delta_counter)
        self.timeout, self.start_timeout = timeout, start_timeout
        self.rx_filter = rx_filter
        self.progress, self.periods = progress, periods  # progress(k, periods) every 1 %
        self.fmu_path = Path(fmu) if fmu else fmu_path("plant")
        self.k = 0
        self.started = False
        self.ctrl_nmt = -1
        self.n = _Counters()
        self._hb = 0
        self._rows: list[list[float]] = []
        self._voltage_cmd, self._stop_cmd = frame_id("VoltageCmd"), frame_id("StopCmd")

    # ---- frames ------------------------------------------------------------------------------
    def _send(self, name: str, signals: Mapping[str, float]) -> None:
        import can

        try:
            self.bus.send(encode(name, signals))
        except (OSError, can.CanError) as exc:
            raise BusLost(f"send {name}: {exc}", self.k) from exc

    def _heartbeat(self, nmt: int) -> None:
        self._send("HeartbeatPlant", {"NmtState": nmt, "Counter": self._hb & 0xFF})
        self._hb += 1

    def _publish(self, x: FloatArray) -> None:
        """The state of period k: JointState1..3, PlantStatus, every 100 periods a heartbeat."""
        from cantools.database import EncodeError

        counter = self.k & 15
        for j in range(3):
            try:
                self._send(f"JointState{j + 1}", {"AliveCounter": counter, "Q": float(x[j]),
                                                  "Qd": float(x[3 + j])})
            except (EncodeError, ValueError):
                self.n.state_out_of_range += 1
        self._send("PlantStatus", {"AliveCounter": counter, **self.sup.status()})
        if self.k % HEARTBEAT_PERIODS == 0:
            self._heartbeat(NMT_OPERATIONAL)

    def _handle(self, msg: Any) -> bool:
        """One received frame (hil_dbc_plant.c handle()); True for a Sync (advance a period).
        A StopCmd goes to the C supervisor, which honours it only with its E2E protection."""
        if msg.arbitration_id == self._voltage_cmd and not msg.is_extended_id:
            self.n.rx[self.sup.on_command_frame(msg)] += 1
            self.started = True
            return False
        if msg.arbitration_id == self._stop_cmd and not msg.is_extended_id:
            rx, _ = self.sup.on_stop_frame(msg)
            self.n.rx[rx] += 1
            self.started = True
            return False
        try:
            name, sig = decode(msg)
        except FrameError as exc:
            reason = {"unknown id": hl.RX_UNKNOWN_ID, "wrong DLC": hl.RX_BAD_DLC}
            self.n.rx[reason.get(exc.reason, hl.RX_BAD_CRC)] += 1
            self.started = self.started or exc.reason != "unknown id"
            return False
        self.n.rx[hl.RX_OK] += 1
        self.started = True
        if name == "HeartbeatCtrl":
            self.ctrl_nmt = int(sig["NmtState"])
            return False
        if name == "Sync":
            if int(sig["Cycle"]) != self.k:
                self.sup.raise_fault(hl.FAULT_SYNC)
            return True
        self.n.rx_ignored += 1
        return False

    # ---- the loop ----------------------------------------------------------------------------
    def _record(self, t: float, x: FloatArray, u: Sequence[float], y: Sequence[float]) -> None:
        self._rows.append([self.k, t, *x, *u, float(self.sup.zero_applied),
                           float(self.sup.faults), *y])

    def _recv(self, deadline: float) -> Any | None:
        """The next frame (after the fault-injection filter), or None past the deadline;
        raises BusLost when the bus fails."""
        import can

        while time.monotonic() < deadline:
            try:
                msg = self.bus.recv(timeout=min(0.2, max(0.0, deadline - time.monotonic())))
            except (OSError, can.CanError) as exc:
                raise BusLost(f"receive: {one_line(exc)}", self.k) from exc
            if msg is None:
                continue
            if self.rx_filter is not None:
                msg = self.rx_filter(self.k, msg)
            if msg is not None:
                return msg
        return None

    def _lockstep(self, slave: Any, p_in: Any, p_out: Any, y_out: Any) -> int:
        """The loop of hil_dbc_plant.c run_lockstep(); raises BusLost, HilError."""
        x = slave.get_block(p_out).copy()
        self._record(slave.time, x, (0.0, 0.0, 0.0), slave.get_block(y_out))
        self._heartbeat(NMT_BOOT)
        published0 = False
        while True:
            wait = self.timeout if self.started else self.start_timeout
            msg = self._recv(time.monotonic() + wait)
            if msg is None:
                what = "the controller went silent" if self.started else "no controller"
                raise BusLost(f"{what} (no frame within {wait:.1f} s)", self.k)
            sync = self._handle(msg)
            if self.started and not published0:
                self._publish(x)
                published0 = True
            if self.sup.stop_reason is not None:  # the heartbeat "stopped" is informational
                return 0 if self.sup.stop_reason == 0 else 6
            if sync:
                u, _ = self.sup.next_period()
                p_in.values[:] = u
                slave.set_block(p_in)
                slave.do_step(PERIOD)
                x = slave.get_block(p_out).copy()
                self.k += 1
                self._record(slave.time, x, u, slave.get_block(y_out))
                if self.progress is not None and self.periods and (
                        self.k % max(1, self.periods // 100) == 0 or self.k + 1 >= self.periods):
                    self.progress(min(self.k + 1, self.periods), self.periods)
                self._publish(x)

    def run(self, log_csv: Path | None = None) -> PlantRun:
        """Run until the controller's StopCmd (exit 0; 7 when the safety policy fired on the
        way, 6 for a reason other than the end of the run) or until it is lost (exit 3, bus
        fault latched); optionally write the log as the C node's --log does."""
        with FmuSlave(self.fmu_path, "plant") as slave:
            slave.initialize(0.0, self.values)
            p_in = slave.real_block(PLANT_IN)
            p_out = slave.real_block(STATE_OUTPUTS)
            y_out = slave.real_block(LOGGED_OUTPUTS)
            try:
                rc = self._lockstep(slave, p_in, p_out, y_out)
            except BusLost as exc:
                log.error("python plant: period %d: %s", self.k, exc)
                self.sup.raise_fault(hl.FAULT_BUS)
                rc = 3
        c = self.sup.counters()
        if rc == 0 and (self.sup.faults or c["fault_events"] or c["zero_periods"]):
            rc = EXIT_SAFETY  # completed, but the safety policy fired (as rrr_hil_plant)
        rows = np.array(self._rows, dtype=float).reshape(-1, len(LOG_HEADER))
        if log_csv is not None:
            write_log(log_csv, PLANT_LOG, rows)  # complete or not at all (core.outputs)
        return PlantRun(log=rows, summary=self._summary(rc))

    def _summary(self, rc: int) -> dict[str, Any]:
        s: dict[str, Any] = {"node": "python-plant", "exit": rc, "periods": self.k,
                             "faults": self.sup.faults, **self.sup.counters(),
                             "state_out_of_range": self.n.state_out_of_range}
        s |= {f"rx_{name}": self.n.rx[i] for i, name in enumerate(hl.RX_NAMES) if i > 0}
        s["rx_ignored"] = self.n.rx_ignored
        log.debug("python plant: %s", s)
        return s
