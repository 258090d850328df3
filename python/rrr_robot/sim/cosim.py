"""The co-simulation master: reference -> controller FMU -> plant FMU -> back, fixed step.

At each communication point t_k the controller (direct feedthrough) gets the reference and the
plant's measured state and returns u; the plant integrates over [t_k, t_k + h] with u held; both
FMUs then advance. Every signal is recorded into preallocated arrays.
"""

from __future__ import annotations

import ctypes as ct
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from fmpy.fmi1 import FMICallException

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.robot import DEFAULT_SAMPLE_TIME
from ..core.tables import write_table
from ..errors import BadInputError
from .fmu_slave import FmuSlave, pooled_slave
from .fmus import fmu_path

log = logging.getLogger(__name__)

__all__ = ["CosimOptions", "CosimResult", "run_cosim"]

#: The controller's inputs the master sets, its outputs, the plant's input and outputs it reads.
CTRL_IN = [n for s in ("q_ref", "qd_ref", "qdd_ref", "q", "qd") for n in fv.names("controller", s)]
CTRL_OUT = [n for s in ("u", "u_n", "u_c") for n in fv.names("controller", s)]
PLANT_IN = fv.names("plant", "u")
PLANT_OUT = [n for s in ("q", "qd", "qdd", "tip") for n in fv.names("plant", s)]
#: Which FMU's variables name each recorded signal (CosimResult.columns).
_COLUMN_FMU = {"q_ref": "controller", "qd_ref": "controller", "q": "plant", "qd": "plant",
               "qdd": "plant", "u": "controller", "u_n": "controller", "u_c": "controller",
               "x_ref": "reference", "tip": "plant"}


@dataclass(frozen=True)
class CosimOptions:
    """Settings of one co-simulation run."""

    step: float = DEFAULT_SAMPLE_TIME                    # communication step, s
    plant_values: Mapping[str, float | bool] = field(default_factory=dict)
    controller_values: Mapping[str, float | bool] = field(default_factory=dict)
    plant_fmu: Path | None = None                        # default: the packaged FMU
    controller_fmu: Path | None = None
    fmi_version: int = 2                                 # of the packaged FMUs: 2 or 3
    progress: Callable[[int, int], None] | None = None  # progress(k, n): sample k of n reached
    # what the controller measures of the plant's (q, qd) (6,), and what the plant receives of
    # the controller's u (3,): e.g. the quantisation of a CAN bench (rrr_robot.hil.dbc.protocol);
    # identity when None
    measure: Callable[[FloatArray], FloatArray] | None = None
    actuate: Callable[[FloatArray], FloatArray] | None = None


@dataclass(frozen=True)
class CosimResult:
    """Recorded signals (one row per communication point) and timing of a run."""

    t: FloatArray          # (n,)
    q_ref: FloatArray      # (n, 3)
    qd_ref: FloatArray
    x_ref: FloatArray      # (n, 3) tip reference
    q: FloatArray          # plant outputs
    qd: FloatArray
    qdd: FloatArray
    tip: FloatArray        # (n, 3)
    u: FloatArray          # controller outputs
    u_n: FloatArray
    u_c: FloatArray
    wall_time: float       # s spent in the stepping loop
    cpu_time: float = float("nan")  # CPU time of the calling thread in that loop, s (unknown: nan)

    @property
    def realtime_factor(self) -> float:
        """Simulated time per wall-clock time of the loop."""
        return float(self.t[-1] - self.t[0]) / self.wall_time if self.wall_time > 0 else np.inf

    def columns(self) -> dict[str, FloatArray]:
        """Every signal as a named column, one row per communication point: ``t``, then
        ``q_ref[i]``, ``qd_ref[i]``, ``q[i]``, ``qd[i]``, ``qdd[i]``, ``u[i]``, ``u_n[i]``,
        ``u_c[i]`` (i = 1..3), ``x_ref.x`` ... ``tip.z`` (the FMU variables' names)."""
        cols: dict[str, FloatArray] = {"t": self.t}
        for name, fmu in _COLUMN_FMU.items():
            arr = getattr(self, name)
            cols |= {col: arr[:, i] for i, col in enumerate(fv.names(fmu, name))}
        return cols

    def write(self, path: Path, fmt: str = "csv") -> None:
        """Write :meth:`columns` as a ``csv`` or ``parquet`` table (core.tables: every value
        exact), atomically: the file appears complete or not at all (core.outputs)."""
        write_table(path, self.columns(), fmt)

    def to_csv(self, path: Path) -> None:
        """Write every signal as CSV (:meth:`write`)."""
        self.write(path, "csv")


def initial_state_values(q0: Sequence[float] | FloatArray, qd0: Sequence[float] | FloatArray,
                         ) -> dict[str, float | bool]:
    """The plant FMU's start values of the initial state: q0[i] and qd0[i] from (3,) arrays."""
    return {**{n: float(v) for n, v in zip(fv.names("plant", "q0"), q0, strict=True)},
            **{n: float(v) for n, v in zip(fv.names("plant", "qd0"), qd0, strict=True)}}


def _check_reference(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                     step: float) -> None:
    n = t.shape[0]
    if n < 2:
        raise BadInputError("the reference needs at least two samples")
    for name, arr in (("q_ref", q_ref), ("qd_ref", qd_ref), ("qdd_ref", qdd_ref)):
        if arr.shape != (n, 3):
            raise BadInputError(f"{name} must have shape ({n}, 3), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise BadInputError(f"{name} contains NaN or Inf")
    if not np.allclose(np.diff(t), step, rtol=1e-9, atol=1e-12):
        raise BadInputError(f"the reference must be sampled at the communication step {step} s")


def _cursor() -> tuple[Any, ct.c_void_p]:
    """A ``double*`` for FMPy's value arguments and the address it holds, to move it over a
    recording array (``address.value = ...``) so that the FMUs read from and write into the
    recording arrays directly: no copy and no new pointer object per step."""
    pointer = ct.POINTER(ct.c_double)()
    return pointer, ct.c_void_p.from_buffer(pointer)


def run_cosim(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
              x_ref: FloatArray, options: CosimOptions = CosimOptions()) -> CosimResult:
    """Co-simulate controller and plant FMUs along a sampled joint reference.

    The loop binds each FMI call once (FmuSlave.setter/getter/stepper) and points it into the
    recording arrays (_cursor): ``rows`` holds, per communication point, the reference (q_ref,
    qd_ref, qdd_ref) followed by the plant's outputs (q, qd, qdd, tip), so that its first 15
    columns are the controller's inputs in their order; ``ctrl_rec`` holds the controller's
    outputs, whose first three (u) are the plant's inputs. A failed call raises CosimError
    naming the FMU, the call and the time; messages of calls that succeeded are logged as
    warnings.
    """
    _check_reference(t, q_ref, qd_ref, qdd_ref, options.step)
    n = t.shape[0]
    plant_values = initial_state_values(q_ref[0], qd_ref[0])
    plant_values |= dict(options.plant_values)
    ctrl_fmu = options.controller_fmu or fmu_path("controller", options.fmi_version)
    plant_fmu = options.plant_fmu or fmu_path("plant", options.fmi_version)
    with pooled_slave(ctrl_fmu, "controller") as ctrl, pooled_slave(plant_fmu, "plant") as plant:
        ctrl.initialize(float(t[0]), options.controller_values)
        plant.initialize(float(t[0]), plant_values)
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        p_in, p_out = plant.real_block(PLANT_IN), plant.real_block(PLANT_OUT)
        rows = np.empty((n, 9 + len(PLANT_OUT)))
        rows[:, 0:3], rows[:, 3:6], rows[:, 6:9] = q_ref, qd_ref, qdd_ref
        ctrl_rec = np.empty((n, len(CTRL_OUT)))
        # row k of `rows` from its first column (the controller's inputs), row k of `ctrl_rec`
        # (the controller's outputs and, its first three, the plant's inputs), row k of `rows`
        # from column 9 (the plant's outputs); the arrays outlive the loop
        rows_at, row_bytes = rows.ctypes.data, rows.strides[0]
        out_at, out_bytes = ctrl_rec.ctypes.data, ctrl_rec.strides[0]
        (c_in_ptr, c_in_addr), (u_ptr, u_addr), (p_out_ptr, p_out_addr) = (
            _cursor(), _cursor(), _cursor())
        c_set, c_get, c_step = ctrl.setter(c_in), ctrl.getter(c_out), ctrl.stepper()
        p_set, p_get, p_step = plant.setter(p_in), plant.getter(p_out), plant.stepper()
        # row 0's qdd: the plant's acceleration under row 0's input (qdd depends on u directly),
        # read after that input is set; the plant's first outputs had it under its start u = 0
        p_qdd = plant.getter(plant.real_block(PLANT_OUT[6:9]))
        qdd0_ptr, qdd0_addr = _cursor()
        qdd0_addr.value = rows_at + 15 * 8
        measure, actuate = options.measure, options.actuate

        def c_set_measured(k: int) -> None:  # the controller's inputs through `measure`
            assert measure is not None
            c_in.values[:9] = rows[k, :9]
            c_in.values[9:] = measure(rows[k, 9:15])
            c_set(c_in.buffer)

        def p_set_actuated(k: int) -> None:  # the plant's inputs through `actuate`
            assert actuate is not None
            p_in.values[:] = actuate(ctrl_rec[k, :3])
            p_set(p_in.buffer)

        step, now = options.step, float(t[0])
        chunk = max(1, (n - 1) // 100) if options.progress is not None else n
        messages = (ctrl.messages, plant.messages)
        stage = "plant GetReal"
        start, start_cpu = time.perf_counter(), time.thread_time()
        try:
            p_out_addr.value = rows_at + 9 * 8
            p_get(p_out_ptr)
            for first in range(0, n - 1, chunk):
                for k in range(first, min(first + chunk, n - 1)):
                    stage = "controller SetReal"
                    if measure is None:
                        c_in_addr.value = rows_at + k * row_bytes
                        c_set(c_in_ptr)
                    else:
                        c_set_measured(k)
                    stage = "controller GetReal"
                    u_addr.value = out_at + k * out_bytes
                    c_get(u_ptr)
                    stage = "plant SetReal"
                    if actuate is None:
                        p_set(u_ptr)
                    else:
                        p_set_actuated(k)
                    if k == 0:
                        stage = "plant GetReal"
                        p_qdd(qdd0_ptr)
                    stage = "plant DoStep"
                    p_step(now, step)
                    stage = "controller DoStep"
                    c_step(now, step)
                    now += step
                    stage = "plant GetReal"
                    p_out_addr.value = rows_at + (k + 1) * row_bytes + 9 * 8
                    p_get(p_out_ptr)
                    if messages[0] or messages[1]:
                        _flush(ctrl, plant, now)
                if options.progress is not None:  # the sample reached: n - 1 at the end
                    options.progress(min(first + chunk, n - 1), n)
            stage = "controller SetReal"
            if measure is None:
                c_in_addr.value = rows_at + (n - 1) * row_bytes
                c_set(c_in_ptr)
            else:
                c_set_measured(n - 1)
            stage = "controller GetReal"
            u_addr.value = out_at + (n - 1) * out_bytes
            c_get(u_ptr)
        except FMICallException as exc:
            who, call = stage.split(" ")
            slave = ctrl if who == "controller" else plant
            raise slave.call_failed(call, exc, now) from exc
        if messages[0] or messages[1]:
            _flush(ctrl, plant, now)
        wall, cpu = time.perf_counter() - start, time.thread_time() - start_cpu
        ctrl.time = plant.time = now
    return CosimResult(
        t=t, q_ref=q_ref, qd_ref=qd_ref, x_ref=x_ref,
        q=rows[:, 9:12], qd=rows[:, 12:15], qdd=rows[:, 15:18], tip=rows[:, 18:21],
        u=ctrl_rec[:, 0:3], u_n=ctrl_rec[:, 3:6], u_c=ctrl_rec[:, 6:9], wall_time=wall,
        cpu_time=cpu,
    )


def _flush(ctrl: FmuSlave, plant: FmuSlave, now: float) -> None:
    """Log the FMUs' error messages of calls that succeeded as warnings."""
    for slave in (ctrl, plant):
        if slave.messages:
            slave.flush_messages(f"the step to t = {now:.6f} s")
