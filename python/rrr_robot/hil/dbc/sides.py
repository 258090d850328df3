"""The sides of a DBC profile run as library calls (``rrr hil bench|controller|plant``): each starts
what it needs (C nodes, a python-can bus), runs the writing reference and returns a
:class:`SideRun` (the exit status, the run, the nodes' summaries). The command line only chooses a
side and prints; the files go to a working folder (a result set's staging folder).

- bench: the C controller node against the C plant node (lockstep, or real time);
- controller: the controller FMU under FMPy over python-can against the C plant node;
- plant: the Python plant (the plant FMU behind the C supervisor) against the C controller node.

With :attr:`Connection.connect` (or SocketCAN) the other node runs elsewhere and keeps its logs.
"""

from __future__ import annotations

import errno
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import BusLost, HilError
from ...writing.trajectory import Reference
from ..channel import DEFAULT_CHANNEL
from ..logs.specs import CONTROLLER_LOG, PLANT_LOG, NodeLog, read_log
from ..nodes import (
    EXIT_PEER_LOST,
    Progress,
    controller_node_args,
    export_reference,
    failure_folder,
    open_bus,
    start_listening_controller,
    start_plant,
    watch_nodes,
)
from ..results import BenchRun, write_controller_log
from .bench import RealTime, run_c_bench
from .controller import run_fmu_controller
from .plant import PlantRun, PythonPlant, RxFilter, drop_commands_from

__all__ = ["Connection", "SideRun", "open_checked_bus", "run_bench", "run_controller_side",
           "run_plant_side"]

@dataclass(frozen=True)
class Connection:
    """How the Python side reaches the other node: a python-can ``interface`` (socketcand or
    socketcan), the ``connect`` address of a socketcand server started elsewhere (None: start
    the node here), and the ``channel`` (socketcand bus name or SocketCAN interface)."""

    interface: str = "socketcand"
    connect: str | None = None
    channel: str = DEFAULT_CHANNEL

    @property
    def external(self) -> bool:
        """The other node runs elsewhere (its logs are not here)."""
        return bool(self.connect) or self.interface == "socketcan"

    def address(self) -> tuple[str, int]:
        """HOST, PORT of --connect (127.0.0.1, 0 without it)."""
        host, _, port = (self.connect or "127.0.0.1:0").rpartition(":")
        return host, int(port)


@dataclass(frozen=True)
class SideRun:
    """One side's outcome: the exit status (the Python side's first, then the other node's),
    the run, the nodes' summaries and, of the plant side, the Python plant's own run (its log,
    the voltages it applied)."""

    rc: int
    run: BenchRun
    nodes: dict[str, Mapping[str, Any]]
    plant: PlantRun | None = None


#: The C node's exit statuses that make a run (its status is the run's): all but a signal's.
_ANY_STATUS = range(256)


def open_checked_bus(conn: Connection, host: str, port: int) -> Any:
    """The python-can bus of ``conn`` at HOST:PORT; HilError saying why it cannot be opened."""
    import can

    # python-can's socketcand client logs a warning per failed connection attempt (thousands in
    # its 10 s of retries); the one error raised at the end says it all
    retries = logging.getLogger("can.interfaces.socketcand.socketcand")
    level = retries.level
    if not logging.getLogger("rrr_robot").isEnabledFor(logging.DEBUG):
        retries.setLevel(logging.ERROR)
    try:
        return open_bus(conn.interface, host=host, port=port, channel=conn.channel)
    except can.CanError as exc:
        raise HilError(f"cannot open the {conn.interface} bus {conn.channel or ''} at "
                       f"{host}:{port}: {exc}") from exc
    except OSError as exc:
        hint = (" (this kernel has no AF_CAN: use --interface socketcand)"
                if exc.errno == errno.EAFNOSUPPORT else "")
        raise HilError(f"cannot open the {conn.interface} bus {conn.channel or ''}: "
                       f"{exc}{hint}") from exc
    finally:
        retries.setLevel(level)


def run_bench(ref: Reference, controller_values: Mapping[str, float | bool], work: Path, *,
              frame_log: str, realtime: RealTime | None = None,
              progress: Progress | None = None, socketcan: str | None = None,
              can_fd: bool = False) -> SideRun:
    """Both C nodes over the socketcand transport (or the SocketCAN interface ``socketcan``,
    with ``can_fd`` as CAN FD frames)
    along ``ref``; logs in ``work``."""
    run = run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=work,
                      controller_values=dict(controller_values), frame_log=frame_log,
                      realtime=realtime, progress=progress, socketcan=socketcan,
                      can_fd=can_fd)
    return SideRun(_status(run.plant_summary, run.controller_summary), run,
                   {"plant": run.plant_summary, "controller": run.controller_summary})


def _status(plant: Mapping[str, Any], controller: Mapping[str, Any]) -> int:
    """The exit status of a run from its nodes': the plant's when it is not 0, else the
    controller's (EXIT_SAFETY when the safety policy fired, docs/can-bench.md "Exit statuses")."""
    rc = int(plant.get("exit", 0))
    return rc if rc != 0 else int(controller.get("exit", 0))


def run_controller_side(ref: Reference, controller_values: Mapping[str, float | bool],
                        work: Path, conn: Connection, *, frame_log: str,
                        progress: Progress | None = None) -> SideRun:
    """The controller FMU under FMPy against the C plant node (started here with its logs in
    ``work`` unless ``conn`` is external); the controller's log is written to ``work``."""
    plant = None
    try:
        if conn.external:
            host, port = conn.address()
        else:
            plant = start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=work / "plant.csv",
                                frame_log=work / frame_log)
            host, port = "127.0.0.1", int(plant.port or 0)
        try:
            with open_checked_bus(conn, host, port) as bus:
                run = run_fmu_controller(bus, ref.t, ref.q, ref.qd, ref.qdd,
                                         dict(controller_values), progress=progress,
                                         alive=plant.running if plant is not None else None)
        except BusLost as exc:  # name the plant node when it is the one that died or froze
            if plant is not None:
                stopped = f"the CAN bench stopped at period {exc.period} of {ref.t.size}"
                if plant.died():
                    raise plant.failure(stopped, failure_folder(work)) from exc
                watch_nodes([plant], stopped, failure_folder(work), ok=_ANY_STATUS,
                            ended=(f"the controller FMU's side lost it ({exc})", EXIT_PEER_LOST))
            raise
        summary = (watch_nodes([plant], "the CAN bench failed", failure_folder(work),
                               ok=_ANY_STATUS, ended=("the controller FMU's side ended", 0))[0]
                   if plant is not None else dict(run.plant_summary))
    finally:
        if plant is not None:
            plant.close()
    write_controller_log(run, work / "controller.csv")
    return SideRun(_status(summary, run.controller_summary), run,
                   {"plant": summary, "controller": run.controller_summary})


def run_plant_side(ref: Reference, controller_values: Mapping[str, float | bool], work: Path,
                   conn: Connection, *, frame_log: str | None = None,
                   drop_from: int | None = None, rx_filter: RxFilter | None = None,
                   timeout: float = 5.0, progress: Progress | None = None,
                   announce: Callable[[str], None] | None = None) -> SideRun:
    """The Python plant against the C controller node: started here (``--listen``, its logs in
    ``work``) unless ``conn`` is external (``rrr_hil_controller --listen HOST:PORT``, or with
    SocketCAN ``rrr_hil_controller --socketcan IF`` started after this plant: ``announce`` is
    told when). Fault injection: ``drop_from``, VoltageCmd frames of periods >= it do not reach
    the plant; ``rx_filter``, any filter between the bus and the plant (not both).
    ``timeout``: of the plant waiting for a frame, s (then it latches a bus fault)."""
    if drop_from is not None:
        if rx_filter is not None:
            raise ValueError("give drop_from or rx_filter, not both")
        rx_filter = drop_commands_from(drop_from)
    ctrl = None
    try:
        if conn.external:
            host, port = conn.address()
        else:
            ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv",
                                       (ref.x, ref.xd, ref.xdd))
            ctrl = start_listening_controller(ref_csv, log_csv=work / "controller.csv",
                                              extra=controller_node_args(controller_values),
                                              frame_log=None if frame_log is None
                                              else work / frame_log)
            host, port = "127.0.0.1", int(ctrl.port or 0)
        with open_checked_bus(conn, host, port) as bus:
            if conn.interface == "socketcan" and announce is not None:
                announce(f"python plant on {conn.channel}: start rrr_hil_controller --socketcan "
                         f"{conn.channel} now")
            plant = PythonPlant(bus, q0=ref.q[0], qd0=ref.qd[0], rx_filter=rx_filter,
                                timeout=timeout, start_timeout=120.0, progress=progress,
                                periods=ref.t.shape[0])
            prun = plant.run(work / "plant.csv")
        cs: dict[str, Any] = {"exit": 0}
        if ctrl is not None:  # killed or frozen: named (its log is cut short)
            rc = int(prun.summary["exit"])
            how = "lost it" if rc == EXIT_PEER_LOST else f"ended with status {rc}"
            cs = watch_nodes([ctrl], f"the CAN bench stopped at period "
                             f"{prun.summary['periods']} of {ref.t.size}", failure_folder(work),
                             ok=_ANY_STATUS, ended=(f"the Python plant {how}", rc))[0]
    finally:
        if ctrl is not None:
            ctrl.close()
    s = prun.summary
    if ctrl is not None:
        c = read_log(work / "controller.csv", CONTROLLER_LOG)
    else:  # the controller's log stays with it
        c = NodeLog(CONTROLLER_LOG, np.zeros((prun.log.shape[0], len(CONTROLLER_LOG.columns))))
    run = BenchRun(t=prun.log[:, PLANT_LOG.index("t")], q=prun.q, qd=prun.qd, u=c.group("u"),
                   plant_summary=s, controller_summary=cs, u_n=c.group("u_n"),
                   u_c=c.group("u_c"))
    # the exit status reflects every side's: the plant's first, then the controller node's
    return SideRun(_status(s, cs), run, {"plant": s, "controller": cs}, prun)
