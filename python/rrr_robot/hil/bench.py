"""Runs of the CAN bench: both C nodes, the controller FMU against the C plant node, and the
FMPy co-simulation with the bench's quantisation (the exact reference of the lockstep bench).

Main entry points: :func:`run_c_bench` (both C nodes), :func:`run_fmu_controller` (the
controller FMU under FMPy against the C plant node), :func:`quantised_cosim` (the FMPy loop with
the DBC's quantisation). The Python plant is in :mod:`rrr_robot.hil.plant`.
"""

from __future__ import annotations

import contextlib
import errno
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.outputs import atomic_path
from ..sim.cosim import CTRL_IN, CTRL_OUT, CosimOptions, CosimResult, run_cosim
from ..sim.fmu_slave import FmuSlave
from ..sim.fmus import fmu_path
from .logspec import CONTROLLER_LOG, PLANT_LOG, read_log, write_log
from .nodes import (
    controller_node_args,
    export_reference,
    failure_folder,
    start_controller,
    start_plant,
    wait_for_boot_up,
)
from .protocol import (
    EXIT_SAFETY,
    NMT_OPERATIONAL,
    NMT_STOPPED,
    PERIOD,
    FrameError,
    HilError,
    decode,
    encode,
    quantise_command,
    quantise_state,
)

__all__ = ["BenchRun", "LogProgress", "RealTime", "quantised_cosim", "quantised_cosim_result",
           "run_c_bench", "run_fmu_controller", "write_controller_log"]

#: Progress of a run: progress(periods done, periods in all).
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class BenchRun:
    """Signals of a bench run, one row per period (the controller's view: measured q, qd)."""

    t: FloatArray
    q: FloatArray        # (n, 3) plant state (exact doubles for the C plant log)
    qd: FloatArray
    u: FloatArray        # (n, 3) commanded voltage
    plant_summary: dict[str, Any]
    controller_summary: dict[str, Any]
    u_n: FloatArray | None = None   # (n, 3) model part of u (the controller's log)
    u_c: FloatArray | None = None   # (n, 3) PD part of u
    wall_time: float = float("nan")  # s from the nodes' start to their end


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


class LogProgress:
    """Reports the rows a node has written to its --log CSV (its periods done) while it runs:
    ``poll()`` reads what was appended since the last call (up to the node's stdio buffer)."""

    def __init__(self, path: Path, total: int, progress: Progress | None) -> None:
        self.path, self.total, self.progress = Path(path), total, progress
        self._offset = 0
        self._rows = -1  # the header line

    def poll(self) -> None:
        if self.progress is None:
            return
        try:
            with open(self.path, "rb") as fh:
                fh.seek(self._offset)
                chunk = fh.read()
        except OSError:
            return
        self._offset += len(chunk)
        self._rows += chunk.count(b"\n")
        self.progress(max(0, min(self._rows, self.total)), self.total)


def wait_node(node: Any, timeout: float, poll: LogProgress | None) -> dict[str, Any]:
    """node.wait(timeout), reporting progress every 0.2 s."""
    if poll is None or poll.progress is None:
        result: dict[str, Any] = node.wait(timeout)
        return result
    deadline = time.monotonic() + timeout
    while node.running() and time.monotonic() < deadline:
        poll.poll()
        time.sleep(0.2)
    poll.poll()
    done: dict[str, Any] = node.wait(max(1.0, deadline - time.monotonic()))
    return done


class _StateWaiter:
    """Collects JointState1..3 of one alive counter from a bus (lockstep controller side)."""

    def __init__(self, bus: Any, timeout: float,
                 alive: Callable[[], bool] | None = None) -> None:
        self.bus = bus
        self.timeout = timeout
        self.alive = alive  # whether the plant node still runs (None: not known here)
        self.status: dict[str, float] = {}
        self.rejected: dict[str, int] = {}
        self.status_faulty = 0  # PlantStatus frames with a latched fault
        self.status_zero = 0  # PlantStatus frames with ZeroVoltage

    def wait(self, counter: int) -> tuple[FloatArray, FloatArray]:
        q, qd = np.zeros(3), np.zeros(3)
        have: set[int] = set()
        deadline = time.monotonic() + self.timeout
        while len(have) < 3:
            left = deadline - time.monotonic()
            msg = self.bus.recv(timeout=max(0.0, min(left, 0.2)))
            if msg is None:
                if self.alive is not None and not self.alive():
                    raise HilError(f"the plant node ended before the joint state with counter "
                                   f"{counter}")
                if left <= 0.2:
                    raise HilError(f"no joint state with counter {counter} within "
                                   f"{self.timeout} s")
                continue
            try:
                name, sig = decode(msg)
            except FrameError as exc:
                self.rejected[exc.reason] = self.rejected.get(exc.reason, 0) + 1
                continue
            if name == "PlantStatus":
                self.status = sig
                self.status_faulty += int(sig["Faults"] != 0)
                self.status_zero += int(sig["ZeroVoltage"] != 0)
            elif name.startswith("JointState") and sig["AliveCounter"] == counter:
                j = int(name[-1]) - 1
                q[j], qd[j] = sig["Q"], sig["Qd"]
                have.add(j)
        return q, qd


def run_fmu_controller(bus: Any, t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
                       qdd_ref: FloatArray, controller_values: Mapping[str, float | bool] = {},
                       timeout: float = 5.0, controller_fmu: Path | None = None,
                       progress: Progress | None = None,
                       alive: Callable[[], bool] | None = None) -> BenchRun:
    """Lockstep: the controller FMU (FMPy) drives the plant node on ``bus`` along the reference;
    ``alive()``: whether the plant node still runs (a node started here: it stops at once when
    the node has died, not after ``timeout``)."""
    n = t.shape[0]
    ref = np.hstack([q_ref, qd_ref, qdd_ref])
    q_rec, qd_rec = np.empty((n, 3)), np.empty((n, 3))
    out_rec = np.empty((n, 9))  # u, u_n, u_c
    waiter = _StateWaiter(bus, timeout, alive)
    start = time.perf_counter()
    with FmuSlave(controller_fmu or fmu_path("controller"), "controller") as ctrl:
        ctrl.initialize(float(t[0]), controller_values)
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        _drive(bus, ctrl, c_in, c_out, ref, q_rec, qd_rec, out_rec, waiter, progress)
        # the stop request: E2E-protected, the next alive counter after the last VoltageCmd
        bus.send(encode("StopCmd", {"AliveCounter": n & 15, "Reason": 0}))
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_STOPPED, "Counter": 1}))
    return BenchRun(t=t, q=q_rec, qd=qd_rec, u=out_rec[:, 0:3], plant_summary=dict(waiter.status),
                    controller_summary={"rejected": waiter.rejected,
                                        "exit": EXIT_SAFETY if waiter.status_faulty
                                        or waiter.status_zero else 0,
                                        "plant_status_faulty": waiter.status_faulty,
                                        "plant_status_zero": waiter.status_zero},
                    u_n=out_rec[:, 3:6],
                    u_c=out_rec[:, 6:9], wall_time=time.perf_counter() - start)


class BusLost(HilError):
    """The bus failed, or the other node went silent, at ``period``."""

    def __init__(self, message: str, period: int) -> None:
        super().__init__(message)
        self.period = period


def _drive(bus: Any, ctrl: FmuSlave, c_in: Any, c_out: Any, ref: FloatArray,
           q_rec: FloatArray, qd_rec: FloatArray, out_rec: FloatArray, waiter: _StateWaiter,
           progress: Progress | None) -> None:
    """The lockstep loop of run_fmu_controller; BusLost when the bus fails or the plant node
    goes silent."""
    import can

    n = ref.shape[0]
    every = max(1, n // 100)
    k = 0
    try:
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_OPERATIONAL, "Counter": 0}))
        for k in range(n):
            q_rec[k], qd_rec[k] = waiter.wait(k & 15)
            c_in.values[:9] = ref[k]
            c_in.values[9:12], c_in.values[12:15] = q_rec[k], qd_rec[k]
            ctrl.set_block(c_in)
            ctrl.get_block(c_out)
            out_rec[k] = c_out.values[:9]
            u = {f"U{i + 1}": float(out_rec[k, i]) for i in range(3)}
            bus.send(encode("VoltageCmd", {"AliveCounter": k & 15, "Enable": 1,
                                           "ResetFault": 0, **u}))
            if k < n - 1:
                bus.send(encode("Sync", {"Cycle": k}))
                ctrl.do_step(PERIOD)
            if progress is not None and (k % every == 0 or k == n - 1):
                progress(k + 1, n)
    except HilError as exc:
        raise BusLost(f"period {k} of {n}: {exc}", k) from exc
    except (can.CanError, OSError) as exc:
        raise BusLost(f"period {k} of {n}: the CAN bus failed "
                      f"({' '.join(str(exc).split()) or type(exc).__name__})", k) from exc


def write_controller_log(run: BenchRun, path: Path) -> Path:
    """The controller log of a run (logspec.CONTROLLER_LOG: the C controller node's --log),
    atomically."""
    assert run.u_n is not None and run.u_c is not None
    spec = CONTROLLER_LOG
    rows = np.zeros((run.t.shape[0], len(spec.columns)))
    rows[:, spec.index("k")] = np.arange(run.t.shape[0])
    rows[:, spec.index("t")] = run.t
    rows[:, spec.index("enable")] = 1.0
    for group, values in (("q", run.q), ("qd", run.qd), ("u", run.u), ("u_n", run.u_n),
                          ("u_c", run.u_c)):
        rows[:, spec.indices(fv.joint_names(group))] = values
    return write_log(path, spec, rows)


@contextlib.contextmanager
def _optional_atomic(path: Path | None) -> Iterator[Path | None]:
    if path is None:
        yield None
    else:
        with atomic_path(path) as tmp:
            yield tmp


@contextlib.contextmanager
def boot_up_watch(socketcan: str | None, can_fd: bool = False,
                  boot_id: int = 0x702) -> Iterator[Any]:
    """A python-can bus on ``socketcan`` that receives only the plant's boot-up ``boot_id``
    (HeartbeatPlant; the CANopen profile: 0x700 + a drive's node id; ``can_fd``: CAN FD frames
    too), opened before the plant starts (None without SocketCAN)."""
    if not socketcan:
        yield None
        return
    import can

    try:
        bus = can.Bus(interface="socketcan", channel=socketcan, fd=can_fd,
                      can_filters=[{"can_id": boot_id, "can_mask": 0x7FF, "extended": False}])
    except (OSError, can.CanError) as exc:
        hint = (" (this kernel has no AF_CAN: use the socketcand transport; docs/socketcan.md)"
                if getattr(exc, "errno", None) == errno.EAFNOSUPPORT else "")
        raise HilError(f"cannot open the SocketCAN interface {socketcan}: {exc}{hint}") from exc
    try:
        yield bus
    finally:
        bus.shutdown()


def run_c_bench(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                workdir: Path | None = None, timeout: float = 300.0,
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
    file name; rrr_robot.hil.framelog) and, in real time, latency_controller.csv and
    latency_plant.csv. A run that completed while the safety policy fired (a node's exit
    status EXIT_SAFETY) is a run: the summaries say so; any other non-zero status raises."""
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
            with boot_up_watch(socketcan, can_fd) as watch, \
                    start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=plant_log,
                                extra=rt_plant, socketcan=socketcan) as plant:
                if watch is not None:
                    wait_for_boot_up(watch, plant)
                ctrl = start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                        log_csv=ctrl_log, frame_log=frames,
                                        extra=[*controller_node_args(controller_values),
                                               *rt_ctrl], socketcan=socketcan)
                with ctrl:
                    cs = wait_node(ctrl, timeout, LogProgress(ctrl_log, n, progress))
                    if cs["exit"] not in (0, EXIT_SAFETY):  # the plant would wait for it
                        # the node that died first is the one to name: a controller whose
                        # plant was killed ends with an error of its own
                        dead = plant if plant.died() else ctrl
                        plant.close()
                        raise dead.failure("the CAN bench failed", failure_folder(work))
                    ps = plant.wait(timeout)
            wall = time.perf_counter() - start
            if ps["exit"] not in (0, EXIT_SAFETY):
                raise plant.failure("the CAN bench failed", failure_folder(work))
            if frames is not None and cs.get("frame_log_error"):
                raise HilError(f"the controller's frame log failed: {cs['frame_log_error']}")
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
