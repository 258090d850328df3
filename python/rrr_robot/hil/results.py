"""Results of a CAN bench run like the writing task's: its signals as a co-simulation result,
the writing task's metrics, the difference to the unquantised co-simulation of the same
scenario, the faults, the bus traffic and, in real time, the wake-up latencies.

:func:`bench_result` turns the plant's log (the plant FMU's q, qd, qdd and tip of every period,
exact) and the controller's voltages into a :class:`~rrr_robot.sim.cosim.CosimResult`, so that
:func:`rrr_robot.writing.job.metrics` and the writing task's figures apply unchanged.
:func:`unquantised_cosim` runs the same scenario without the DBC's quantisation in the C closed
loop (``rr.simulate``, bit-identical to the FMU co-simulation). :func:`bench_summary` is what
``rrr hil bench|controller|plant`` write to summary.json.
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
from ..core.outputs import ResultSet
from ..core.param_names import model_fmu_values
from ..core.summary import reference_section, write_summary
from ..sim.cosim import CosimOptions, CosimResult
from ..sim.native import simulate
from ..writing.job import metrics, scenario_summary
from ..writing.trajectory import Reference
from .bench import BenchRun
from .logspec import LATENCY_LOG, PLANT_LOG, read_log
from .protocol import PERIOD, HilError

__all__ = ["PLANT_LOG_COLUMNS", "RunInfo", "bench_result", "bench_summary", "comparison",
           "extend_reference", "latency_stats", "read_latency_log", "read_plant_log",
           "unquantised_cosim", "write_results"]


def _span(first: str, n: int = 1) -> slice:
    i = PLANT_LOG.index(first)
    return slice(i, i + n)


#: Columns of the plant log (logspec.PLANT_LOG: the C plant node's --log and the Python
#: plant's), by name.
PLANT_LOG_COLUMNS: dict[str, slice] = {
    "t": _span("t"), **{g: _span(fv.names("plant", g)[0], 3) for g in ("q", "qd", "u", "qdd")},
    "zero": _span("zero"), "faults": _span("faults"), "tip": _span(fv.names("plant", "tip")[0], 3)}


def read_plant_log(path: Path) -> FloatArray:
    """The rows of a plant log (HilError when it is not logspec.PLANT_LOG)."""
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
    """The (latency_ns, work_ns) rows of a node's --latency-log (logspec.LATENCY_LOG)."""
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


@dataclass(frozen=True)
class RunInfo:
    """What a run was: its side (bench, controller, plant), mode (lockstep, realtime),
    scenario, the node's frame log in the staging folder and whose view that log is."""

    side: str
    mode: str
    scenario: str
    node_log: str
    view: str


def write_results(rs: ResultSet, info: RunInfo, ref: Reference, run: BenchRun, model: Model,
                  controller_values: Mapping[str, float | bool],
                  nodes: Mapping[str, Mapping[str, Any]], *, can_log: Path | None,
                  figures: bool = True, mcap: bool = False) -> dict[str, Any]:
    """Evaluate a run whose logs (plant.csv, the node's frame log, in real time the latency
    logs) are in the result set's staging folder: the unquantised co-simulation, the standard
    frame log (``can_log``: in the output folder, or elsewhere, written atomically), the
    figures, with ``mcap`` the run as ``bench.mcap`` (hil.mcap) and summary.json. Returns the
    summary."""
    from . import framelog as fl
    from .busload import FD_DATA_BITRATE, measured_fd_load, measured_load, schedule_load
    from .protocol import DBC_PATH, database

    work = rs.staging
    plant_log = read_plant_log(work / "plant.csv")
    bench = bench_result(ref, run, plant_log)
    if bench.t.shape[0] < 2:
        raise HilError(f"the bench ran {bench.t.shape[0]} periods: nothing to evaluate")
    ref_run = extend_reference(ref, float(bench.t[-1] - bench.t[0]))
    unq = unquantised_cosim(ref_run, model, controller_values)
    records = fl.read_node_log(work / info.node_log)
    bus: dict[str, Any] = {"node_log": info.node_log, "view": info.view, **fl.rates(records)}
    bus["measured_1mbit"] = measured_load(fl.frames(records), bench.t.shape[0])
    bus["schedule_worst_percent_1mbit"] = schedule_load(
        database(), lockstep=info.mode == "lockstep", dbc_name=str(DBC_PATH)).worst_percent
    if any(n.get("transport") == "socketcan-fd" for n in nodes.values()):
        # CAN FD frames on the bus (--fd): their load at 1 Mbit/s nominal, 5 Mbit/s data
        bus["measured_fd"] = measured_fd_load(fl.frames(records), bench.t.shape[0])
        bus["schedule_fd_worst_percent"] = schedule_load(
            database(), data_bitrate=FD_DATA_BITRATE, lockstep=info.mode == "lockstep",
            dbc_name=str(DBC_PATH)).worst_percent
    if can_log is not None:
        inside = can_log.parent.resolve() == rs.folder.resolve()
        fl.write_can_log(records, rs.path(can_log.name) if inside else can_log)
        bus["can_log"] = can_log.name if inside else str(can_log)
    if mcap:
        from ..core.robot import read_robot_file
        from .mcap import write_bench_mcap

        m = bench.t.shape[0]
        write_bench_mcap(rs.path("bench.mcap"), bench.columns(), read_robot_file(), records,
                         plant_log[:m, PLANT_LOG_COLUMNS["faults"]][:, 0],
                         metadata={"side": info.side, "mode": info.mode,
                                   "scenario": info.scenario, "view": info.view})
    realtime: dict[str, Any] | None = None
    latencies: dict[str, FloatArray] = {}
    stats: dict[str, dict[str, Any]] = {}
    if info.mode == "realtime":
        for node in ("controller", "plant"):
            lat = read_latency_log(work / f"latency_{node}.csv")
            latencies[node] = lat[:, 0]
            stats[node] = {**latency_stats(lat[:, 0]), **nodes[node].get("rt", {})}
        realtime = {**stats, "goal_p99_us": 50.0}
    summary = bench_summary(side=info.side, mode=info.mode, scenario=info.scenario, ref=ref_run,
                            bench=bench, unquantised=unq, plant=nodes["plant"],
                            controller=nodes["controller"], bus=bus, realtime=realtime)
    if figures:
        from .figures import write_bench_figures

        write_bench_figures(work, ref_run, bench, unq, latencies or None, stats,
                            scenario=info.scenario)
    return write_summary(rs, summary)
