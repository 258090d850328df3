"""The C controller node as the CANopen master (``rrr hil canopen --master c``,
``rrr_hil_controller --profile canopen``): the same NMT, SDO and 402 sequence as the Python master
(:mod:`.master`), the core's computed-torque law, one SYNC per period in lockstep or on its own
clock in real time, against the same drives.
"""

from __future__ import annotations

import contextlib
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ...core._arrays import FloatArray
from ...core.model import Model
from ...errors import BadInputError
from ..logs.specs import CONTROLLER_LOG, read_log
from ..nodes import (
    GRACE_PERIODS,
    PERIOD,
    LogProgress,
    Progress,
    boot_up_watch,
    controller_node_args,
    export_reference,
    failure_folder,
    start_controller,
    wait_for_boot_up,
    watch_nodes,
)
from ..results import BenchRun
from .drives import (
    DEFAULT_NODE_IDS,
    EXPECTED_MAPPING,
    STOP_END_MS_SOCKETCAN,
    DriveInfo,
    start_drives,
    torque_per_mille,
)
from .master import MasterRun, check_run
from .realtime import HEARTBEAT_MS, CanopenRealTime

__all__ = ["run_c_master"]


def run_c_master(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                 model: Model, controller_values: Mapping[str, float | bool], work: Path, *,
                 node_ids: Sequence[int] = DEFAULT_NODE_IDS, timeout: float = 5.0,
                 progress: Progress | None = None, interface: str = "socketcand",
                 channel: str = "vcan0", realtime: CanopenRealTime | None = None) -> MasterRun:
    """As :func:`.master.run_canopen_master`, with the C controller node as the master
    (``rrr_hil_controller --profile canopen``: the same NMT, SDO and 402 sequence, the core's
    computed-torque law with the controller FMU's ``controller_values``, one SYNC per period).
    ``model`` is the same controller model (its k_t give the target torques of the log's u).
    HilError when a node fails or stops answering (nodes.watch_nodes), naming it, with the C
    master's exit status and its reason; TamperedError when a drive's TPDO came twice in a SYNC
    or with another length than its mapping's (the C master's exit status 8). ``realtime``: the
    C master's ``--realtime`` (its rrr_hil_rt clock, SCHED_FIFO ``realtime.fifo`` and mlockall
    when permitted, the spin; the SYNC source is its clock, its heartbeat every HEARTBEAT_MS,
    20 ms, the drives' consumer time ``realtime.consumer_ms`` and RPDO timeout
    ``realtime.rpdo_timeout`` as its --consumer-ms and --rpdo-timeout), and the plant's."""
    check_run(t, q_ref, node_ids, interface, realtime)
    if realtime is not None and (realtime.heartbeat_stop_at is not None
                                 or realtime.heartbeat_ms != HEARTBEAT_MS):
        raise BadInputError(f"the C master in real time: its own heartbeat of {HEARTBEAT_MS} ms, "
                            "never stopped (heartbeat loss is injected with the Python master)")
    n = t.shape[0]
    sc = interface == "socketcan"
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="rrr_co_") as tmp:
        ref_csv = export_reference(t, q_ref, qd_ref, qdd_ref, Path(tmp) / "reference.csv")
        ctrl_log = Path(tmp) / "controller.csv"
        with contextlib.ExitStack() as stack:
            boot = 0x700 + DEFAULT_NODE_IDS[0]  # the plant's first drive
            watch = stack.enter_context(boot_up_watch(channel, boot)) if sc else None
            plant = stack.enter_context(start_drives(
                q_ref, qd_ref, Path(work), channel if sc else None,
                None if realtime is None else realtime.fifo, timeout=timeout))
            if watch is not None:
                wait_for_boot_up(watch, plant, boot)
            extra = ["--profile", "canopen", "--node-ids", ",".join(str(i) for i in node_ids),
                     "--timeout-ms", str(round(timeout * 1000)),
                     *controller_node_args(controller_values)]
            if realtime is not None:
                extra += ["--realtime", "--mlock", "--spin-us", str(realtime.spin_us),
                          "--consumer-ms", str(realtime.consumer_ms),
                          *(["--fifo", str(realtime.fifo)] if realtime.fifo else []),
                          *([] if realtime.rpdo_timeout is None
                            else ["--rpdo-timeout", str(realtime.rpdo_timeout)])]
            ctrl = stack.enter_context(start_controller(
                ref_csv, connect=f"127.0.0.1:{plant.port}", log_csv=ctrl_log, extra=extra,
                socketcan=channel if sc else None))
            # over SocketCAN the plant ends STOP_END_MS_SOCKETCAN after the master's NMT stop
            cs, ps = watch_nodes([ctrl, plant], "the CANopen bench (C master) failed",
                                 failure_folder(work), poll=LogProgress(ctrl_log, n, progress),
                                 grace=GRACE_PERIODS * PERIOD + STOP_END_MS_SOCKETCAN * 1e-3)
        c = read_log(ctrl_log, CONTROLLER_LOG)
    u = c.group("u")
    drives = [DriveInfo(int(i), int(r), int(inc), EXPECTED_MAPPING)
              for i, r, inc in zip(cs["node_ids"], cs["rated_torque_mNm"],
                                   cs["increments_per_revolution"], strict=True)]
    kt = [float(v) for v in model.kt]
    pm = np.array([[torque_per_mille(float(row[j]), kt[j], d.rated_torque_mNm)
                    for j, d in enumerate(drives)] for row in u], dtype=np.int64)
    run = BenchRun(t=t, q=c.group("q"), qd=c.group("qd"), u=u, plant_summary=ps,
                   controller_summary={**cs, "transport": interface, "master": "c"},
                   u_n=c.group("u_n"), u_c=c.group("u_c"), wall_time=time.perf_counter() - start)
    return MasterRun(run, pm, drives, ps, realtime)
