"""``rrr ls-bus`` as a library call: the CAN bench's two nodes as FMI-LS-BUS network FMUs in
an fmucontainer, run by FMPy, turned into the files of ``rrr hil bench`` (plant.csv,
controller.csv, the controller's frame log) and what the bus did to the frames.
"""

from __future__ import annotations

import contextlib
import logging
import shutil
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...core import fmu_vars as fv
from ...core._arrays import FloatArray
from ...errors import HilError, one_line
from ...writing.trajectory import Reference
from ..dbc.protocol import EXIT_SAFETY
from ..logs.specs import CONTROLLER_LOG, PLANT_LOG, write_log
from ..nodes import PERIOD, Progress, export_reference
from ..results import BenchRun
from . import datalog as dl
from .container import CONTAINER, NODES, ContainerSpec, build_container, outputs

__all__ = ["LsbusRun", "frame_delays", "run_lsbus"]

log = logging.getLogger(__name__)

#: The node's frame log the results read (hil.dbc.results: its bus traffic), and the pcap.
NODE_LOG = "frames.rrrcan"
PCAP = "frames.pcap"


@dataclass(frozen=True)
class LsbusRun:
    """A container run: the bench run, the nodes' counters (summary keys of the C nodes), what
    the bus did to each node's frames, the container and the tools."""

    run: BenchRun
    nodes: dict[str, Mapping[str, Any]]
    ls_bus: dict[str, Any]
    rc: int


def _status(r: np.ndarray, role: str) -> dict[str, Any]:
    """The node's counters at the end of the run (status.* outputs), as integers."""
    prefix = f"{role}.status."
    return {name[len(prefix):]: int(r[name][-1]) for name in r.dtype.names or ()
            if name.startswith(prefix)}


def _cols(r: np.ndarray, role: str, names: list[str]) -> FloatArray:
    return np.stack([np.asarray(r[f"{role}.{n}"], dtype=float) for n in names], axis=1)


def frame_delays(log: list[dl.Transmission], sent_by: str, received_by: str,
                 ) -> dict[str, Any]:
    """What the link did to the CAN frames of sender ``sent_by``: each matched, in order, with
    the first equal frame (identifier and data) that ``received_by`` delivers at or after its
    sending; frames sent, delivered, lost (never delivered; those sent in the run's last period
    are counted as still in flight instead), and the delays (s) of the delivered ones: mean,
    max, and how many came in a later period than they were sent."""
    sent = [(tr.time, op.can_id, op.data) for tr in log if tr.sender == sent_by
            for op in tr.ops if op.opcode == dl.CAN_TRANSMIT]
    got = [(tr.time, op.can_id, op.data) for tr in log if tr.sender == received_by
           for op in tr.ops if op.opcode == dl.CAN_TRANSMIT]
    delays: list[float] = []
    late = in_flight = 0
    end = max((tr.time for tr in log), default=0.0)
    j = 0
    for t, can_id, data in sent:
        k = j
        while k < len(got) and not (got[k][1] == can_id and got[k][2] == data and got[k][0] >= t):
            k += 1
        if k == len(got):
            in_flight += t > end - PERIOD + 1e-9
            continue
        delays.append(got[k][0] - t)
        late += int(np.floor(got[k][0] / PERIOD + 1e-6)) > int(np.floor(t / PERIOD + 1e-6))
        j = k + 1
    d = np.asarray(delays)
    return {"sent": len(sent), "delivered": len(delays),
            "lost": len(sent) - len(delays) - in_flight, "in_flight_at_end": in_flight,
            "delayed_to_a_later_period": late,
            "delay_mean_s": float(d.mean()) if d.size else None,
            "delay_max_s": float(d.max()) if d.size else None}


def run_lsbus(ref: Reference, plant_values: Mapping[str, float | bool],
              controller_values: Mapping[str, float | bool], work: Path, *,
              bus_sim: bool = False, bitrate: int = 1_000_000, step: float | None = None,
              progress: Progress | None = None) -> LsbusRun:
    """Build the container in ``work/container`` (fmucontainer), run it with FMPy over the
    reference's duration, and write plant.csv, controller.csv, the controller's frame log
    (frames.rrrcan), the pcap of every frame (frames.pcap), reference.csv, the container, its
    description (container.json) with the FMUs it names, and its data log into ``work``.
    ``bus_sim``: through the bus simulation FMU at ``bitrate`` bit/s, the controller's
    real-time schedule (no Sync), container steps of ``step`` s (default 10 us: a frame's end
    is seen at the next step); else the direct link, the lockstep schedule, steps of one
    period (the C bench's arithmetic)."""
    import fmpy

    n = ref.t.shape[0]
    duration = float(ref.t[-1] - ref.t[0])
    ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv",
                               (ref.x, ref.xd, ref.xdd))
    plant = {**{name: float(v) for name, v in zip(fv.names("plant", "q0"), ref.q[0], strict=True)},
             **{name: float(v) for name, v in zip(fv.names("plant", "qd0"), ref.qd[0],
                                                  strict=True)},
             **plant_values}
    ctrl = {**controller_values, "sync": not bus_sim}
    spec = ContainerSpec(reference_csv=ref_csv, plant_values=plant, controller_values=ctrl,
                         bus_sim=bus_sim, bitrate=bitrate,
                         step=(step if step is not None else (1e-5 if bus_sim else PERIOD)))
    cdir = (work / "container").resolve()  # absolute: the run changes into it
    container = build_container(spec, cdir)
    names = [f"{role}.{v}" for role in NODES for v in outputs(role)]

    def finished(t: float, _recorder: Any) -> bool:
        if progress is not None:
            progress(min(n, round(t / PERIOD) + 1), n)
        return True

    def fmu_log(*args: Any) -> None:  # the container's and the FMUs' messages: DEBUG lines
        message = args[-1]
        log.debug("%s", message.decode(errors="replace") if isinstance(message, bytes)
                  else message)

    start = time.perf_counter()
    with contextlib.chdir(cdir):  # the container writes its data log into the working folder
        try:
            r = fmpy.simulate_fmu(str(container), start_time=0.0, stop_time=duration,
                                  step_size=PERIOD, output_interval=PERIOD, output=names,
                                  validate=False, step_finished=finished, logger=fmu_log)
        except Exception as exc:  # FMPy raises Exception for a failed FMI call
            raise HilError(f"FMPy could not run the container {container}: "
                           f"{one_line(exc)}") from exc
    wall = time.perf_counter() - start
    if r.shape[0] != n:
        raise HilError(f"the container run has {r.shape[0]} rows, the reference {n} periods")
    datalog = f"{Path(CONTAINER).stem}-datalog.csv"
    # results (plain files of the output): the container, its data log, and what fmucontainer
    # builds it from again (container.json and the node copies it names)
    nodes = ["controller.fmu", "plant.fmu", *(["bus.fmu"] if bus_sim else [])]
    for name in (CONTAINER, datalog, "container.json", *nodes):
        shutil.copyfile(cdir / name, work / name)
    sent = dl.read_datalog(work / datalog)
    rx = "bus.Node1" if bus_sim else "plant.CAN"
    dl.write_node_log(sent, "controller.CAN", rx, work / NODE_LOG)
    frames_in_pcap = dl.write_pcap(sent, work / PCAP,
                                   ("controller.CAN", "plant.CAN") if bus_sim else None)

    # the times the C nodes log: the controller k * period, the plant its steps summed
    t = np.arange(n) * PERIOD
    t_plant = np.cumsum(np.r_[0.0, np.full(n - 1, PERIOD)])
    q, qd = _cols(r, "plant", fv.names("plant", "q")), _cols(r, "plant", fv.names("plant", "qd"))
    u_plant = _cols(r, "plant", fv.names("plant", "u"))
    p_status, c_status = _status(r, "plant"), _status(r, "controller")
    rows = np.zeros((n, len(PLANT_LOG.columns)))
    rows[:, PLANT_LOG.index("k")] = np.arange(n)
    rows[:, PLANT_LOG.index("t")] = t_plant
    for group, values in (("q", q), ("qd", qd), ("u", u_plant),
                          ("qdd", _cols(r, "plant", fv.names("plant", "qdd"))),
                          ("tip", _cols(r, "plant", fv.names("plant", "tip")))):
        rows[:, PLANT_LOG.indices(fv.names("plant", group))] = values
    rows[:, PLANT_LOG.index("zero")] = np.asarray(r["plant.zero"], dtype=float)
    rows[:, PLANT_LOG.index("faults")] = np.asarray(r["plant.status.faults"], dtype=float)
    write_log(work / "plant.csv", PLANT_LOG, rows)
    safety = any(p_status.get(k, 0) for k in ("faults", "fault_events", "zero_periods"))
    p_status["exit"] = EXIT_SAFETY if safety else 0
    faulty = c_status.get("plant_status_faulty", 0) or c_status.get("plant_status_zero", 0)
    c_status["exit"] = EXIT_SAFETY if faulty else 0
    run = BenchRun(t=t_plant, q=q, qd=qd, u=_cols(r, "controller", fv.names("controller", "u")),
                   plant_summary=p_status, controller_summary=c_status,
                   u_n=_cols(r, "controller", fv.names("controller", "u_n")),
                   u_c=_cols(r, "controller", fv.names("controller", "u_c")), wall_time=wall)
    # the controller's log: the state it received (quantised by JointState), as the C node's
    rows = np.zeros((n, len(CONTROLLER_LOG.columns)))
    rows[:, CONTROLLER_LOG.index("k")] = np.arange(n)
    rows[:, CONTROLLER_LOG.index("t")] = t
    rows[:, CONTROLLER_LOG.index("enable")] = np.asarray(r["controller.enable"], dtype=float)
    for group in ("q", "qd", "u", "u_n", "u_c"):
        names = fv.names("controller", group)
        rows[:, CONTROLLER_LOG.indices(fv.joint_names(group))] = _cols(r, "controller", names)
    write_log(work / "controller.csv", CONTROLLER_LOG, rows)
    from importlib.metadata import version

    periods = np.asarray(r["controller.period"], dtype=float)
    ls_bus: dict[str, Any] = {
        "container": CONTAINER, "data_log": datalog, "description": "container.json",
        "built_by": f"fmu_manipulation_toolbox {version('fmu-manipulation-toolbox')} "
        "(fmucontainer)",
        "run_by": f"FMPy {fmpy.__version__} (simulate_fmu)",
        "link": "bus simulation (rrr_can_bus_simulation)" if bus_sim else "direct",
        "bitrate": bitrate, "container_step_s": spec.step, "wall_time_s": wall,
        "schedule": "real time (VoltageCmd only)" if bus_sim else "lockstep (VoltageCmd, Sync)",
        "periods_without_a_command": n - int(np.isin(np.arange(n), periods).sum()),
        "pcap": PCAP, "pcap_frames": frames_in_pcap,
    }
    if bus_sim:  # the data log holds what the bus delivered to each node
        ls_bus["controller_to_plant"] = frame_delays(sent, "controller.CAN", "bus.Node2")
        ls_bus["plant_to_controller"] = frame_delays(sent, "plant.CAN", "bus.Node1")
    else:  # the direct link hands a value over within the event: the receivers' counts
        for key, (sender, receiver) in {"controller_to_plant": (c_status, p_status),
                                        "plant_to_controller": (p_status, c_status)}.items():
            n_sent, n_got = sender.get("frames_sent", 0), receiver.get("frames_received", 0)
            ls_bus[key] = {"sent": n_sent, "delivered": n_got, "lost": n_sent - n_got,
                           "in_flight_at_end": 0, "delayed_to_a_later_period": 0,
                           "delay": "none: delivered in the event it was sent in"}
    rc = p_status["exit"] or c_status["exit"]
    return LsbusRun(run=run, nodes={"plant": p_status, "controller": c_status}, ls_bus=ls_bus,
                    rc=int(rc))
