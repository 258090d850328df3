"""Runs of the CAN bench: both C nodes, the controller FMU against the C plant node, and the
FMPy co-simulation with the bench's quantisation (the exact reference of the lockstep bench).

Main entry points: :func:`run_c_bench` (both C nodes), :func:`run_fmu_controller` (the
controller FMU under FMPy against the C plant node), :func:`quantised_cosim` (the FMPy loop with
the DBC's quantisation). The Python plant is in :mod:`rrr_robot.hil.plant`.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.outputs import atomic_path
from ..sim.cosim import CTRL_IN, CTRL_OUT, CosimOptions, run_cosim
from ..sim.fmu_slave import FmuSlave
from ..sim.fmus import fmu_path
from .nodes import controller_node_args, export_reference, start_controller, start_plant
from .protocol import (
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

__all__ = ["BenchRun", "quantised_cosim", "run_c_bench", "run_fmu_controller"]


@dataclass(frozen=True)
class BenchRun:
    """Signals of a bench run, one row per period (the controller's view: measured q, qd)."""

    t: FloatArray
    q: FloatArray        # (n, 3) plant state (exact doubles for the C plant log)
    qd: FloatArray
    u: FloatArray        # (n, 3) commanded voltage
    plant_summary: dict[str, Any]
    controller_summary: dict[str, Any]


class _StateWaiter:
    """Collects JointState1..3 of one alive counter from a bus (lockstep controller side)."""

    def __init__(self, bus: Any, timeout: float) -> None:
        self.bus = bus
        self.timeout = timeout
        self.status: dict[str, float] = {}
        self.rejected: dict[str, int] = {}

    def wait(self, counter: int) -> tuple[FloatArray, FloatArray]:
        q, qd = np.zeros(3), np.zeros(3)
        have: set[int] = set()
        deadline = time.monotonic() + self.timeout
        while len(have) < 3:
            msg = self.bus.recv(timeout=max(0.0, deadline - time.monotonic()))
            if msg is None:
                raise HilError(f"no joint state with counter {counter} within {self.timeout} s")
            try:
                name, sig = decode(msg)
            except FrameError as exc:
                self.rejected[exc.reason] = self.rejected.get(exc.reason, 0) + 1
                continue
            if name == "PlantStatus":
                self.status = sig
            elif name.startswith("JointState") and sig["AliveCounter"] == counter:
                j = int(name[-1]) - 1
                q[j], qd[j] = sig["Q"], sig["Qd"]
                have.add(j)
        return q, qd


def run_fmu_controller(bus: Any, t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
                       qdd_ref: FloatArray, controller_values: Mapping[str, float | bool] = {},
                       timeout: float = 5.0, controller_fmu: Path | None = None) -> BenchRun:
    """Lockstep: the controller FMU (FMPy) drives the plant node on ``bus`` along the reference."""
    n = t.shape[0]
    ref = np.hstack([q_ref, qd_ref, qdd_ref])
    q_rec, qd_rec, u_rec = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    waiter = _StateWaiter(bus, timeout)
    with FmuSlave(controller_fmu or fmu_path("controller"), "controller") as ctrl:
        ctrl.initialize(float(t[0]), controller_values)
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_OPERATIONAL, "Counter": 0}))
        for k in range(n):
            q_rec[k], qd_rec[k] = waiter.wait(k & 15)
            c_in.values[:9] = ref[k]
            c_in.values[9:12], c_in.values[12:15] = q_rec[k], qd_rec[k]
            ctrl.set_block(c_in)
            ctrl.get_block(c_out)
            u_rec[k] = c_out.values[:3]
            u = {f"U{i + 1}": float(u_rec[k, i]) for i in range(3)}
            bus.send(encode("VoltageCmd", {"AliveCounter": k & 15, "Enable": 1,
                                           "ResetFault": 0, **u}))
            if k < n - 1:
                bus.send(encode("Sync", {"Cycle": k}))
                ctrl.do_step(PERIOD)
        # the stop request: E2E-protected, the next alive counter after the last VoltageCmd
        bus.send(encode("StopCmd", {"AliveCounter": n & 15, "Reason": 0}))
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_STOPPED, "Counter": 1}))
    return BenchRun(t=t, q=q_rec, qd=qd_rec, u=u_rec, plant_summary=dict(waiter.status),
                    controller_summary={"rejected": waiter.rejected})


def _read_log(path: Path) -> FloatArray:
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def run_c_bench(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                workdir: Path | None = None, timeout: float = 300.0,
                controller_values: Mapping[str, float | bool] = {}) -> BenchRun:
    """Both C nodes in lockstep over the socketcand transport (plant = server). The plant starts
    at (q_ref[0], qd_ref[0]) on the default robot; the controller uses the default robot and
    gains changed by ``controller_values`` (controller FMU names, e.g. a scenario's)."""
    own = workdir is None
    work = Path(tempfile.mkdtemp(prefix="rrr_hil_")) if workdir is None else Path(workdir)
    try:
        ref_csv = export_reference(t, q_ref, qd_ref, qdd_ref, work / "reference.csv")
        # the C nodes write their logs themselves: to temporary names, renamed when the run
        # succeeded (core.outputs), so a failed or interrupted run leaves no half log
        with atomic_path(work / "plant.csv") as plant_log, \
                atomic_path(work / "controller.csv") as ctrl_log:
            with start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=plant_log) as plant, \
                    start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                     log_csv=ctrl_log,
                                     extra=controller_node_args(controller_values)) as ctrl:
                cs = ctrl.wait(timeout)
                if cs["exit"] != 0:  # the plant would wait for a controller that is gone
                    plant.close()
                    raise HilError(f"bench failed: controller exit {cs['exit']}: "
                                   f"{ctrl.stderr.strip()}")
                ps = plant.wait(timeout)
            if cs["exit"] != 0 or ps["exit"] != 0:
                raise HilError(f"bench failed: controller exit {cs['exit']}: "
                               f"{ctrl.stderr.strip()}; plant exit {ps['exit']}: "
                               f"{plant.stderr.strip()}")
            p, c = _read_log(plant_log), _read_log(ctrl_log)
        return BenchRun(t=p[:, 1], q=p[:, 2:5], qd=p[:, 5:8], u=c[:, [8, 11, 14]],
                        plant_summary=ps, controller_summary=cs)
    finally:
        if own:
            shutil.rmtree(work, ignore_errors=True)


def quantised_cosim(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                    plant_values: Mapping[str, float] = {},
                    controller_values: Mapping[str, float | bool] = {}) -> BenchRun:
    """The FMPy co-simulation (cosim.run_cosim) with the bench's quantisation: the plant's q, qd
    pass through JointState and the controller's u through VoltageCmd (cantools, the same DBC).
    This is the arithmetic of the lockstep bench, so the C bench must match it to rounding."""
    options = CosimOptions(step=PERIOD, plant_values=plant_values,
                           controller_values=controller_values, measure=quantise_state,
                           actuate=quantise_command)
    r = run_cosim(t, q_ref, qd_ref, qdd_ref, np.zeros_like(q_ref), options)
    return BenchRun(t=t, q=r.q, qd=r.qd, u=r.u, plant_summary={}, controller_summary={})
