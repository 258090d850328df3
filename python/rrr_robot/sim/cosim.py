"""The co-simulation master: reference -> controller FMU -> plant FMU -> back, fixed step.

At each communication point t_k the controller (direct feedthrough) gets the reference and the
plant's measured state and returns u; the plant integrates over [t_k, t_k + h] with u held; both
FMUs then advance. Every signal is recorded into preallocated arrays.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core._arrays import FloatArray
from ..core.robot_file import DEFAULT_SAMPLE_TIME
from ..core.tables import write_table
from ..errors import BadInputError
from .fmu_slave import FmuSlave
from .fmus import fmu_path

log = logging.getLogger(__name__)

J = (1, 2, 3)
CTRL_IN = [f"{s}[{i}]" for s in ("q_ref", "qd_ref", "qdd_ref", "q", "qd") for i in J]
CTRL_OUT = [f"{s}[{i}]" for s in ("u", "u_n", "u_c") for i in J]
PLANT_IN = [f"u[{i}]" for i in J]
PLANT_OUT = [f"{s}[{i}]" for s in ("q", "qd", "qdd") for i in J] + ["tip.x", "tip.y", "tip.z"]


@dataclass(frozen=True)
class CosimOptions:
    """Settings of one co-simulation run."""

    step: float = DEFAULT_SAMPLE_TIME                    # communication step, s
    plant_values: Mapping[str, float | bool] = field(default_factory=dict)
    controller_values: Mapping[str, float | bool] = field(default_factory=dict)
    plant_fmu: Path | None = None                        # default: the packaged FMU
    controller_fmu: Path | None = None
    fmi_version: int = 2                                 # of the packaged FMUs: 2 or 3
    progress: Callable[[int, int], None] | None = None  # called as progress(k, n) now and then
    # what the controller measures of the plant's (q, qd) (6,), and what the plant receives of
    # the controller's u (3,): e.g. the quantisation of a CAN bench (rrr_robot.hil.protocol);
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

    @property
    def realtime_factor(self) -> float:
        """Simulated time per wall-clock time of the loop."""
        return float(self.t[-1] - self.t[0]) / self.wall_time if self.wall_time > 0 else np.inf

    def columns(self) -> dict[str, FloatArray]:
        """Every signal as a named column, one row per communication point: ``t``, then
        ``q_ref[i]``, ``qd_ref[i]``, ``q[i]``, ``qd[i]``, ``qdd[i]``, ``u[i]``, ``u_n[i]``,
        ``u_c[i]`` (i = 1..3), ``x_ref.x`` ... ``tip.z`` (the FMU variables' names)."""
        cols: dict[str, FloatArray] = {"t": self.t}
        for name in ("q_ref", "qd_ref", "q", "qd", "qdd", "u", "u_n", "u_c"):
            arr = getattr(self, name)
            for i in range(3):
                cols[f"{name}[{i + 1}]"] = arr[:, i]
        for name in ("x_ref", "tip"):
            arr = getattr(self, name)
            for i, axis in enumerate("xyz"):
                cols[f"{name}.{axis}"] = arr[:, i]
        return cols

    def write(self, path: Path, fmt: str = "csv") -> None:
        """Write :meth:`columns` as a ``csv`` or ``parquet`` table (core.tables: every value
        exact), atomically: the file appears complete or not at all (core.outputs)."""
        write_table(path, self.columns(), fmt)

    def to_csv(self, path: Path) -> None:
        """Write every signal as CSV (:meth:`write`)."""
        self.write(path, "csv")


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


def run_cosim(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
              x_ref: FloatArray, options: CosimOptions = CosimOptions()) -> CosimResult:
    """Co-simulate controller and plant FMUs along a sampled joint reference."""
    _check_reference(t, q_ref, qd_ref, qdd_ref, options.step)
    n = t.shape[0]
    plant_values = {f"q0[{i}]": float(q_ref[0, i - 1]) for i in J}
    plant_values |= {f"qd0[{i}]": float(qd_ref[0, i - 1]) for i in J}
    plant_values |= dict(options.plant_values)
    ctrl_fmu = options.controller_fmu or fmu_path("controller", options.fmi_version)
    plant_fmu = options.plant_fmu or fmu_path("plant", options.fmi_version)
    with FmuSlave(ctrl_fmu, "controller") as ctrl, FmuSlave(plant_fmu, "plant") as plant:
        ctrl.initialize(float(t[0]), options.controller_values)
        plant.initialize(float(t[0]), plant_values)
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        p_in, p_out = plant.real_block(PLANT_IN), plant.real_block(PLANT_OUT)
        plant_rec = np.empty((n, len(PLANT_OUT)))
        ctrl_rec = np.empty((n, len(CTRL_OUT)))
        ref = np.hstack([q_ref, qd_ref, qdd_ref])
        plant.get_block(p_out)
        step, every = options.step, max(1, n // 100)
        measure, actuate = options.measure, options.actuate
        start = time.perf_counter()
        for k in range(n):
            plant_rec[k] = p_out.values
            c_in.values[:9] = ref[k]
            c_in.values[9:] = p_out.values[:6] if measure is None else measure(p_out.values[:6])
            ctrl.set_block(c_in)
            ctrl.get_block(c_out)
            ctrl_rec[k] = c_out.values
            if k == n - 1:
                break
            p_in.values[:] = c_out.values[:3] if actuate is None else actuate(c_out.values[:3])
            plant.set_block(p_in)
            plant.do_step(step)
            ctrl.do_step(step)
            plant.get_block(p_out)
            if options.progress is not None and k % every == 0:
                options.progress(k, n)
        wall = time.perf_counter() - start
    return CosimResult(
        t=t, q_ref=q_ref, qd_ref=qd_ref, x_ref=x_ref,
        q=plant_rec[:, 0:3], qd=plant_rec[:, 3:6], qdd=plant_rec[:, 6:9], tip=plant_rec[:, 9:12],
        u=ctrl_rec[:, 0:3], u_n=ctrl_rec[:, 3:6], u_c=ctrl_rec[:, 6:9], wall_time=wall,
    )
