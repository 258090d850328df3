"""The DBC profile's bench of both C nodes: the C controller node against the C plant node
(lockstep over socketcand or SocketCAN, or real time), and the FMPy co-simulation with the
bench's quantisation (the exact reference of the lockstep bench).

Main entry points: :func:`run_c_bench` (both C nodes), :func:`quantised_cosim` (the FMPy loop
with the DBC's quantisation). The Python FMU sides are :mod:`rrr_robot.hil.dbc.controller` and
:mod:`rrr_robot.hil.dbc.plant`.
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core._arrays import FloatArray
from ...core.outputs import atomic_path
from ...errors import HilError, OutputError
from ...sim.cosim import CosimOptions, CosimResult, run_cosim
from ..logs.specs import CONTROLLER_LOG, PLANT_LOG, read_log
from ..nodes import (
    PERIOD,
    LogProgress,
    Progress,
    boot_up_watch,
    controller_node_args,
    export_reference,
    failure_folder,
    start_controller,
    start_plant,
    wait_for_boot_up,
    watch_nodes,
)
from ..results import BenchRun
from .protocol import EXIT_SAFETY, frame_id, quantise_command, quantise_state

__all__ = ["RealTime", "quantised_cosim", "quantised_cosim_result", "run_c_bench"]


@dataclass(frozen=True)
class RealTime:
    """The real-time mode of both C nodes (each option applied when permitted: the node warns
    and falls back otherwise, rrr_hil_rt_init): SCHED_FIFO priority (0: off), mlockall, the
    CPUs of the controller and the plant (None: no affinity), the spin before each release (us,
    sleep-then-spin; 0: sleep only), and the plant's --duration."""

    duration: float
    fifo: int = 80
    mlock: bool = True
    cpus: tuple[int, int] | None = None
    spin_us: int = 100

    def args(self, cpu: int | None) -> list[str]:
        a = ["--realtime", "--spin-us", str(self.spin_us)]
        if self.fifo:
            a += ["--fifo", str(self.fifo)]
        if self.mlock:
            a.append("--mlock")
        if cpu is not None:
            a += ["--cpu", str(cpu)]
        return a


@contextlib.contextmanager
def _optional_atomic(path: Path | None) -> Iterator[Path | None]:
    if path is None:
        yield None
    else:
        with atomic_path(path) as tmp:
            yield tmp


def run_c_bench(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                workdir: Path | None = None,
                controller_values: Mapping[str, float | bool] = {}, *,
                frame_log: str | None = None, realtime: RealTime | None = None,
                progress: Progress | None = None, socketcan: str | None = None,
                can_fd: bool = False) -> BenchRun:
    """Both C nodes in lockstep (or ``realtime``) over the socketcand transport (plant =
    server), or over the SocketCAN interface ``socketcan`` (e.g. vcan0; the controller starts
    once the plant's boot-up heartbeat is on the bus), with ``can_fd`` as CAN FD frames with
    bit-rate switch (the nodes' --fd; the interface needs MTU 72, e.g. vcan1). The plant starts
    at (q_ref[0], qd_ref[0]) on the default robot; the controller uses the default robot and
    gains changed by ``controller_values`` (controller FMU names, e.g. a scenario's). The logs go to
    ``workdir``: plant.csv, controller.csv, the controller node's frame log ``frame_log`` (a
    file name; rrr_robot.hil.logs.frames) and, in real time, latency_controller.csv and
    latency_plant.csv. A run that completed while the safety policy fired (a node's exit
    status EXIT_SAFETY) is a run: the summaries say so; any other non-zero status raises
    (nodes.watch_nodes: a node that stops answering is named and stopped within a bound in
    bench periods, whatever the run's length; TamperedError for a controller that received a
    JointState twice in a lockstep period)."""
    if can_fd and not socketcan:
        raise HilError("CAN FD needs the SocketCAN transport (--interface socketcan): the "
                       "socketcand protocol carries classical CAN frames only")
    own = workdir is None
    work = Path(tempfile.mkdtemp(prefix="rrr_hil_")) if workdir is None else Path(workdir)
    n = t.shape[0]
    try:
        ref_csv = export_reference(t, q_ref, qd_ref, qdd_ref, work / "reference.csv")
        rt_plant: list[str] = ["--fd"] if can_fd else []
        rt_ctrl: list[str] = ["--fd"] if can_fd else []
        latency = (work / "latency_controller.csv", work / "latency_plant.csv")
        if realtime is not None:
            cpus = realtime.cpus or (None, None)
            rt_ctrl += realtime.args(cpus[0])
            rt_plant += [*realtime.args(cpus[1]), "--duration", f"{realtime.duration:.3f}"]
        # the C nodes write their logs themselves: to temporary names, renamed when the run
        # succeeded (core.outputs), so a failed or interrupted run leaves no half log
        with atomic_path(work / "plant.csv") as plant_log, \
                atomic_path(work / "controller.csv") as ctrl_log, \
                _optional_atomic(work / frame_log if frame_log else None) as frames, \
                _optional_atomic(latency[0] if realtime else None) as lat_c, \
                _optional_atomic(latency[1] if realtime else None) as lat_p:
            if lat_c is not None and lat_p is not None:
                rt_ctrl += ["--latency-log", str(lat_c)]
                rt_plant += ["--latency-log", str(lat_p)]
            start = time.perf_counter()
            boot_id = frame_id("HeartbeatPlant")
            with boot_up_watch(socketcan, boot_id, can_fd) as watch, \
                    start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=plant_log,
                                extra=rt_plant, socketcan=socketcan) as plant:
                if watch is not None:
                    wait_for_boot_up(watch, plant, boot_id)
                ctrl = start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                        log_csv=ctrl_log, frame_log=frames,
                                        extra=[*controller_node_args(controller_values),
                                               *rt_ctrl], socketcan=socketcan)
                with ctrl:
                    cs, ps = watch_nodes([ctrl, plant], "the CAN bench failed",
                                         failure_folder(work), ok=(0, EXIT_SAFETY),
                                         poll=LogProgress(ctrl_log, n, progress))
            wall = time.perf_counter() - start
            if frames is not None and cs.get("frame_log_error"):
                raise OutputError(f"cannot write the controller's frame log "
                                  f"{failure_folder(work) / str(frame_log)}: "
                                  f"{cs['frame_log_error']}; free space, or write the results "
                                  "elsewhere (--out)")
            p, c = read_log(plant_log, PLANT_LOG), read_log(ctrl_log, CONTROLLER_LOG)
        m = min(p.rows.shape[0], c.rows.shape[0])  # real time: the loops need not end together
        return BenchRun(t=p.col("t")[:m], q=p.group("q")[:m], qd=p.group("qd")[:m],
                        u=c.group("u")[:m], plant_summary=ps, controller_summary=cs,
                        u_n=c.group("u_n")[:m], u_c=c.group("u_c")[:m], wall_time=wall)
    finally:
        if own:
            shutil.rmtree(work, ignore_errors=True)


def quantised_cosim_result(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
                           qdd_ref: FloatArray, x_ref: FloatArray | None = None,
                           plant_values: Mapping[str, float] = {},
                           controller_values: Mapping[str, float | bool] = {}) -> CosimResult:
    """The FMPy co-simulation (cosim.run_cosim) with the bench's quantisation: the plant's q, qd
    pass through JointState and the controller's u through VoltageCmd (cantools, the same DBC).
    This is the arithmetic of the lockstep bench, so the C bench must match it to rounding."""
    options = CosimOptions(step=PERIOD, plant_values=plant_values,
                           controller_values=controller_values, measure=quantise_state,
                           actuate=quantise_command)
    x = np.zeros_like(q_ref) if x_ref is None else x_ref
    return run_cosim(t, q_ref, qd_ref, qdd_ref, x, options)


def quantised_cosim(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                    plant_values: Mapping[str, float] = {},
                    controller_values: Mapping[str, float | bool] = {}) -> BenchRun:
    """:func:`quantised_cosim_result` as a BenchRun (t, q, qd, u)."""
    r = quantised_cosim_result(t, q_ref, qd_ref, qdd_ref, None, plant_values, controller_values)
    return BenchRun(t=t, q=r.q, qd=r.qd, u=r.u, plant_summary={}, controller_summary={},
                    u_n=r.u_n, u_c=r.u_c)
