"""The files of a DBC profile run (``rrr hil bench|controller|plant``): summary.json with the
bus traffic of the DBC's schedule, the standard frame log, the figures and, with ``--mcap``, the
run as MCAP; on the shared evaluation of :mod:`rrr_robot.hil.results`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...core._arrays import FloatArray
from ...core.model import Model
from ...core.outputs import ResultSet
from ...core.summary import write_summary
from ...errors import HilError
from ...writing.trajectory import Reference
from ..results import (
    PLANT_LOG_COLUMNS,
    BenchRun,
    bench_result,
    bench_summary,
    extend_reference,
    latency_stats,
    read_latency_log,
    read_plant_log,
    unquantised_cosim,
)

__all__ = ["RunInfo", "write_results"]


@dataclass(frozen=True)
class RunInfo:
    """What a run was: its side (bench, controller, plant), mode (lockstep, realtime),
    scenario, the node's frame log in the staging folder, whose view that log is and the bit
    rate of the bus its loads are given for."""

    side: str
    mode: str
    scenario: str
    node_log: str
    view: str
    bitrate: int = 1_000_000


def write_results(rs: ResultSet, info: RunInfo, ref: Reference, run: BenchRun, model: Model,
                  controller_values: Mapping[str, float | bool],
                  nodes: Mapping[str, Mapping[str, Any]], *, can_log: Path | None,
                  figures: bool = True, mcap: bool = False,
                  extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Evaluate a run whose logs (plant.csv, the node's frame log, in real time the latency
    logs) are in the result set's staging folder: the unquantised co-simulation, the standard
    frame log (``can_log``: in the output folder, or elsewhere, written atomically), the
    figures, with ``mcap`` the run as ``bench.mcap`` (hil.logs.mcap) and summary.json (with the
    sections of ``extra`` added: ``rrr hil pil``'s target). Returns the summary."""
    from ..busload import FD_DATA_BITRATE, bus_loads, fd_bus_loads, schedule_load
    from ..logs import frames as fl
    from .protocol import DBC_PATH, FAULT_BITS, database, frame_id

    work = rs.staging
    plant_log = read_plant_log(work / "plant.csv")
    bench = bench_result(ref, run, plant_log)
    if bench.t.shape[0] < 2:
        raise HilError(f"the bench ran {bench.t.shape[0]} periods: nothing to evaluate")
    ref_run = extend_reference(ref, float(bench.t[-1] - bench.t[0]))
    unq = unquantised_cosim(ref_run, model, controller_values)
    records = fl.read_node_log(work / info.node_log)
    periods, lockstep = bench.t.shape[0], info.mode == "lockstep"
    bus: dict[str, Any] = {"node_log": info.node_log, "view": info.view,
                           **fl.traffic(records, periods, realtime=not lockstep)}
    # the loads of the run's bus (1 Mbit/s but rrr ls-bus --bitrate), each named
    # (hil.busload.bus_loads; docs/can-bench.md, "Which load is which")
    bus["load"] = bus_loads(
        fl.frames(records), periods,
        schedule_load(database(), info.bitrate, lockstep=lockstep, dbc_name=str(DBC_PATH)),
        schedule_load(database(), info.bitrate, dbc_name=str(DBC_PATH)))
    if any(n.get("transport") == "socketcan-fd" for n in nodes.values()):
        # CAN FD frames on the bus (--fd): their load at 1 Mbit/s nominal, 5 Mbit/s data
        bus["load_fd"] = fd_bus_loads(
            fl.frames(records), periods,
            schedule_load(database(), data_bitrate=FD_DATA_BITRATE, lockstep=lockstep,
                          dbc_name=str(DBC_PATH)))
    if can_log is not None:
        inside = can_log.parent.resolve() == rs.folder.resolve()
        fl.write_can_log(records, rs.path(can_log.name) if inside else can_log)
        bus["can_log"] = can_log.name if inside else str(can_log)
    if mcap:
        from ...core.robot import read_robot_file
        from ..logs.mcap import write_bench_mcap

        m = bench.t.shape[0]
        write_bench_mcap(rs.path("bench.mcap"), bench.columns(), read_robot_file(), records,
                         plant_log[:m, PLANT_LOG_COLUMNS["faults"]][:, 0], database(),
                         period_id=frame_id("JointState1"), fault_bits=len(FAULT_BITS),
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
    summary.update(extra or {})
    if figures:
        from ..figures import write_bench_figures

        write_bench_figures(work, ref_run, bench, unq, latencies or None, stats,
                            scenario=info.scenario)
    if extra:  # the sections of the run's kind (rrr ls-bus: the container and its bus)
        summary = {**summary, **extra}
    return write_summary(rs, summary)
