"""The CAN bench over each transport, one suite in python-can's back2back_test.py shape: the
same cases and the same checks, run once over SocketCAN (vcan0, and vcan1 for CAN FD) in the
session's QEMU guest (can_guest.py, the one harness) and once over the C socketcand server on
this machine (TCP on loopback): the ``transport`` and ``guest`` fixtures of can/conftest.py.

- Over each transport (tests that take ``transport``): both C nodes in lockstep on the first
  BENCH_PERIODS periods of the writing task (they equal the FMPy loop with the DBC's
  quantisation, and differ from the unquantised writing task by that quantisation only);
  ``rrr hil bench``; the Python sides (``rrr hil controller|plant``: an FMU under FMPy against
  the C node); the CANopen masters (``rrr hil canopen``, the Python and the C one) against the
  C plant's three CiA 402 drives; both C nodes in real time.
- The transports agree (``..._socketcan_equals_socketcand``): the same runs over SocketCAN give
  the socketcand runs' logs bit for bit and their summaries but for the transport's own fields.
- Over SocketCAN only: what socketcand cannot carry or show: candump's record of the bus
  (can-utils), CAN FD on vcan1, frames from a third node on the bus (cansend, cangen, a Python
  injector) while the nodes run, classical frames on the CAN FD bus, ``--fd`` refused on a
  classical interface, NMT and heartbeat loss driven by cansend.

In the guest the C cases run as shell scripts and the Python cases in ONE Python process
(guest_python_sides.py: Python starts slowly under emulation); each prints the time it took in
the guest (pytest -s shows it). The socketcand runs are made here while the guest runs (the
emulator takes one CPU), and once for both the cases over socketcand and the comparisons.
"""

from __future__ import annotations

import json
import math
import shlex
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

import can
import cantools
import numpy as np
import pytest
from can_guest import CanGuest, Result
from guest_python_sides import CANOPEN_MASTERS
from rrr_robot.core.param_names import model_fmu_values
from rrr_robot.hil.dbc.bench import quantised_cosim
from rrr_robot.hil.dbc.protocol import DBC_PATH, EXIT_SAFETY, FAULT_BITS
from rrr_robot.hil.figures import FIGURES
from rrr_robot.hil.logs import frames as framelog
from rrr_robot.hil.logs.specs import CONTROLLER_LOG, PLANT_LOG, read_log
from rrr_robot.hil.nodes import (
    controller_node_args,
    export_reference,
    node_executable,
    start_controller,
    start_plant,
)
from rrr_robot.hil.results import BenchRun
from rrr_robot.sim.cosim import CosimOptions, CosimResult, run_cosim
from rrr_robot.sim.fmus import fmu_path
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

#: Summary fields that name or count the transport itself (socketcan has no connection).
TRANSPORT_FIELDS = {"transport", "connects", "disconnects"}
#: Identifiers the guest scripts put on the bus around a run (never used by the bench): a probe
#: that tells when candump is reading, and the end marker after which its log is complete.
PROBE_ID, END_ID = 0x7FE, 0x7FF

T = TypeVar("T")


class Background(Generic[T]):
    """A run made at most once, in a thread of its own: started where a guest job begins (so
    that it runs meanwhile), awaited where it is needed."""

    def __init__(self, fn: Callable[[], T]) -> None:
        self._fn = fn
        self._future: Future[T] | None = None

    def start(self) -> Background[T]:
        if self._future is None:
            pool = ThreadPoolExecutor(max_workers=1)
            self._future = pool.submit(self._fn)
            pool.shutdown(wait=False)
        return self

    def result(self) -> T:
        future = self.start()._future
        assert future is not None
        return future.result()


def run(guest: CanGuest, command: str, what: str, timeout: float = 120.0) -> Result:
    r = guest.run(command, timeout=timeout)
    print(f"{what}: exit {r.rc}, {r.seconds:.1f} s ({r.guest_seconds:.1f} s in the guest)")
    return r


def summary_lines(text: str) -> dict[str, Any]:
    lines = [ln for ln in text.splitlines() if ln.startswith("RRR_HIL_SUMMARY ")]
    assert len(lines) == 1, text
    return dict(json.loads(lines[0][len("RRR_HIL_SUMMARY "):]))


def rt_line(text: str) -> dict[str, Any]:
    """A node's real-time statistics (its one RRR_HIL_RT line)."""
    rt = [ln for ln in text.splitlines() if ln.startswith("RRR_HIL_RT ")]
    assert len(rt) == 1, text[-2000:]
    return dict(json.loads(rt[0][len("RRR_HIL_RT "):]))


# ---- the inputs and the runs of both C nodes -------------------------------------------------


@dataclass(frozen=True)
class Writing:
    """The writing task's scenario ctc: its model, robot, scenario, reference and the controller
    FMU's values of the scenario."""

    model: Any
    robot: Any
    scenario: Any
    ref: Any
    values: dict[str, Any]


#: Periods of the all-C lockstep runs (3 s of the 5909 of the writing task): the largest
#: tracking error, |dq| and |du| against the unquantised task and the tip error's difference of
#: the whole task all fall in them (measured: equal to the whole task's), and over SocketCAN
#: each run's length is emulated work (the C bench, its CAN FD run: about 2 ms a period).
BENCH_PERIODS = 3000


@pytest.fixture(scope="module")
def writing() -> Writing:
    """The writing task (ctc) cut to its first BENCH_PERIODS periods."""
    from rrr_robot.hil.nodes import PERIOD
    from rrr_robot.hil.results import extend_reference

    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), scenarios=["ctc"]))
    assert ref.t.shape[0] > BENCH_PERIODS
    ref = extend_reference(ref, (BENCH_PERIODS - 1) * PERIOD)
    assert ref.t.shape[0] == BENCH_PERIODS
    values = controller_fmu_values(scenarios[0], model, robot.require_control())
    return Writing(model, robot, scenarios[0], ref, values)


def bench_inputs_in(work: Path, w: Writing) -> dict[str, Any]:
    """The writing task's reference (ctc), the controller node's options and the unzipped
    plant FMU, in ``work``."""
    work.mkdir(parents=True)
    fmu = work / "plant_fmu"
    with zipfile.ZipFile(fmu_path("plant")) as z:
        z.extractall(fmu)
    ref = w.ref
    ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv")
    vec = ",".join
    plant_args = ["--fmu", str(fmu), "--q0", vec(f"{x:.17g}" for x in ref.q[0]),
                  "--qd0", vec(f"{x:.17g}" for x in ref.qd[0])]
    return {"ref": ref, "ref_csv": ref_csv, "plant_args": plant_args,
            "ctrl_args": controller_node_args(w.values), "fmu": fmu, "work": work,
            "periods": ref.t.shape[0]}


@pytest.fixture(scope="module")
def bench_inputs(guest: CanGuest, writing: Writing) -> dict[str, Any]:
    """The inputs of the runs in the guest, in its scratch folder (its /tmp is its own)."""
    return bench_inputs_in(guest.scratch / "bench", writing)


@pytest.fixture(scope="module")
def host_inputs(tmp_path_factory: pytest.TempPathFactory, writing: Writing) -> dict[str, Any]:
    """The same inputs for the runs here over socketcand."""
    return bench_inputs_in(tmp_path_factory.mktemp("socketcand") / "bench", writing)


@dataclass(frozen=True)
class NodesRun:
    """A run of both C nodes: the folder of their logs (plant.csv, controller.csv, and their
    frame logs plant.rrrcan, controller.rrrcan), their RRR_HIL_SUMMARY lines, exit statuses,
    stdout and stderr; ``rc`` and ``detail``: the guest job's exit status and what to show when
    it failed (0 and "" here)."""

    transport: str
    work: Path
    summary: dict[str, dict[str, Any]]
    exits: dict[str, int]
    stdout: dict[str, str]
    stderr: dict[str, str]
    rc: int = 0
    detail: str = ""


def host_nodes(inputs: dict[str, Any], work: Path, *, plant_extra: tuple[str, ...] = (),
               ctrl_extra: tuple[str, ...] = (), ref_csv: Path | None = None) -> NodesRun:
    """Both C nodes on this machine over socketcand (plant = server), the options of the
    guest's runs."""
    work.mkdir()
    ref = inputs["ref"]
    plant = start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=work / "plant.csv",
                        frame_log=work / "plant.rrrcan", extra=plant_extra)
    with plant, start_controller(ref_csv or inputs["ref_csv"],
                                 connect=f"127.0.0.1:{plant.port}",
                                 log_csv=work / "controller.csv",
                                 frame_log=work / "controller.rrrcan",
                                 extra=[*inputs["ctrl_args"], *ctrl_extra]) as ctrl:
        cs = ctrl.wait(300)
        ps = plant.wait(60)
    return NodesRun("socketcand", work, {"plant": ps, "controller": cs},
                    {"plant": ps["exit"], "controller": cs["exit"]},
                    {"plant": plant.stdout, "controller": ctrl.stdout},
                    {"plant": plant.stderr, "controller": ctrl.stderr})


def guest_nodes(work: Path, r: Result) -> NodesRun:
    """The files a guest script of c_bench_script wrote (candump's exit status among the
    exits)."""

    def text(name: str) -> str:
        return (work / name).read_text() if (work / name).exists() else ""

    exits = {k: int(v) for k, v in (line.split() for line in text("exit").splitlines())}
    out = {node: text(f"{node}.out") for node in ("plant", "controller")}
    summary = {node: summary_lines(o) if "RRR_HIL_SUMMARY " in o else {}
               for node, o in out.items()}
    return NodesRun("socketcan", work, summary, exits, out,
                    {node: text(f"{node}.err") for node in ("plant", "controller")},
                    r.rc, r.stderr[-3000:] + text("plant.err")[-3000:])


def bench_run(nodes: NodesRun) -> BenchRun:
    """t, q, qd (the plant's log) and u (the controller's) of a run, as run_c_bench reads
    them."""
    p = read_log(nodes.work / "plant.csv", PLANT_LOG)
    c = read_log(nodes.work / "controller.csv", CONTROLLER_LOG)
    m = min(p.rows.shape[0], c.rows.shape[0])
    return BenchRun(t=p.col("t")[:m], q=p.group("q")[:m], qd=p.group("qd")[:m],
                    u=c.group("u")[:m], plant_summary=nodes.summary["plant"],
                    controller_summary=nodes.summary["controller"], u_n=c.group("u_n")[:m],
                    u_c=c.group("u_c")[:m])


#: Shell functions of the guest scripts: candump recording a bus into $L (started first; a probe
#: frame tells when it reads), waiting for a line in it, and stopping it: after the run an end
#: marker tells that candump has written every frame before it, then SIGINT (it flushes its
#: output and exits 0) and a wait for it.
RECORDER = f"""
set -u
L=/tmp/candump.log
wait_for() {{
  n=0; until grep -q "$1" "$2"; do n=$((n+1)); [ $n -gt 600 ] && return 1; sleep 0.05; done
}}
record_start() {{
  stdbuf -oL candump -L -d -r 16777216 "$1" > $L 2> /tmp/candump.err &
  CD=$!
  n=0; until grep -q ' {PROBE_ID:03X}#' $L; do cansend "$1" {PROBE_ID:03X}#01; sleep 0.1;
    n=$((n+1)); [ $n -gt 100 ] && {{ echo "candump does not record" >&2; exit 90; }}; done
}}
record_stop() {{  # BUS DEST_FOLDER
  cansend "$1" {END_ID:03X}#454E44
  wait_for ' {END_ID:03X}#454E44' $L || {{ echo "candump missed the end marker" >&2; exit 92; }}
  kill -INT $CD; wait $CD; echo "candump $?" >> "$2/exit"
  cp $L "$2/candump.log"; cp /tmp/candump.err "$2/candump.err"
  sync
}}
"""


def c_bench_script(work: Path, plant_args: list[str], ctrl_args: list[str], ref_csv: Path,
                   channel: str = "vcan0", inject: str = "", fd: bool = False) -> str:
    """Both C nodes over SocketCAN with candump recording the bus: candump first, the plant next
    (its boot-up heartbeat on the bus tells that it listens), then the controller. ``inject``:
    shell commands run while the nodes run, once the plant's log has 200 rows. ``fd``: both
    nodes with --fd (CAN FD frames; candump -L writes them as ID##FLAGS DATA)."""
    q = shlex.quote
    link = ["--socketcan", channel, *(["--fd"] if fd else [])]
    plant = shlex.join([str(node_executable("plant")), *plant_args, *link,
                        "--log", str(work / "plant.csv"), "--frame-log",
                        str(work / "plant.rrrcan")])
    ctrl = shlex.join([str(node_executable("controller")), "--reference", str(ref_csv),
                       *ctrl_args, *link, "--log", str(work / "controller.csv"),
                       "--frame-log", str(work / "controller.rrrcan")])
    boot_up = " 702##[0-9A-F]00" if fd else " 702#00"
    w = q(str(work))
    injection = "" if not inject else (
        f'( n=0; until [ "$(wc -l < {w}/plant.csv)" -gt 200 ] || [ $n -gt 1200 ]; do sleep 0.05;'
        f' n=$((n+1)); done; {inject}; echo done > {w}/injected ) &\nINJ=$!')
    return RECORDER + f"""
record_start {channel}
{plant} > {w}/plant.out 2> {w}/plant.err &
P=$!
wait_for '{boot_up}' $L || {{ echo "no boot-up heartbeat of the plant" >&2; exit 91; }}
T0=$(cut -d' ' -f1 /proc/uptime)
{injection}
{ctrl} > {w}/controller.out 2> {w}/controller.err
echo "controller $?" > {w}/exit
wait $P
echo "plant $?" >> {w}/exit
{"wait $INJ" if inject else ""}
T1=$(cut -d' ' -f1 /proc/uptime)
echo "nodes $T0 $T1" > {w}/times
record_stop {channel} {w}
"""


def read_csv(path: Path) -> list[str]:
    lines = path.read_text().splitlines()
    assert len(lines) > 1, path
    return lines


def log_metrics(controller_csv: Path, ref: Any) -> dict[str, float]:
    """The summary metrics of a run from the controller's log: RMS tracking error and RMS
    voltages per joint, the largest |u|."""
    log = read_log(controller_csv, CONTROLLER_LOG)
    c = log.rows
    n = min(c.shape[0], ref.q.shape[0])
    out = {}
    for j in range(3):
        q = log.col(f"q[{j + 1}]")
        out[f"rms_e[{j + 1}]"] = float(np.sqrt(np.mean((q[:n] - ref.q[:n, j]) ** 2)))
        for name in ("u", "u_n", "u_c"):
            v = log.col(f"{name}[{j + 1}]")
            out[f"rms_{name}[{j + 1}]"] = float(np.sqrt(np.mean(v[:n] ** 2)))
    out["max_abs_u"] = float(np.abs(c[:n, [8, 11, 14]]).max())
    return out


def candump_messages(path: Path) -> list[can.Message]:
    """The frames of a candump -L log through python-can's reader, the harness's probe and end
    marker left out."""
    msgs = list(can.LogReader(str(path)))
    return [m for m in msgs if m.arbitration_id not in (PROBE_ID, END_ID)]


# ---- both C nodes in lockstep, the first BENCH_PERIODS periods of the writing task ---------


@pytest.fixture(scope="module")
def socketcand_c_bench(host_inputs: dict[str, Any]) -> Background[NodesRun]:
    """Both C nodes over socketcand here, BENCH_PERIODS periods of the writing task."""
    return Background(lambda: host_nodes(host_inputs, host_inputs["work"].parent / "c_bench"))


@pytest.fixture(scope="module")
def vcan_bench(guest: CanGuest, bench_inputs: dict[str, Any],
               socketcand_c_bench: Background[NodesRun]) -> dict[str, Any]:
    """Both C nodes over vcan0 in the guest with candump recording the bus, BENCH_PERIODS
    periods of the writing task (the socketcand run is made here meanwhile)."""
    work = bench_inputs["work"] / "vcan"
    work.mkdir()
    script = work / "bench.sh"
    script.write_text(c_bench_script(work, bench_inputs["plant_args"], bench_inputs["ctrl_args"],
                                     bench_inputs["ref_csv"]))
    socketcand_c_bench.start()
    r = run(guest, f"sh {shlex.quote(str(script))}", "C bench over vcan0 (with candump)",
            timeout=240)
    times = (work / "times").read_text().split() if (work / "times").exists() else []
    if times:
        print(f"  the two nodes: {float(times[2]) - float(times[1]):.1f} s in the guest for "
              f"{bench_inputs['periods']} periods")
    return {"result": r, "work": work, "nodes": guest_nodes(work, r)}


@pytest.fixture
def c_bench(transport: str, request: pytest.FixtureRequest) -> NodesRun:
    """Both C nodes in lockstep over ``transport``, BENCH_PERIODS periods of the writing
    task."""
    if transport == "socketcan":
        nodes: NodesRun = request.getfixturevalue("vcan_bench")["nodes"]
        return nodes
    return request.getfixturevalue("socketcand_c_bench").result()


@pytest.fixture(scope="module")
def quantised(writing: Writing) -> BenchRun:
    """The FMPy loop with the DBC's quantisation (the bench's arithmetic), BENCH_PERIODS
    periods."""
    ref = writing.ref
    return quantised_cosim(ref.t, ref.q, ref.qd, ref.qdd, controller_values=writing.values)


@pytest.fixture(scope="module")
def unquantised(writing: Writing) -> CosimResult:
    """The writing task's FMPy co-simulation (BENCH_PERIODS periods), without the bench's
    quantisation."""
    model, robot, scn, ref = writing.model, writing.robot, writing.scenario, writing.ref
    opts = CosimOptions(step=robot.sample_time, plant_values=model_fmu_values(model),
                        controller_values=controller_fmu_values(scn, model, robot.control))
    return run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)


def test_c_bench_completes(c_bench: NodesRun, writing: Writing, transport: str) -> None:
    """rrr_hil_plant and rrr_hil_controller in lockstep over the transport (--socketcan vcan0 in
    the guest, --listen/--connect here), BENCH_PERIODS periods of the writing task: both exit 0
    with their "completed" lines; each log has a row per period; the plant's summary counts n - 1
    periods and no fault, the controller's n states; both summaries name the transport; the
    run's metrics are finite."""
    assert c_bench.rc == 0, c_bench.detail
    assert {k: c_bench.exits[k] for k in ("plant", "controller")} == {"plant": 0,
                                                                      "controller": 0}
    assert "rrr_hil_plant: exit 0 (completed)" in c_bench.stderr["plant"]
    assert "rrr_hil_controller: exit 0 (completed)" in c_bench.stderr["controller"]
    n = writing.ref.t.shape[0]
    for name in ("plant.csv", "controller.csv"):
        assert len(read_csv(c_bench.work / name)) >= n, name
    ps, cs = c_bench.summary["plant"], c_bench.summary["controller"]
    assert ps["transport"] == cs["transport"] == transport
    assert ps["exit"] == cs["exit"] == 0
    assert ps["periods"] == n - 1 and cs["states"] == n
    assert ps["faults"] == 0 and ps["fault_events"] == 0
    metrics = log_metrics(c_bench.work / "controller.csv", writing.ref)
    assert all(math.isfinite(v) for v in metrics.values())


def test_c_bench_equals_quantised_fmpy_loop(c_bench: NodesRun, writing: Writing,
                                            quantised: BenchRun) -> None:
    """Both C nodes in lockstep reproduce the FMPy loop with the DBC's quantisation (q to 1e-6
    rad and qd to 1e-4 rad/s in JointState, u to 1 mV in VoltageCmd) to < 1e-9 rad: the same
    plant FMU binary, the same rrr_ctc, the same rounding (measured: bit for bit)."""
    run = bench_run(c_bench)
    assert run.q.shape == writing.ref.q.shape
    assert np.abs(run.q - quantised.q).max() < 1e-9
    assert np.abs(run.qd - quantised.qd).max() < 1e-9
    assert np.abs(run.u - quantised.u).max() < 1e-9


def test_c_bench_vs_writing_task_differs_by_quantisation_only(
        c_bench: NodesRun, writing: Writing, unquantised: CosimResult) -> None:
    """Against the unquantised FMPy run (rrr_robot.writing's ctc) the only difference is the
    DBC's quantisation: |dq| stays below 1e-5 rad (measured 3.0e-6 rad, |du| 4.0e-4 V), which is
    small against the tracking error itself (1.8e-4 rad), and the tip error metric agrees to
    5 %."""
    model, ref, r = writing.model, writing.ref, unquantised
    run = bench_run(c_bench)
    dq = np.abs(run.q - r.q).max()
    du = np.abs(run.u - r.u).max()
    tracking = np.abs(r.q - ref.q).max()
    print(f"bench vs FMPy writing task: max |dq| {dq:.3e} rad, max |du| {du:.3e} V, "
          f"tracking error {tracking:.3e} rad")
    assert dq < 1e-5
    # voltage quantisation 0.5 mV plus Kp * 0.5 urad + Kd * 0.5e-4 rad/s (max Kd 4 V s/rad)
    assert du < 2e-3
    assert dq < 0.05 * tracking
    tip = model.fk(run.q)[0]
    e_bench = np.linalg.norm(tip - ref.x, axis=1).max()
    e_fmpy = np.linalg.norm(r.tip - ref.x, axis=1).max()
    assert e_bench == pytest.approx(e_fmpy, rel=0.05)


def test_c_bench_socketcan_equals_socketcand(vcan_bench: dict[str, Any],
                                             socketcand_c_bench: Background[NodesRun],
                                             bench_inputs: dict[str, Any]) -> None:
    """The run over vcan0 and the run over socketcand: their logs equal bit for bit, their
    summaries too (but for the transport's name and connection counts, and the plant's boot-up
    heartbeat, on the bus over SocketCAN and dropped by a socketcand server that has no client
    yet), and so do the metrics of the run."""
    mine, host = vcan_bench["nodes"], socketcand_c_bench.result()
    work, host_work = mine.work, host.work
    n = bench_inputs["periods"]
    for name in ("plant.csv", "controller.csv"):
        a, b = read_csv(work / name), read_csv(host_work / name)
        assert len(a) == len(b) >= n, name
        assert a == b, f"{name}: differs from the socketcand run"
    for node in ("plant", "controller"):
        guest_sum = dict(mine.summary[node])
        host_sum = dict(host.summary[node])
        assert guest_sum["transport"] == "socketcan" and host_sum["transport"] == "socketcand"
        assert guest_sum["exit"] == host_sum["exit"] == 0
        if node == "plant":  # its boot-up heartbeat: on the bus here, dropped by a
            # socketcand server that has no client yet (docs/dbc.md, Heartbeats)
            assert (host_sum["tx_dropped"], guest_sum["tx_dropped"]) == (1, 0)
            for k in ("tx_frames", "frames_logged", "tx_dropped"):
                host_sum[k] += 1 if k != "tx_dropped" else -1
        diff = {k: (host_sum.get(k), v) for k, v in guest_sum.items()
                if k not in TRANSPORT_FIELDS and host_sum.get(k) != v}
        assert not diff, f"{node} summary differs from the socketcand run: {diff}"
        assert set(guest_sum) == set(host_sum)
    assert mine.summary["plant"]["periods"] == n - 1
    ref = bench_inputs["ref"]
    a_m, b_m = log_metrics(work / "controller.csv", ref), log_metrics(host_work / "controller.csv",
                                                                       ref)
    assert a_m == b_m and all(math.isfinite(v) for v in a_m.values())


# ---- over SocketCAN only: candump, CAN FD, traffic from other nodes ------------------------

#: The controller's frames (Sync, StopCmd, VoltageCmd, HeartbeatCtrl); the rest are the plant's.
CONTROLLER_IDS = {0x080, 0x090, 0x100, 0x701}


def test_candump_log_equals_node_frame_logs(vcan_bench: dict[str, Any],
                                            bench_inputs: dict[str, Any]) -> None:
    """candump -L (can-utils) recorded the run with no frame dropped; python-can reads its log
    and cantools decodes every frame with the bench's DBC. Frame for frame (identifier, data,
    order), each node's frames on the bus are its frame log's Tx records and the other node's
    Rx records, but for the documented ends: the plant's boot-up heartbeat precedes the
    controller, the plant may end before the controller's last heartbeat reaches it, and the
    controller stops reading after the last joint state (docs/can-bench.md, Frame logs)."""
    work = vcan_bench["work"]
    assert vcan_bench["nodes"].exits["candump"] == 0
    assert "" == (work / "candump.err").read_text().strip()  # -d: it reports drops there
    bus = candump_messages(work / "candump.log")
    db = cantools.database.load_file(str(DBC_PATH))
    names = [db.get_message_by_frame_id(m.arbitration_id).name for m in bus]
    decoded = [db.decode_message(m.arbitration_id, m.data, decode_choices=False) for m in bus]
    assert names[0] == "HeartbeatPlant" and decoded[0]["NmtState"] == 0  # boot-up
    assert names.count("VoltageCmd") == names.count("JointState1") == names.count("Sync") + 1
    assert names.count("VoltageCmd") == bench_inputs["periods"]  # one per joint state
    stop = decoded[names.index("StopCmd")]
    last_hb = len(names) - 1 - names[::-1].index("HeartbeatCtrl")
    assert stop["Reason"] == 0 and decoded[last_hb]["NmtState"] == 4  # "stopped", after it
    assert last_hb > names.index("StopCmd")
    seen = [(m.arbitration_id, bytes(m.data), m.is_extended_id) for m in bus]
    from_ctrl = [f for f in seen if f[0] in CONTROLLER_IDS]
    from_plant = [f for f in seen if f[0] not in CONTROLLER_IDS]
    plant = framelog.read_node_log(work / "plant.rrrcan")
    ctrl = framelog.read_node_log(work / "controller.rrrcan")
    assert framelog.frames(ctrl, 1) == from_ctrl
    assert framelog.frames(plant, 1) == from_plant
    plant_rx, ctrl_rx = framelog.frames(plant, 0), framelog.frames(ctrl, 0)
    assert plant_rx in (from_ctrl, from_ctrl[:-1])
    assert ctrl_rx in (from_plant[1:], from_plant[1:-1])
    print(f"  candump: {len(bus)} frames, {len(from_ctrl)} of the controller, {len(from_plant)} "
          f"of the plant; equal to the nodes' frame logs")


# ---- the same bench as CAN FD frames on vcan1 (SocketCAN only) ----------------------------

#: The data bit rate of the CAN FD figures (1 Mbit/s nominal): rrr hil busload --fd's argument.
FD_DATA_BITRATE = 5_000_000


@pytest.fixture(scope="module")
def c_bench_fd(guest: CanGuest, bench_inputs: dict[str, Any],
               vcan_bench: dict[str, Any]) -> dict[str, Any]:
    """The all-C lockstep bench of vcan_bench again, both nodes with --fd on vcan1 (MTU 72)."""
    work = bench_inputs["work"] / "vcan_fd"
    work.mkdir()
    script = work / "bench.sh"
    script.write_text(c_bench_script(work, bench_inputs["plant_args"], bench_inputs["ctrl_args"],
                                     bench_inputs["ref_csv"], channel="vcan1", fd=True))
    r = run(guest, f"sh {shlex.quote(str(script))}", "C bench over vcan1, CAN FD (with candump)",
            timeout=240)
    return {"result": r, "work": work}


def test_c_bench_fd_over_vcan1_equals_classical(c_bench_fd: dict[str, Any],
                                                vcan_bench: dict[str, Any],
                                                bench_inputs: dict[str, Any]) -> None:
    """rrr_hil_plant and rrr_hil_controller with --socketcan vcan1 --fd: both exit 0; the
    payloads are the classical frames' (same DBC, same quantisation), so the run is the
    classical run over vcan0 bit for bit: equal logs, equal metrics, equal summaries but for
    the transport's name (socketcan-fd); no frame was malformed or of the wrong format."""
    r, work, classical = c_bench_fd["result"], c_bench_fd["work"], vcan_bench["work"]
    assert r.rc == 0, r.stderr + (work / "plant.err").read_text()
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    assert exits == {"controller": "0", "plant": "0", "candump": "0"}, exits
    assert "rrr_hil_plant: exit 0 (completed)" in (work / "plant.err").read_text()
    for name in ("plant.csv", "controller.csv"):
        mine, theirs = read_csv(work / name), read_csv(classical / name)
        assert len(mine) >= bench_inputs["periods"] and mine == theirs, name
    ref = bench_inputs["ref"]
    mine_m = log_metrics(work / "controller.csv", ref)
    assert mine_m == log_metrics(classical / "controller.csv", ref)
    for node in ("plant", "controller"):
        fd_sum = summary_lines((work / f"{node}.out").read_text())
        cl_sum = summary_lines((classical / f"{node}.out").read_text())
        assert (fd_sum["transport"], cl_sum["transport"]) == ("socketcan-fd", "socketcan")
        assert fd_sum["rx_malformed"] == 0 and fd_sum["exit"] == 0
        diff = {k: (cl_sum.get(k), v) for k, v in fd_sum.items()
                if k != "transport" and cl_sum.get(k) != v}
        assert not diff, f"{node}: the CAN FD run's summary differs: {diff}"
    print(f"  CAN FD over vcan1: rms_e {[mine_m[f'rms_e[{j}]'] for j in (1, 2, 3)]} rad, "
          "equal to the classical run bit for bit")


def test_c_bench_fd_frames_and_busload(c_bench_fd: dict[str, Any], vcan_bench: dict[str, Any],
                                       bench_inputs: dict[str, Any]) -> None:
    """candump -L on vcan1 recorded the CAN FD run with no drop; python-can reads every bench
    frame as CAN FD with bit-rate switch, and each node's frames are the classical run's (id,
    data, order). Counted per period, the frames and data bytes on the bus agree with rrr hil
    busload --lockstep --fd's schedule (the DBC's periods and lengths), computed independently,
    up to the run's documented ends: the plant's boot-up heartbeat, the StopCmd, the
    controller's "stopped" heartbeat, one joint state and one command more than Syncs, and the
    heartbeat of period 0 (at most 7 frames and 8 bytes per frame of them). The measured load
    is printed beside busload's figure."""
    from rrr_robot.cli.app import main as rrr
    from rrr_robot.hil.busload import measured_fd_load, schedule_load
    from rrr_robot.hil.dbc.protocol import database

    work = c_bench_fd["work"]
    assert "" == (work / "candump.err").read_text().strip()
    bus = candump_messages(work / "candump.log")
    assert bus and all(m.is_fd and m.bitrate_switch for m in bus)
    classical = candump_messages(vcan_bench["work"] / "candump.log")
    assert not any(m.is_fd for m in classical)

    def split(msgs: list[can.Message]) -> tuple[list[Any], list[Any]]:
        seen = [(m.arbitration_id, bytes(m.data)) for m in msgs]
        return ([f for f in seen if f[0] in CONTROLLER_IDS],
                [f for f in seen if f[0] not in CONTROLLER_IDS])

    assert split(bus) == split(classical)
    n = bench_inputs["periods"]
    frames = [(m.arbitration_id, bytes(m.data), m.is_extended_id) for m in bus]
    measured = measured_fd_load(frames, n, data_bitrate=FD_DATA_BITRATE)
    schedule = schedule_load(database(), data_bitrate=FD_DATA_BITRATE, lockstep=True)
    sched_frames = sum(f.rate_hz for f in schedule.frames) * 1e-3
    sched_bytes = sum(f.rate_hz * f.length for f in schedule.frames) * 1e-3
    assert abs(measured["frames_per_period"] - sched_frames) * n <= 7
    assert abs(measured["bytes_per_period"] - sched_bytes) * n <= 7 * 8
    assert abs(measured["load_worst_percent"] - schedule.worst_percent) < 0.01 * \
        schedule.worst_percent
    assert rrr(["hil", "busload", "--lockstep", "--fd", str(FD_DATA_BITRATE)]) == 0
    print(f"  CAN FD on vcan1 (candump), {n} periods: {measured['frames_per_period']:.4f} "
          f"frames and {measured['bytes_per_period']:.3f} bytes per period, "
          f"{measured['load_worst_percent']:.2f} % worst case / "
          f"{measured['load_no_stuffing_percent']:.2f} % without stuff bits of 1 Mbit/s + "
          f"{FD_DATA_BITRATE // 1_000_000} Mbit/s; rrr hil busload --lockstep --fd "
          f"{FD_DATA_BITRATE}: {sched_frames:.4f} frames, {sched_bytes:.3f} bytes per period, "
          f"{schedule.worst_percent:.2f} % worst case, {schedule.nominal_percent:.2f} % without")


# ---- hostile traffic from can-utils while the plant runs (SocketCAN only), and real time ---

#: Periods of the hostile runs (the first rows of the writing task).
HOSTILE_PERIODS = 1000
#: name: (what cansend/cangen put on the bus, fault bit it latches (0: none), what it shows)
HOSTILE = {
    "bad_crc": ("cansend vcan0 100#0000000000000000", 2, "VoltageCmd with a wrong CRC"),
    "wrong_dlc": ("cansend vcan0 100#1111", 16, "VoltageCmd with DLC 2"),
    "replayed": ("cansend vcan0 @REPLAY@", 4, "a valid VoltageCmd of an earlier period again"),
    "other_ids": ("cangen vcan0 -g 0 -I 555 -L 8 -n 3000; cangen vcan0 -g 0 -e -n 500; "
                  "cangen vcan0 -g 0 -I 7FD -L 8 -n 500", 0,
                  "a flood of unknown identifiers (standard and extended) at the bus's rate"),
}


#: What the classical_on_fd run injects into a CAN FD bench: classical frames of VoltageCmd.
CLASSICAL_ON_FD = "cansend vcan1 100#0000000000000000; cansend vcan1 100#1111"


@pytest.fixture(scope="module")
def hostile(guest: CanGuest, bench_inputs: dict[str, Any], vcan_bench: dict[str, Any],
            socketcand_realtime: Background[NodesRun]) -> dict[str, Any]:
    """One guest job: the C bench over vcan0 on the first HOSTILE_PERIODS periods, once per
    case of HOSTILE, with its traffic injected mid-run; the same on the CAN FD bus with
    classical frames; and both nodes in real time on a clean bus (the socketcand run in real
    time is made here meanwhile)."""
    work = bench_inputs["work"] / "hostile"
    work.mkdir()
    ref_csv = first_periods_reference(bench_inputs, work)
    # a valid VoltageCmd of the clean run (period 100): CRC and counter right, but old
    replay = next(m for m in candump_messages(vcan_bench["work"] / "candump.log")
                  if m.arbitration_id == 0x100 and (m.data[1] & 15) == 100 % 16)
    replay_arg = f"100#{bytes(replay.data).hex().upper()}"
    scripts = []
    for name, (inject, _, _) in HOSTILE.items():
        (work / name).mkdir()
        one = c_bench_script(work / name, bench_inputs["plant_args"], bench_inputs["ctrl_args"],
                             ref_csv, inject=inject.replace("@REPLAY@", replay_arg))
        scripts.append(f"( {one} )")
    # classical frames on the CAN FD bench (vcan1, --fd): a VoltageCmd of a wrong CRC and one of
    # DLC 2, which would latch crc and format on a classical bench
    (work / "classical_on_fd").mkdir()
    scripts.append("( " + c_bench_script(
        work / "classical_on_fd", bench_inputs["plant_args"], bench_inputs["ctrl_args"], ref_csv,
        channel="vcan1", fd=True, inject=CLASSICAL_ON_FD) + " )")
    # and the real-time mode of both nodes on the same periods, on a clean bus
    (work / "realtime").mkdir()
    scripts.append("( " + c_bench_script(
        work / "realtime", [*bench_inputs["plant_args"], *REALTIME_PLANT],
        [*bench_inputs["ctrl_args"], *REALTIME_CONTROLLER], ref_csv) + " )")
    script = work / "hostile.sh"
    script.write_text("\n".join(scripts) + "\n")
    socketcand_realtime.start()
    r = run(guest, f"sh {shlex.quote(str(script))}",
            f"{len(HOSTILE)} hostile runs and one in real time of {HOSTILE_PERIODS} periods",
            timeout=400)
    return {"result": r, "work": work}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_hostile_traffic(hostile: dict[str, Any], vcan_bench: dict[str, Any], case: str) -> None:
    """Frames from cansend/cangen on the bus while the plant runs: a bad CRC, a wrong DLC, a
    replayed command each latch their fault (crc, format, counter) at once and the plant applies
    0 V from then to the end (log column zero = 1, u = 0, PlantStatus reports it), the run goes
    on to its end (lockstep) and both nodes end with EXIT_SAFETY (7: completed, but the safety
    policy fired; the controller read it in PlantStatus). Frames of other identifiers never
    reach the nodes (their kernel receive filters): the run equals the clean run bit for bit,
    costs no counter at all and ends with 0."""
    work = hostile["work"] / case
    assert hostile["result"].rc == 0, hostile["result"].stderr
    assert (work / "injected").exists(), "the injection did not run during the run"
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    _, bit, _ = HOSTILE[case]
    status = str(EXIT_SAFETY if bit else 0)
    assert exits == {"controller": status, "plant": status, "candump": "0"}, exits
    s = summary_lines((work / "plant.out").read_text())
    c = summary_lines((work / "controller.out").read_text())
    plant = read_log(work / "plant.csv", PLANT_LOG)
    log = plant.rows
    assert log.shape[0] == HOSTILE_PERIODS
    if bit == 0:
        clean = read_csv(vcan_bench["work"] / "plant.csv")[: HOSTILE_PERIODS]
        assert read_csv(work / "plant.csv")[: HOSTILE_PERIODS] == clean
        assert s["faults"] == 0 and s["fault_events"] == 0 and s["rx_unknown_id"] == 0
        assert s["rx_frames"] == c["tx_frames"] or s["rx_frames"] == c["tx_frames"] - 1
        bus = candump_messages(work / "candump.log")
        assert sum(m.arbitration_id == 0x555 for m in bus) == 3000
        return
    assert s["faults"] & bit and s["fault_events"] >= 1 and s["zero_periods"] > 0
    zero, faults, u = plant.col("zero"), plant.col("faults").astype(int), plant.group("u")
    first = int(np.argmax(faults != 0))
    assert 0 < first and np.all(faults[first:] & bit) and np.all(zero[first + 1:] == 1)
    assert np.all(u[first + 1:] == 0.0) and np.any(u[:first] != 0.0)
    assert c["plant_faults"] & bit  # the controller saw it in PlantStatus
    assert s["exit"] == c["exit"] == EXIT_SAFETY and c["plant_status_faulty"] > 0
    assert "the safety policy fired" in (work / "plant.err").read_text()
    print(f"  {case}: fault {s['faults']:#04x} from period {first}, "
          f"{s['zero_periods']} periods at 0 V, plant exit {exits['plant']}")


def test_classical_frames_on_the_fd_bench(hostile: dict[str, Any],
                                          vcan_bench: dict[str, Any]) -> None:
    """Classical frames on the CAN FD bench (cansend on vcan1 while both nodes run with --fd): a
    VoltageCmd of a wrong CRC and one of DLC 2, each of which latches a fault on a classical
    bench, are not of the bench's format: the plant drops both before the codec and counts them
    (rx_malformed 2), latches nothing, and the run equals the clean classical run bit for bit;
    candump saw them as classical frames among the FD ones."""
    work = hostile["work"] / "classical_on_fd"
    assert (work / "injected").exists(), "the injection did not run during the run"
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    assert exits == {"controller": "0", "plant": "0", "candump": "0"}, exits
    s = summary_lines((work / "plant.out").read_text())
    assert s["transport"] == "socketcan-fd" and s["rx_malformed"] == 2
    assert s["faults"] == 0 and s["fault_events"] == 0
    clean = read_csv(vcan_bench["work"] / "plant.csv")[: HOSTILE_PERIODS]
    assert read_csv(work / "plant.csv")[: HOSTILE_PERIODS] == clean
    cmds = [m for m in candump_messages(work / "candump.log") if m.arbitration_id == 0x100]
    assert [bytes(m.data).hex() for m in cmds if not m.is_fd] == ["0000000000000000", "1111"]
    assert abs(len([m for m in cmds if m.is_fd]) - HOSTILE_PERIODS) <= 1


def test_fd_refused_on_a_classical_interface(guest: CanGuest,
                                             bench_inputs: dict[str, Any]) -> None:
    """--fd on vcan0 (MTU 16): each node refuses before the run (exit 2) and says why."""
    for node, args in (("plant", bench_inputs["plant_args"]),
                       ("controller", ["--reference", str(bench_inputs["ref_csv"])])):
        r = run(guest, shlex.join([str(node_executable(node)), *args, "--socketcan", "vcan0",
                                   "--fd"]), f"{node} --fd on vcan0")
        assert r.rc == 2, (r.rc, r.stderr)
        assert ("socketcan: vcan0 is not a CAN FD interface (MTU 16, CAN FD needs 72: ip link "
                "set vcan0 mtu 72)") in r.stderr


def first_periods_reference(inputs: dict[str, Any], folder: Path) -> Path:
    """The reference of the first HOSTILE_PERIODS periods of the writing task, in ``folder``."""
    ref_lines = read_csv(inputs["ref_csv"])[: HOSTILE_PERIODS + 1]
    ref_csv = folder / "reference.csv"
    ref_csv.write_text("\n".join(ref_lines) + "\n")
    return ref_csv


#: The real-time runs' options: 1 kHz of CLOCK_MONOTONIC (the plant ends after 5 s at most).
REALTIME_PLANT, REALTIME_CONTROLLER = ("--realtime", "--duration", "5"), ("--realtime",)


@pytest.fixture(scope="module")
def socketcand_realtime(host_inputs: dict[str, Any]) -> Background[NodesRun]:
    """Both C nodes in real time over socketcand here, on the periods of the hostile runs."""

    def go() -> NodesRun:
        folder = host_inputs["work"].parent / "realtime_reference"
        folder.mkdir()
        return host_nodes(host_inputs, host_inputs["work"].parent / "realtime",
                          plant_extra=REALTIME_PLANT, ctrl_extra=REALTIME_CONTROLLER,
                          ref_csv=first_periods_reference(host_inputs, folder))

    return Background(go)


@pytest.fixture
def realtime(transport: str, request: pytest.FixtureRequest) -> NodesRun:
    """Both C nodes in real time over ``transport``: over SocketCAN the run of the hostile
    runs' guest job on a clean bus."""
    if transport == "socketcan":
        hostile = request.getfixturevalue("hostile")
        return guest_nodes(hostile["work"] / "realtime", hostile["result"])
    return request.getfixturevalue("socketcand_realtime").result()


def test_realtime(realtime: NodesRun, transport: str) -> None:
    """Both C nodes in real time (--realtime, 1 kHz of CLOCK_MONOTONIC) over the transport for
    HOSTILE_PERIODS periods: the run completes, with status 0, or 7 when the plant's safety
    policy fired (under emulation, or on a busy machine, a node may miss its periods long enough
    for the plant's timeout: the summary then says so). Its wake-up latencies are the machine's
    (under emulation, the emulator's): printed, not asserted."""
    exits = realtime.exits
    s, c = realtime.summary["plant"], realtime.summary["controller"]
    fired = s["fault_events"] > 0 or s["zero_periods"] > 0
    assert exits["plant"] == (EXIT_SAFETY if fired else 0), (exits, s)
    assert exits["controller"] in (0, EXIT_SAFETY), exits
    assert c["states"] > 0 and s["periods"] > 0
    for node in ("plant", "controller"):
        r = rt_line(realtime.stdout[node])
        assert r["rt_periods"] > 0
        print(f"  real time over {transport}, {node}: exit {exits[node]}, {r['rt_periods']} "
              f"periods, wake-up p50 {r['rt_latency_p50_us']:.0f} us, p99 "
              f"{r['rt_latency_p99_us']:.0f} us, max {r['rt_latency_max_us']:.0f} us, "
              f"{r['rt_deadline_misses']} deadline misses")
    print(f"  real time over {transport}: plant faults {s['faults']:#04x}, {s['cmd_missed']} "
          f"periods without a command, {s['zero_periods']} at 0 V; controller: {c['stale']} "
          "stale")


# ---- rrr hil bench, the Python sides and the CANopen masters ------------------------------

#: Seconds of the writing task the Python cases run, 501 periods (their time is mostly Python's
#: start-up and FMPy's under emulation, and each period is emulated work: Python's sides and the
#: CANopen masters step in Python; the bad-CRC case's frame after the Sync of period 200
#: leaves 300 periods at 0 V; BENCH_PERIODS periods run in the all-C case above). No figures are
#: drawn in the guest (matplotlib took about 30 s there): figures_from_files draws them here.
PY_DURATION = "0.5"
#: Values of summary.json that time the run (wall clock), not what it computed.
TIMING = {"wall_time", "realtime_factor", "duration_s", "frames_per_second", "per_second"}


def _untimed(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k not in TIMING}
    return value


def _close(a: Any, b: Any, rtol: float = 1e-9, atol: float = 1e-15) -> bool:
    """Equal structures, numbers within ``rtol`` (relative) or ``atol`` (absolute)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rtol, atol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, rtol, atol)
                                        for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(a, b, rel_tol=rtol, abs_tol=atol)
    return bool(a == b)


#: summary.json keys compared with the host's run, and their (relative, absolute) tolerance:
#: the bench's metrics to 1e-9; the unquantised FMPy co-simulation (computed again by rrr from
#: the reference, numpy inside) and its difference to the bench to 1e-6 and 1e-12 (measured:
#: 1.1e-11, 5.1e-9 and 1.1e-7 relative, the last on differences of about 1e-6).
SUMMARY_TOLERANCE = {"reference": (0.0, 0.0), "bench": (1e-9, 1e-15),
                     "unquantised_cosim": (1e-6, 1e-12),
                     "difference_to_unquantised": (1e-6, 1e-12), "faults": (0.0, 0.0),
                     "missed_commands": (0.0, 0.0), "plant_exit": (0.0, 0.0)}


def figures_from_files(folder: Path, out: Path) -> list[Path]:
    """The figures of an ``rrr hil bench --duration PY_DURATION`` run (scenario ctc) drawn from
    the logs it wrote into ``folder`` (plant.csv, controller.csv), as rrr hil bench draws them
    (rrr_robot.hil.dbc.results.write_results, figures.write_bench_figures); into ``out``."""
    from rrr_robot.hil.figures import write_bench_figures
    from rrr_robot.hil.results import BenchRun, bench_result, extend_reference, unquantised_cosim

    model, robot, scenarios, ref = prepare(WritingJob(out=out, scenarios=["ctc"]))
    values = controller_fmu_values(scenarios[0], model, robot.require_control())
    ref = extend_reference(ref, float(PY_DURATION))
    p = read_log(folder / "plant.csv", PLANT_LOG)
    c = read_log(folder / "controller.csv", CONTROLLER_LOG)
    m = min(p.rows.shape[0], c.rows.shape[0])
    run = BenchRun(t=p.col("t")[:m], q=p.group("q")[:m], qd=p.group("qd")[:m],
                   u=c.group("u")[:m], plant_summary={}, controller_summary={},
                   u_n=c.group("u_n")[:m], u_c=c.group("u_c")[:m])
    bench = bench_result(ref, run, p.rows)
    ref_run = extend_reference(ref, float(bench.t[-1] - bench.t[0]))
    write_bench_figures(out, ref_run, bench, unquantised_cosim(ref_run, model, values),
                        scenario="ctc")
    return sorted(out.glob("*.png"))


#: The CANopen masters over socketcand here: kind -> the options of ``rrr hil canopen`` (over
#: SocketCAN, guest_python_sides.CANOPEN_MASTERS adds ``--interface socketcan``).
MASTER_ARGS = {"python": [], "c": ["--master", "c"]}
#: The drives' rated torques (0x6076, mN m), which the masters read by SDO
#: (test_hil_canopen_master.py asserts it).
RATED_TORQUE_MNM = [120000, 110000, 47000]


@dataclass(frozen=True)
class Sides:
    """The runs of ``rrr hil bench|controller|plant`` and ``rrr hil canopen`` (each master) of
    PY_DURATION s over one transport, each in its folder of ``out`` (bench, controller, plant,
    canopen_python, canopen_c); ``cases``: each one's exit status ``rc`` and, for the Python
    sides, the C node's ``node_rc``; ``detail``: what to show when one is missing."""

    transport: str
    out: Path
    cases: dict[str, Any]
    detail: str = ""

    def node(self, side: str) -> Path:
        """The folder of the C node's logs in a Python side's run: over SocketCAN the guest
        starts that node itself (guest_python_sides.py), here ``rrr hil`` does."""
        return self.out / side / "node" if self.transport == "socketcan" else self.out / side


def host_sides(out: Path) -> Sides:
    """The runs of Sides here over socketcand (the other node started by rrr)."""
    t0 = time.monotonic()
    common = ["--duration", PY_DURATION, "--scenario", "ctc", "-q", "--no-figures"]
    argv = {side: ["hil", side] for side in ("bench", "controller", "plant")} | {
        f"canopen_{kind}": ["hil", "canopen", *args] for kind, args in MASTER_ARGS.items()}
    cases: dict[str, Any] = {}
    for name, args in argv.items():
        p = subprocess.run([sys.executable, "-m", "rrr_robot", *args, "--out", str(out / name),
                            *common], capture_output=True, text=True, timeout=600)
        cases[name] = {"rc": p.returncode, "stderr": p.stderr[-3000:], "error": None}
    for side, node in (("controller", "plant_exit"), ("plant", "controller")):
        path = out / side / "summary.json"
        s = json.loads(path.read_text()) if path.exists() else {}
        cases[side]["node_rc"] = s.get(node) if side == "controller" else \
            s.get(node, {}).get("exit")
    print(f"the runs over socketcand here: {time.monotonic() - t0:.1f} s")
    return Sides("socketcand", out, cases)


@pytest.fixture(scope="module")
def socketcand_sides(tmp_path_factory: pytest.TempPathFactory) -> Background[Sides]:
    return Background(lambda: host_sides(tmp_path_factory.mktemp("socketcand_sides")))


@pytest.fixture(scope="module")
def python_sides(guest: CanGuest, socketcand_sides: Background[Sides]) -> dict[str, Any]:
    """guest_python_sides.py in one Python process in the guest (and meanwhile the same runs
    here over socketcand: the emulator runs on one host CPU, these on the other)."""
    out = guest.scratch / "python_sides"
    out.mkdir()
    driver = Path(__file__).with_name("guest_python_sides.py")
    socketcand_sides.start()
    r = guest.run(f"{shlex.join([sys.executable, str(driver), str(out), PY_DURATION])} "
                  "vcan0 vcan1 $(cut -d' ' -f1 /proc/uptime)", timeout=600)
    print(f"python sides in the guest: exit {r.rc}, {r.seconds:.1f} s")
    cases = json.loads((out / "cases.json").read_text()) if (out / "cases.json").exists() \
        else {}
    for name, case in cases.items():
        print(f"  {name}: {case}")
    return {"result": r, "out": out, "cases": cases,
            "sides": Sides("socketcan", out, cases, r.stderr[-3000:])}


@pytest.fixture
def sides(transport: str, request: pytest.FixtureRequest) -> Sides:
    """The runs of Sides over ``transport``."""
    if transport == "socketcan":
        guest_sides: Sides = request.getfixturevalue("python_sides")["sides"]
        assert guest_sides.cases, ("guest_python_sides.py wrote no cases.json",
                                   guest_sides.detail)
        return guest_sides
    return request.getfixturevalue("socketcand_sides").result()


def rerun_nodes(folder: Path, ctrl_args: list[str], out: Path) -> None:
    """The C nodes over socketcand here on the reference.csv of ``folder`` (a run of rrr hil
    bench), its logs into ``out``."""
    ref_csv = folder / "reference.csv"
    row0 = read_csv(ref_csv)[1].split(",")
    out.mkdir()
    plant = start_plant(q0=[float(x) for x in row0[1:4]], qd0=[float(x) for x in row0[4:7]],
                        log_csv=out / "plant.csv")
    with plant, start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                 log_csv=out / "controller.csv", extra=ctrl_args) as ctrl:
        assert ctrl.wait(300)["exit"] == 0 and plant.wait(60)["exit"] == 0


def test_rrr_hil_bench(sides: Sides, transport: str, writing: Writing,
                       tmp_path: Path) -> None:
    """``rrr hil bench`` over the transport (``--interface socketcan`` in the guest): exit 0,
    its summary and frame logs written; its figures, drawn here from the logs it wrote (in the
    guest, matplotlib is slow), are all there; its logs equal those of the same C nodes over
    socketcand here on the reference it wrote, bit for bit; its summary names the transport;
    frames.blf read back equals the controller's frame log. (The writing reference itself,
    computed with numpy, differs in its last bits between this CPU and the emulated one, which
    has no AVX-512: numpy takes other SIMD code paths; hence the rerun on the run's file.)"""
    case = sides.cases.get("bench")
    assert case is not None and case["rc"] == 0, (case, sides.detail)
    mine = sides.out / "bench"
    for name in ("summary.json", "frames.blf", "frames.rrrcan"):
        assert (mine / name).stat().st_size > 0, name
    figures = tmp_path / "figures_of_the_run"
    figures.mkdir()
    drawn = figures_from_files(mine, figures)
    assert sorted(p.name for p in drawn) == sorted(FIGURES)
    assert all(p.stat().st_size > 10_000 for p in drawn)
    rerun_nodes(mine, controller_node_args(writing.values), tmp_path / "rerun")
    for name in ("plant.csv", "controller.csv"):
        assert read_csv(mine / name) == read_csv(tmp_path / "rerun" / name), name
    s = json.loads((mine / "summary.json").read_text())
    assert s["controller"]["transport"] == transport
    assert framelog.compare(framelog.read_node_log(mine / "frames.rrrcan"),
                            framelog.read_can_log(mine / "frames.blf")) is None


def test_rrr_hil_bench_socketcan_equals_socketcand(python_sides: dict[str, Any],
                                                   socketcand_sides: Background[Sides]) -> None:
    """``rrr hil bench --interface socketcan`` in the guest and ``rrr hil bench`` here over
    socketcand: summary.json equal to SUMMARY_TOLERANCE, and exactly for every count; the
    controller's account and the bus's frames equal but for the transport's own fields."""
    r, out = python_sides["result"], python_sides["out"]
    host = socketcand_sides.result()
    assert r.rc == 0, r.stderr[-3000:]
    assert python_sides["cases"]["bench"]["rc"] == 0 and host.cases["bench"]["rc"] == 0
    s, h = (json.loads((d / "bench" / "summary.json").read_text()) for d in (out, host.out))
    for key, (rtol, atol) in SUMMARY_TOLERANCE.items():
        assert _close(_untimed(s[key]), _untimed(h[key]), rtol, atol), key
    assert s["controller"]["transport"] == "socketcan"
    assert {k: v for k, v in s["controller"].items() if k not in TRANSPORT_FIELDS} == \
        {k: v for k, v in h["controller"].items() if k not in TRANSPORT_FIELDS}
    bus, hbus = _untimed(s["bus"]), _untimed(h["bus"])
    same = ("frames", "frames_per_period", "tx", "rx", "by_id", "load")
    assert {k: bus[k] for k in same} == {k: hbus[k] for k in same}


def _side_logs(sides: Sides, side: str) -> dict[str, Any]:
    """The plant's and the controller's logs of a Python side's run: the Python side's in its
    folder, the C node's in Sides.node."""
    python_log = "controller.csv" if side == "controller" else "plant.csv"
    logs = {}
    for log in ("plant.csv", "controller.csv"):
        spec = PLANT_LOG if log == "plant.csv" else CONTROLLER_LOG
        folder = sides.out / side if log == python_log else sides.node(side)
        logs[log] = read_log(folder / log, spec).rows
    return logs


def _state_columns(log: str) -> slice:
    """q, qd and u (plant), q, qd, u, u_n and u_c (controller)."""
    spec = PLANT_LOG if log == "plant.csv" else CONTROLLER_LOG
    return slice(spec.index("q[1]"), spec.index("zero" if spec is PLANT_LOG else "enable"))


@pytest.mark.parametrize("side", ["controller", "plant"])
def test_python_side(sides: Sides, side: str) -> None:
    """``rrr hil controller`` (the controller FMU under FMPy against the C plant node) and
    ``rrr hil plant`` (the plant FMU behind the C supervisor against the C controller node)
    over the transport (python-can's socketcan interface in the guest, its socketcand one
    here): both exit 0; the Python side's log and the C node's equal those of the all-C run
    over the same transport (``rrr hil bench``) to < 1e-9 rad, V."""
    case = sides.cases.get(side)
    assert case is not None, sides.detail
    assert (case["rc"], case["node_rc"], case.get("error")) == (0, 0, None), case
    logs = _side_logs(sides, side)
    for log, a in logs.items():
        spec = PLANT_LOG if log == "plant.csv" else CONTROLLER_LOG
        b = read_log(sides.out / "bench" / log, spec).rows
        cols = _state_columns(log)
        assert a.shape == b.shape and np.abs(a[:, cols] - b[:, cols]).max() < 1e-9, log


@pytest.mark.parametrize("side", ["controller", "plant"])
def test_python_side_socketcan_equals_socketcand(python_sides: dict[str, Any],
                                                 socketcand_sides: Background[Sides],
                                                 side: str) -> None:
    """The same side over SocketCAN in the guest and over socketcand here: both logs equal to
    < 1e-9 rad, V (the references differ in their last bits: see test_rrr_hil_bench)."""
    host = socketcand_sides.result()
    assert host.cases[side]["rc"] == 0, host.cases[side]
    mine, theirs = _side_logs(python_sides["sides"], side), _side_logs(host, side)
    for log, a in mine.items():
        b, cols = theirs[log], _state_columns(log)
        assert a.shape == b.shape and np.abs(a[:, cols] - b[:, cols]).max() < 1e-9, log


def _master_reference(sides: Sides) -> Any:
    """The reference the CANopen masters ran: over SocketCAN the guest's (computed there:
    canopen_reference.npz), here the same computation on this CPU."""
    from dataclasses import replace

    from rrr_robot.hil.canopen.results import writing_controller
    from rrr_robot.hil.results import extend_reference

    ref = extend_reference(writing_controller(None, "ctc").ref, float(PY_DURATION))
    if sides.transport != "socketcan":
        return ref
    z = np.load(sides.out / "canopen_reference.npz")
    return replace(ref, t=z["t"], q=z["q"], qd=z["qd"], qdd=z["qdd"], x=z["x"])


def _by_id_counts(summary: dict[str, Any]) -> dict[str, Any]:
    """The frame count of each identifier but the heartbeats (wall-clock timed)."""
    return {i: v["frames"] for i, v in summary["bus"]["by_id"].items()
            if not 0x701 <= int(i, 16) <= 0x77F}


@pytest.mark.parametrize("master", sorted(CANOPEN_MASTERS))
def test_canopen_master(sides: Sides, master: str, transport: str) -> None:
    """A CANopen master (``rrr hil canopen``: canopen.Network on python-can's interface of the
    transport, or ``--master c``, the C controller node) against ``rrr_hil_plant --profile
    canopen``'s three CiA 402 drives, PY_DURATION s of the writing task in lockstep: exit 0, no
    drive fault; its summary.json, logs and frame logs written, the .blf equal to the node's
    frame log; the run equals the co-simulation with the PDOs' quantisation bit for bit on the
    reference it ran; one SYNC per period."""
    from rrr_robot.hil.canopen.drives import pdo_quantisation
    from rrr_robot.hil.canopen.results import writing_controller
    from rrr_robot.hil.nodes import PERIOD
    from rrr_robot.hil.results import BenchRun, bench_result

    case = sides.cases.get(f"canopen_{master}")
    assert case is not None and case["rc"] == 0, (case, sides.detail)
    mine = sides.out / f"canopen_{master}"
    for name in ("summary.json", "plant.csv", "controller.csv", "frames.rrrcan", "frames.blf"):
        assert (mine / name).stat().st_size > 0, name
    s = json.loads((mine / "summary.json").read_text())
    assert s["side"] == "canopen" and s["controller"]["transport"] == transport
    assert s["plant_exit"] == 0 and s["missed_commands"] == 0, s
    assert framelog.compare(framelog.read_node_log(mine / "frames.rrrcan"),
                            framelog.read_can_log(mine / "frames.blf")) is None

    ref = _master_reference(sides)
    wc = writing_controller(None, "ctc")
    measure, actuate = pdo_quantisation([float(v) for v in wc.controller_model.kt],
                                        [float(v) for v in wc.model.kt], RATED_TORQUE_MNM)
    cosim = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                      CosimOptions(step=PERIOD, controller_values=wc.controller_values,
                                   measure=measure, actuate=actuate))
    p = read_log(mine / "plant.csv", PLANT_LOG)
    c = read_log(mine / "controller.csv", CONTROLLER_LOG)
    run = BenchRun(t=c.col("t"), q=c.group("q"), qd=c.group("qd"), u=c.group("u"),
                   plant_summary={}, controller_summary={}, u_n=c.group("u_n"),
                   u_c=c.group("u_c"))
    bench = bench_result(ref, run, p.rows)
    assert np.array_equal(bench.q, cosim.q) and np.array_equal(bench.qd, cosim.qd)
    assert np.array_equal(run.u, cosim.u) and np.array_equal(bench.tip, cosim.tip)
    assert _by_id_counts(s)["0x080"] == ref.t.shape[0]
    print(f"  CANopen master {master} over {transport}: {ref.t.shape[0]} SYNC periods; tip "
          f"error max {1e3 * s['bench']['tip_error_max']:.4f} mm")


@pytest.mark.parametrize("master", sorted(CANOPEN_MASTERS))
def test_canopen_master_socketcan_equals_socketcand(python_sides: dict[str, Any], master: str,
                                                    tmp_path: Path) -> None:
    """The master over vcan0 in the guest and the same master over socketcand here on the
    reference the guest ran: the plant's and master's logs equal bit for bit; summary.json
    equals that run's to SUMMARY_TOLERANCE, and the frame counts of every identifier but the
    heartbeats (wall-clock timed) are the same; the C master's own account too (its transport
    counters differ by transport)."""
    from dataclasses import replace

    from rrr_robot.core.outputs import ResultSet
    from rrr_robot.hil.canopen.c_master import run_c_master
    from rrr_robot.hil.canopen.master import run_canopen_master
    from rrr_robot.hil.canopen.results import write_master_results, writing_controller

    guest_sides: Sides = python_sides["sides"]
    case = guest_sides.cases.get(f"canopen_{master}")
    assert case is not None and case["rc"] == 0, (case, guest_sides.detail)
    mine = guest_sides.out / f"canopen_{master}"
    s = json.loads((mine / "summary.json").read_text())
    ref = _master_reference(guest_sides)
    wc = replace(writing_controller(None, "ctc"), ref=ref)
    with ResultSet(tmp_path / "host", kind="hil") as rs:
        if master == "c":
            mrun = run_c_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model,
                                wc.controller_values, rs.staging)
        else:
            mrun = run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model,
                                      wc.gains, rs.staging)
        h = write_master_results(rs, wc, mrun, scenario="ctc", figures=False)
    assert [d.rated_torque_mNm for d in mrun.drives] == RATED_TORQUE_MNM
    for name in ("plant.csv", "controller.csv"):
        assert read_csv(mine / name) == read_csv(tmp_path / "host" / name), name
    for key, (rtol, atol) in SUMMARY_TOLERANCE.items():
        assert _close(_untimed(s[key]), _untimed(h[key]), rtol, atol), key
    if master == "c":  # the C node's own account; its transport counters differ by transport
        keys = ("exit", "profile", "node_ids", "syncs", "states", "sdo_transfers",
                "tpdo_bad_length", "ctc_failed", "rated_torque_mNm", "increments_per_revolution",
                "target_torque_per_mille_max_abs", "master")
        assert {k: s["controller"][k] for k in keys} == {k: h["controller"][k] for k in keys}
        assert s["controller"]["transport"] == "socketcan"
    else:
        assert s["controller"] == {**h["controller"], "transport": "socketcan"}
    assert _by_id_counts(s) == _by_id_counts(h)
    print(f"  CANopen master {master} over vcan0: {ref.t.shape[0]} SYNC periods in "
          f"{case['seconds']:.1f} s in the guest, equal to the run here over socketcand")


# ---- over SocketCAN only: rrr hil bench --fd, a bad frame from a third node, NMT by cansend -


def test_rrr_hil_bench_fd_over_socketcan(python_sides: dict[str, Any]) -> None:
    """``rrr hil bench --interface socketcan --channel vcan1 --fd`` in the guest: exit 0, both
    nodes on CAN FD (transport socketcan-fd), the same logs as the classical run over vcan0 bit
    for bit and the same metrics; summary.json's bus section has the CAN FD load of what the
    controller sent and received, its frame count equal to the classical run's."""
    case, out = python_sides["cases"]["bench_fd"], python_sides["out"]
    assert case["rc"] == 0, case
    for name in ("plant.csv", "controller.csv"):
        assert read_csv(out / "bench_fd" / name) == read_csv(out / "bench" / name), name
    s, c = (json.loads((out / d / "summary.json").read_text()) for d in ("bench_fd", "bench"))
    assert s["controller"]["transport"] == "socketcan-fd" and s["plant_exit"] == 0
    assert _untimed(s["bench"]) == _untimed(c["bench"]) and s["faults"] == c["faults"]
    fd = s["bus"]["load_fd"]
    assert s["bus"]["frames_per_period"] == c["bus"]["frames_per_period"]
    assert 0 < fd["measured_no_stuffing_percent"] < fd["measured_worst_case_percent"] < \
        s["bus"]["load"]["measured_percent"]
    assert "load_fd" not in c["bus"]
    print(f"  rrr hil bench --fd: {s['bus']['frames_per_period']:.3f} frames, "
          f"{fd['bytes_per_period']:.2f} bytes per period at the controller, "
          f"{fd['measured_worst_case_percent']:.2f} % worst case (schedule "
          f"{fd['schedule_worst_case_percent']:.2f} %)")


def test_rrr_hil_bench_safety_status(python_sides: dict[str, Any]) -> None:
    """``rrr hil bench --interface socketcan`` with one VoltageCmd of a wrong CRC put on the bus
    mid-run: the run completes, the plant latched ``crc`` and applied 0 V to the end, and
    ``rrr hil bench`` returns EXIT_SAFETY (7), as do both nodes, so a CI job running it fails;
    its summary.json and frame log are written all the same."""
    case = python_sides["cases"]["bench_fault"]
    assert case["rc"] == EXIT_SAFETY, case
    assert case.get("injected_after_sync", -1) >= 200, case
    s = json.loads((python_sides["out"] / "bench_fault" / "summary.json").read_text())
    assert s["plant_exit"] == EXIT_SAFETY and s["controller"]["exit"] == EXIT_SAFETY
    assert s["faults"]["crc"] == 1 and s["faults"]["faults"] == FAULT_BITS["crc"]
    assert s["faults"]["zero_periods"] > 0 and s["controller"]["plant_status_faulty"] > 0
    assert s["bench"]["tip_error_max"] > 1e-3  # 0 V from period ~200 on: the arm fell


def test_canopen_nmt_and_heartbeat_loss_on_vcan(guest: CanGuest, bench_inputs: dict[str, Any],
                                                tmp_path_factory: pytest.TempPathFactory
                                                ) -> None:
    """``rrr_hil_plant --profile canopen`` on vcan0, driven by can-utils' cansend and recorded by
    candump: the three power-on boot-ups, NMT reset node (boot-ups again), NMT start
    (heartbeats in operational, 0x05), node 2 set by an expedited SDO download to monitor a
    master heartbeat (0x1016 sub 1 = node 0x7F, 100 ms) that comes and then stops: node 2 sends
    EMCY 0x8130 with the error register 0x11 once, the others do not; NMT stop (heartbeats
    0x04); the plant then ends 1 s into the silence that follows (--end-after-stop-ms), while
    10 s of silence with a drive operational would be a lost master (far above the gaps between
    two cansend processes under emulation on a busy machine). One master heartbeat only: a cansend
    process takes longer than 100 ms to start under emulation, so a train of them would be lost
    between each two (measured: ten sent 20 ms apart, ten losses)."""
    work = guest.scratch / "canopen_nmt"
    work.mkdir()
    w = shlex.quote(str(work))
    plant = shlex.join([str(node_executable("plant")), *bench_inputs["plant_args"],
                        "--profile", "canopen", "--socketcan", "vcan0",
                        "--idle-timeout-ms", "10000", "--end-after-stop-ms", "1000"])
    script = RECORDER + f"""
record_start vcan0
{plant} > {w}/plant.out 2> {w}/plant.err &
P=$!
wait_for ' 703#00' $L || {{ echo "no boot-up" >&2; exit 91; }}
cansend vcan0 000#8100
n=0; until [ "$(grep -c ' 703#00' $L)" -ge 2 ]; do sleep 0.05; n=$((n+1));
  [ $n -gt 400 ] && {{ echo "no boot-up after reset" >&2; exit 93; }}; done
cansend vcan0 000#0100
wait_for ' 702#05' $L || {{ echo "no heartbeat in operational" >&2; exit 94; }}
cansend vcan0 602#2316100164007F00
wait_for ' 582#60161001' $L || {{ echo "no SDO answer" >&2; exit 95; }}
cansend vcan0 77F#05
wait_for ' 082#308111' $L || {{ echo "no EMCY" >&2; exit 96; }}
cansend vcan0 000#0200
wait_for ' 702#04' $L || {{ echo "no heartbeat in stopped" >&2; exit 97; }}
wait $P
echo "plant $?" > {w}/exit
record_stop vcan0 {w}
"""
    (work / "run.sh").write_text(script)
    r = run(guest, f"sh {shlex.quote(str(work / 'run.sh'))}",
            "CANopen plant on vcan0 (cansend, candump)", timeout=120)
    assert r.rc == 0, (r.stderr, (work / "plant.err").read_text() if (work / "plant.err")
                       .exists() else "")
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    # the drive latched a fault (the lost master heartbeat): the run ends with EXIT_SAFETY
    assert exits["candump"] == "0" and exits["plant"] == str(EXIT_SAFETY), exits
    bus = candump_messages(work / "candump.log")
    frames = [(m.arbitration_id, bytes(m.data)) for m in bus]
    for node in (1, 2, 3):
        assert frames.count((0x700 + node, b"\0")) == 2  # power-on and after the reset
        assert (0x700 + node, b"\x05") in frames and (0x700 + node, b"\x04") in frames
    emcy = [(cob, data) for cob, data in frames if 0x81 <= cob <= 0x83]
    assert len(emcy) == 1 and emcy[0][0] == 0x82, emcy
    assert emcy[0][1][:3] == bytes([0x30, 0x81, 0x11]), emcy
    s = summary_lines((work / "plant.out").read_text())
    assert s["profile"] == "canopen" and s["transport"] == "socketcan"
    hb = [d["hb_lost"] for d in s["drives"]]
    assert hb == [0, 1, 0] and [d["state"] for d in s["drives"]] == [
        "SWITCH ON DISABLED", "FAULT", "SWITCH ON DISABLED"], s["drives"]
    assert (s["drives"][1]["error_code"], s["drives"][1]["error_register"]) == (0x8130, 0x11)
    assert [d["nmt"] for d in s["drives"]] == [4, 4, 4]  # stopped
