"""The files of a CANopen profile run (``rrr hil canopen``): the writing task's reference and
controller it runs (:func:`writing_controller`), and summary.json with the drives' bus traffic,
the frame logs and the figures (:func:`write_master_results`), on the shared evaluation of
:mod:`rrr_robot.hil.results`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...core.control import CtcGains
from ...core.model import Model
from ...core.outputs import ResultSet
from ...errors import HilError
from ...writing.trajectory import Reference
from .drives import CAN_LOG, NODE_FRAMES
from .master import MasterRun

__all__ = ["WritingController", "write_master_results", "writing_controller"]


@dataclass(frozen=True)
class WritingController:
    """The writing task's reference and a scenario's controller, as ``rrr hil bench`` runs
    them (writing.job.prepare): the true model (the plant's), the controller's model and gains,
    and the controller FMU's start values of the same (the co-simulations')."""

    ref: Reference
    model: Model
    controller_model: Model
    gains: CtcGains
    controller_values: dict[str, float | bool]


def writing_controller(text: str | None = None, scenario: str = "ctc") -> WritingController:
    """The writing reference and the controller of ``scenario`` (pd, ctc, mismatch or a
    scenario .toml) on the default robot."""
    from ...writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), text=text,
                                                      scenarios=[scenario]))
    scn, control = scenarios[0], robot.require_control()
    gains = CtcGains(kp=scn.kp or control.kp, kd=scn.kd or control.kd,
                     feedforward=scn.feedforward)
    return WritingController(ref, model, scn.controller_model(model), gains,
                             controller_fmu_values(scn, model, control))


def write_master_results(rs: ResultSet, wc: WritingController, mrun: MasterRun, *,
                         scenario: str, figures: bool = True) -> dict[str, Any]:
    """The run's files into the result set: controller.csv (the master's log), plant.csv and
    the frame log NODE_FRAMES (already there: the plant node's), frames.blf (the same frames),
    summary.json (results.bench_summary, core.summary) and the figures. Returns the summary."""
    from ...core.summary import write_summary
    from ..busload import bus_loads
    from ..logs import frames as fl
    from ..results import (
        bench_result,
        bench_summary,
        read_plant_log,
        unquantised_cosim,
        write_controller_log,
    )
    from .drives import canopen_load

    work = rs.staging
    write_controller_log(mrun.run, work / "controller.csv")
    bench = bench_result(wc.ref, mrun.run, read_plant_log(work / "plant.csv"))
    if bench.t.shape[0] != wc.ref.t.shape[0]:
        raise HilError(f"the plant logged {bench.t.shape[0]} periods of {wc.ref.t.shape[0]}")
    unq = unquantised_cosim(wc.ref, wc.model, wc.controller_values)
    n = bench.t.shape[0]
    records = fl.read_node_log(work / NODE_FRAMES)
    fl.write_can_log(records, rs.path(CAN_LOG))
    bus = {"profile": "canopen", "node_log": NODE_FRAMES, "can_log": CAN_LOG,
           "view": "the C plant node's (Tx: the drives' frames, Rx: the master's)",
           **fl.traffic(records, n, realtime=mrun.realtime is not None),
           # the SYNC schedule is the same in both modes: it is the real-time schedule too
           "load": bus_loads(fl.frames(records), n, canopen_load(1_000_000),
                             canopen_load(1_000_000)),
           "node_ids": [d.node_id for d in mrun.drives],
           "sync_periods": n, "schedule_frames_per_period": 1 + 3 * len(mrun.drives),
           "drives": [{"node_id": d.node_id, "rated_torque_mNm": d.rated_torque_mNm,
                       "increments_per_revolution": d.increments,
                       "pdo_mapping": {k: [f"0x{i:04X}:{b}" for i, b in v]
                                       for k, v in d.mapping.items()}}
                      for d in mrun.drives],
           "target_torque_per_mille_max_abs": np.abs(mrun.torque_pm).max(axis=0).tolist()}
    drives = mrun.plant_summary.get("drives", [])
    # the drives' faults and missed commands (RPDO timeouts), in the DBC plant's keys
    plant = {**mrun.plant_summary, "faults": mrun.plant_summary.get("drive_faults"),
             "cmd_missed": sum(int(d.get("rpdo_timeouts", 0)) for d in drives)}
    realtime = None
    if mrun.realtime is not None:
        from .realtime import frame_log_timing, realtime_summary

        realtime = realtime_summary(mrun.realtime, mrun.master_setup,
                                    frame_log_timing(records, [d.node_id for d in mrun.drives]),
                                    mrun.run.controller_summary
                                    if mrun.run.controller_summary.get("master") == "c" else None,
                                    mrun.plant_summary.get("rt_setup"))
        bus["sync_periods"] = realtime["drives"]["syncs"]
    summary = bench_summary(side="canopen", mode="lockstep" if realtime is None else "realtime",
                            scenario=scenario, ref=wc.ref, bench=bench, unquantised=unq,
                            plant=plant, controller=mrun.run.controller_summary, bus=bus,
                            realtime=realtime)
    if figures:
        from ..figures import write_bench_figures

        write_bench_figures(work, wc.ref, bench, unq, scenario=scenario)
    return write_summary(rs, summary)
