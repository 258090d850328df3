"""The DBC profile's controller side from Python (run by ``rrr hil controller``): the controller
FMU under FMPy drives the C plant node over a python-can bus in lockstep, along the writing
reference (:func:`run_fmu_controller`). Frames are encoded and decoded with cantools from the
shipped DBC (:mod:`rrr_robot.hil.dbc.protocol`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...errors import BusLost, FrameError, HilError, one_line
from ...sim.cosim import CTRL_IN, CTRL_OUT
from ...sim.fmu_slave import FmuSlave
from ...sim.fmus import fmu_path
from ..nodes import NMT_OPERATIONAL, NMT_STOPPED, PERIOD, Progress
from ..results import BenchRun
from .protocol import EXIT_SAFETY, decode, encode

__all__ = ["run_fmu_controller"]


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
                      f"({one_line(exc)})", k) from exc
