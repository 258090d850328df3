"""Results of a CAN bench run like the writing task's (every profile): its signals
(:class:`BenchRun`) as a co-simulation result, the writing task's metrics, the difference to the
unquantised co-simulation of the same scenario, the faults, the bus traffic and, in real time,
the wake-up latencies.

:func:`bench_result` turns the plant's log (the plant FMU's q, qd, qdd and tip of every period,
exact) and the controller's voltages into a :class:`~rrr_robot.sim.cosim.CosimResult`, so that
:func:`rrr_robot.writing.job.metrics` and the writing task's figures apply unchanged.
:func:`unquantised_cosim` runs the same scenario without the bench's quantisation in the C
closed loop (``rr.simulate``, bit-identical to the FMU co-simulation). :func:`bench_summary` is
what ``rrr hil`` writes to summary.json (each profile's files: ``hil.dbc.results``,
``hil.canopen.results``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.param_names import model_fmu_values
from ..core.summary import reference_section
from ..errors import HilError
from ..sim.cosim import CosimOptions, CosimResult
from ..sim.native import simulate
from ..writing.job import metrics, scenario_summary
from ..writing.trajectory import Reference
from .logs.specs import CONTROLLER_LOG, LATENCY_LOG, PLANT_LOG, read_log, write_log
from .nodes import PERIOD

__all__ = ["PLANT_LOG_COLUMNS", "BenchRun", "bench_result", "bench_summary", "comparison",
           "extend_reference", "latency_stats", "read_latency_log", "read_plant_log",
           "unquantised_cosim", "write_controller_log"]


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


def write_controller_log(run: BenchRun, path: Path) -> Path:
    """The controller log of a run (specs.CONTROLLER_LOG: the C controller node's --log),
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


def _span(first: str, n: int = 1) -> slice:
    i = PLANT_LOG.index(first)
    return slice(i, i + n)


#: Columns of the plant log (specs.PLANT_LOG: the C plant node's --log and the Python
#: plant's), by name.
PLANT_LOG_COLUMNS: dict[str, slice] = {
    "t": _span("t"), **{g: _span(fv.names("plant", g)[0], 3) for g in ("q", "qd", "u", "qdd")},
    "zero": _span("zero"), "faults": _span("faults"), "tip": _span(fv.names("plant", "tip")[0], 3)}


def read_plant_log(path: Path) -> FloatArray:
    """The rows of a plant log (HilError when it is not specs.PLANT_LOG)."""
    return read_log(path, PLANT_LOG).rows


def extend_reference(ref: Reference, duration: float) -> Reference:
    """The reference cut to, or held at its last pose up to, ``duration`` seconds (real time:
    the bench runs for --duration): velocities and accelerations 0 after its end."""
    n = round(duration / PERIOD) + 1
    idx = np.minimum(np.arange(n), ref.t.size - 1)
    moving = (np.arange(n) < ref.t.size)[:, None]
    t = ref.t[0] + np.arange(n) * PERIOD

    def hold(a: FloatArray) -> FloatArray:
        return np.where(moving, a[idx], 0.0)

    return replace(ref, t=t, x=ref.x[idx], xd=hold(ref.xd), xdd=hold(ref.xdd), q=ref.q[idx],
                   qd=hold(ref.qd), qdd=hold(ref.qdd), pen_down=ref.pen_down[idx],
                   speed=np.where(moving[:, 0], ref.speed[idx], 0.0), s=ref.s[idx])


def bench_result(ref: Reference, run: BenchRun, plant_log: FloatArray) -> CosimResult:
    """A bench run as a co-simulation result: the plant log's q, qd, qdd and tip (the plant
    FMU's outputs, exact) and the controller's u, u_n, u_c, period by period (in real time the
    plant's period k ends half a period after the controller's)."""
    if run.u_n is None or run.u_c is None:
        raise HilError("the bench run has no u_n and u_c (the controller's log)")
    m = min(plant_log.shape[0], run.u.shape[0], ref.t.shape[0])
    c = PLANT_LOG_COLUMNS
    return CosimResult(t=ref.t[:m], q_ref=ref.q[:m], qd_ref=ref.qd[:m], x_ref=ref.x[:m],
                       q=plant_log[:m, c["q"]], qd=plant_log[:m, c["qd"]],
                       qdd=plant_log[:m, c["qdd"]], tip=plant_log[:m, c["tip"]],
                       u=run.u[:m], u_n=run.u_n[:m], u_c=run.u_c[:m], wall_time=run.wall_time)


def unquantised_cosim(ref: Reference, model: Model,
                      controller_values: Mapping[str, float | bool]) -> CosimResult:
    """The same scenario without the bench's quantisation: the C closed loop (rr.simulate,
    bit-identical to the FMU co-simulation of the writing task)."""
    options = CosimOptions(step=PERIOD, plant_values=model_fmu_values(model),
                           controller_values=controller_values)
    return simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)


def _joint_errors(res: CosimResult) -> dict[str, Any]:
    e = res.q - res.q_ref
    return {"joint_error_max": np.abs(e).max(axis=0).tolist(),
            "joint_error_rms": np.sqrt(np.mean(e**2, axis=0)).tolist()}


def tracking(res: CosimResult) -> dict[str, Any]:
    """The writing task's metrics of a run (summary.json form) and its joint errors."""
    return scenario_summary({**metrics(res), **_joint_errors(res)})


def comparison(bench: CosimResult, other: CosimResult) -> dict[str, Any]:
    """Largest differences bench - other over their common periods: q, qd (rad, rad/s), u (V),
    tip (m), and of the tip error metrics (m)."""
    m = min(bench.t.shape[0], other.t.shape[0])
    a, b = metrics(bench), metrics(other)

    def dmax(x: FloatArray, y: FloatArray) -> list[float]:
        return np.abs(x[:m] - y[:m]).max(axis=0).tolist()  # type: ignore[no-any-return]

    return {
        "periods": m, "q_max_abs": dmax(bench.q, other.q), "qd_max_abs": dmax(bench.qd, other.qd),
        "u_max_abs": dmax(bench.u, other.u),
        "tip_max_abs_m": float(np.linalg.norm(bench.tip[:m] - other.tip[:m], axis=1).max()),
        "tip_error_max_delta_m": a["tip_error_max"] - b["tip_error_max"],
        "tip_error_rms_delta_m": a["tip_error_rms"] - b["tip_error_rms"],
    }


def read_latency_log(path: Path) -> FloatArray:
    """The (latency_ns, work_ns) rows of a node's --latency-log (specs.LATENCY_LOG)."""
    return read_log(path, LATENCY_LOG).cols(["latency_ns", "work_ns"])


@dataclass(frozen=True)
class _Percentiles:
    p50: float
    p99: float
    p999: float
    max: float


def _nearest_rank(sorted_values: FloatArray, p: float) -> float:
    """The value of rank ceil(p n) (rrr_hil_percentile's definition)."""
    n = sorted_values.shape[0]
    rank = min(n, max(1, int(np.ceil(p * n))))
    return float(sorted_values[rank - 1])


def latency_stats(latency_ns: FloatArray) -> dict[str, float | None]:
    """p50, p99, p99.9 and max of wake-up latencies, in us (nearest rank, as the nodes)."""
    if latency_ns.size == 0:
        return {"p50_us": None, "p99_us": None, "p999_us": None, "max_us": None}
    v = np.sort(latency_ns) * 1e-3
    pc = _Percentiles(*(_nearest_rank(v, p) for p in (0.5, 0.99, 0.999, 1.0)))
    return {"p50_us": pc.p50, "p99_us": pc.p99, "p999_us": pc.p999, "max_us": pc.max}


_FAULT_KEYS = ("faults", "fault_events", "crc", "counter", "range", "format", "sync", "bus",
               "timeout", "cmd_missed", "zero_periods", "resets", "stop_rejected",
               "state_out_of_range", "rx_bad_crc", "rx_bad_dlc", "rx_unknown_id")


def bench_summary(*, side: str, mode: str, scenario: str, ref: Reference, bench: CosimResult,
                  unquantised: CosimResult, plant: Mapping[str, Any],
                  controller: Mapping[str, Any], bus: Mapping[str, Any],
                  realtime: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """summary.json of ``rrr hil``: the bench run's metrics (the writing task's, plus joint
    errors), the unquantised co-simulation's and the difference, the plant's faults and missed
    commands, the controller's counters, the bus traffic and, in real time, the latencies."""
    s: dict[str, Any] = {
        "side": side, "mode": mode, "scenario": scenario,
        "reference": reference_section(ref.spec.text, ref.t[-1] - ref.t[0], PERIOD,
                                       periods=int(ref.t.shape[0])),
        "bench": tracking(bench),
        "unquantised_cosim": tracking(unquantised),
        "difference_to_unquantised": comparison(bench, unquantised),
        "faults": {k: plant.get(k) for k in _FAULT_KEYS if k in plant},
        "missed_commands": plant.get("cmd_missed"),
        "plant_exit": plant.get("exit"),
        "controller": {k: v for k, v in controller.items() if k != "rt"},
        "bus": dict(bus),
    }
    if realtime is not None:
        s["realtime"] = dict(realtime)
    return s
