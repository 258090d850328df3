"""The CAN bench on a Linux kernel CAN stack: SocketCAN (vcan) in a QEMU guest (can_guest.py).

One guest is booted for this module and runs every case (a boot costs about 10 s under
emulation). The reference runs are the same programs on this machine over the socketcand
transport (TCP on loopback), which needs no AF_CAN. Each case prints the time it took in the
guest (pytest -s shows it).
"""

from __future__ import annotations

import json
import math
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import can
import cantools
import numpy as np
import pytest
from can_guest import CanGuest, GuestError, GuestUnavailable, Result, default_shares
from guest_python_sides import CANOPEN_MASTERS
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
from rrr_robot.sim.fmus import fmu_path
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

#: Summary fields that name or count the transport itself (socketcan has no connection).
TRANSPORT_FIELDS = {"transport", "connects", "disconnects"}
#: Identifiers the guest scripts put on the bus around a run (never used by the bench): a probe
#: that tells when candump is reading, and the end marker after which its log is complete.
PROBE_ID, END_ID = 0x7FE, 0x7FF


@pytest.fixture(scope="module")
def tmp_checkout() -> Iterator[Path]:
    """A checkout under /tmp (where the guest has a tmpfs of its own), a blank in its name: a
    script that reads a file beside it, and a virtual environment (``python -m venv``) whose
    python links to this interpreter's."""
    tree = Path(tempfile.mkdtemp(prefix="rrr guest checkout ", dir="/tmp"))
    try:
        (tree / "tools").mkdir()
        (tree / "tools" / "probe.py").write_text(
            "import pathlib, sys\nprint(sys.prefix)\n"
            "print((pathlib.Path(__file__).parent / 'data.txt').read_text().strip())\n")
        (tree / "tools" / "data.txt").write_text("read from the checkout\n")
        subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tree / ".venv")],
                       check=True)
        yield tree
    finally:
        shutil.rmtree(tree, ignore_errors=True)


@pytest.fixture(scope="module")
def guest(tmp_path_factory: pytest.TempPathFactory, tmp_checkout: Path) -> Iterator[CanGuest]:
    scratch = tmp_path_factory.mktemp("can guest")  # a blank in every path the jobs write to
    shares = [*default_shares(), *default_shares(tmp_checkout, tmp_checkout / ".venv/bin/python")]
    try:
        g = CanGuest(scratch, share=shares).start()
    except GuestUnavailable as exc:  # not a skip: the test command provides all of it
        pytest.fail(f"the SocketCAN guest cannot be booted here: {exc}")
    print(f"guest: kernel {g.kernel_release}, booted in {g.boot_seconds:.1f} s")
    try:
        yield g
    finally:
        g.close()


def run(guest: CanGuest, command: str, what: str, timeout: float = 120.0) -> Result:
    r = guest.run(command, timeout=timeout)
    print(f"{what}: exit {r.rc}, {r.seconds:.1f} s ({r.guest_seconds:.1f} s in the guest)")
    return r


# ---- the harness -----------------------------------------------------------------------------


def test_guest_interfaces(guest: CanGuest) -> None:
    """vcan0 classical (MTU 16), vcan1 CAN FD (MTU 72), both up; the kernel has AF_CAN."""
    r = run(guest, "ip -details -json link show type vcan", "ip link")
    assert r.rc == 0, r.stderr
    links = {link["ifname"]: link for link in json.loads(r.stdout)}
    assert set(links) == {"vcan0", "vcan1"}
    assert links["vcan0"]["mtu"] == 16 and links["vcan1"]["mtu"] == 72
    assert all("UP" in link["flags"] for link in links.values())
    r = run(guest, f"{shlex.quote(sys.executable)} -c 'import socket; socket.socket(socket.PF_CAN, "
            "socket.SOCK_RAW, "
            "socket.CAN_RAW).bind((\"vcan1\",)); print(\"bound\")'", "AF_CAN socket")
    assert (r.rc, r.stdout.strip()) == (0, "bound"), r.stderr


def test_guest_files_status_and_time_bound(guest: CanGuest) -> None:
    """Output and exit status come back, the host tree is read-only, the scratch folder is
    written through, and a job past its timeout is killed (status 137) in time."""
    here = Path(__file__).resolve()
    r = run(guest, f"head -c 3 {shlex.quote(str(here))}; echo err >&2; exit 7", "status")
    assert (r.rc, r.stdout, r.stderr) == (7, '"""', "err\n")
    r = run(guest, f"touch {shlex.quote(str(here.parent / 'guest_was_here'))}", "read-only")
    assert r.rc != 0 and "Read-only file system" in r.stderr
    assert not (here.parent / "guest_was_here").exists()
    target = guest.scratch / "from_guest.txt"
    r = run(guest, f"echo from the guest > {shlex.quote(str(target))}; uname -r", "scratch")
    assert r.rc == 0 and target.read_text() == "from the guest\n"
    assert r.stdout.strip() == guest.kernel_release
    r = run(guest, "sleep 60 & sleep 60; echo never", "timeout", timeout=2)
    assert r.rc == 137 and r.stdout == ""  # killed before the sleep ended
    r = run(guest, "pgrep -c -x -f 'sleep 60' || true", "leftovers")  # killed with the job
    assert r.stdout.strip() == "0"


def test_guest_sees_a_checkout_under_tmp(guest: CanGuest, tmp_checkout: Path) -> None:
    """A checkout under /tmp: its virtual environment's python runs its script by path in the
    guest (the checkout, the venv and the interpreter it links to are there, read-only, at their
    own paths), while the guest's /tmp stays its own and writable."""
    python, probe = tmp_checkout / ".venv" / "bin" / "python", tmp_checkout / "tools" / "probe.py"
    r = run(guest, shlex.join([str(python), str(probe)]), "a checkout under /tmp")
    assert r.rc == 0, r.stderr
    assert r.stdout.splitlines() == [str(tmp_checkout / ".venv"), "read from the checkout"]
    r = run(guest, f"touch {shlex.quote(str(tmp_checkout / 'guest_was_here'))}", "read-only")
    assert r.rc != 0 and "Read-only file system" in r.stderr
    assert not (tmp_checkout / "guest_was_here").exists()
    mine = f"/tmp/{tmp_checkout.name}.guest-own"
    r = run(guest, f"echo own > {shlex.quote(mine)} && cat {shlex.quote(mine)}", "own /tmp")
    assert (r.rc, r.stdout) == (0, "own\n"), r.stderr
    assert not Path(mine).exists()  # on the guest's tmpfs, not here


def test_guest_bad_use(guest: CanGuest, tmp_path: Path) -> None:
    """A scratch path with a newline is refused before anything boots; a stopped guest
    refuses."""
    with pytest.raises(ValueError, match="newline"):
        CanGuest(tmp_path / "a\nb")
    idle = CanGuest(tmp_path / "idle")
    with pytest.raises(GuestError, match="not running"):
        idle.run("true")


# ---- the all-C lockstep bench over vcan0 against the socketcand bench ------------------------


def summary_lines(text: str) -> dict[str, Any]:
    lines = [ln for ln in text.splitlines() if ln.startswith("RRR_HIL_SUMMARY ")]
    assert len(lines) == 1, text
    return dict(json.loads(lines[0][len("RRR_HIL_SUMMARY "):]))


@pytest.fixture(scope="module")
def bench_inputs(guest: CanGuest) -> dict[str, Any]:
    """The writing task's reference (ctc), the controller node's options and the unzipped
    plant FMU, in the scratch folder (the guest's /tmp is its own)."""
    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), scenarios=["ctc"]))
    values = controller_fmu_values(scenarios[0], model, robot.require_control())
    work = guest.scratch / "bench"
    work.mkdir()
    fmu = work / "plant_fmu"
    with zipfile.ZipFile(fmu_path("plant")) as z:
        z.extractall(fmu)
    ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv")
    vec = ",".join
    plant_args = ["--fmu", str(fmu), "--q0", vec(f"{x:.17g}" for x in ref.q[0]),
                  "--qd0", vec(f"{x:.17g}" for x in ref.qd[0])]
    return {"ref": ref, "ref_csv": ref_csv, "plant_args": plant_args,
            "ctrl_args": controller_node_args(values), "fmu": fmu, "work": work,
            "periods": ref.t.shape[0]}


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


def host_socketcand_bench(inputs: dict[str, Any], work: Path) -> dict[str, dict[str, Any]]:
    """The same nodes and options on this machine over socketcand (plant = server)."""
    work.mkdir()
    ref = inputs["ref"]
    plant = start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=work / "plant.csv",
                        frame_log=work / "plant.rrrcan")
    with plant, start_controller(inputs["ref_csv"], connect=f"127.0.0.1:{plant.port}",
                                 log_csv=work / "controller.csv",
                                 frame_log=work / "controller.rrrcan",
                                 extra=inputs["ctrl_args"]) as ctrl:
        cs = ctrl.wait(300)
        ps = plant.wait(60)
    return {"plant": ps, "controller": cs}


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


@pytest.fixture(scope="module")
def c_bench(guest: CanGuest, bench_inputs: dict[str, Any]) -> dict[str, Any]:
    work = bench_inputs["work"] / "vcan"
    work.mkdir()
    script = work / "bench.sh"
    script.write_text(c_bench_script(work, bench_inputs["plant_args"], bench_inputs["ctrl_args"],
                                     bench_inputs["ref_csv"]))
    with ThreadPoolExecutor(max_workers=1) as pool:  # the same run here, meanwhile
        here = pool.submit(host_socketcand_bench, bench_inputs,
                           bench_inputs["work"] / "socketcand")
        r = run(guest, f"sh {shlex.quote(str(script))}", "C bench over vcan0 (with candump)",
                timeout=240)
        host = here.result()
    times = (work / "times").read_text().split() if (work / "times").exists() else []
    if times:
        print(f"  the two nodes: {float(times[2]) - float(times[1]):.1f} s in the guest for "
              f"{bench_inputs['periods']} periods")
    return {"result": r, "work": work, "host": host,
            "host_work": bench_inputs["work"] / "socketcand"}


def test_c_bench_over_vcan_equals_socketcand(c_bench: dict[str, Any],
                                             bench_inputs: dict[str, Any]) -> None:
    """rrr_hil_plant and rrr_hil_controller with --socketcan vcan0 in lockstep: both exit 0,
    their logs equal the socketcand run's bit for bit, their summaries too (but for the
    transport's name and connection counts), and so do the metrics of the run."""
    r, work, host_work = c_bench["result"], c_bench["work"], c_bench["host_work"]
    assert r.rc == 0, r.stderr + (work / "plant.err").read_text()
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    assert exits == {"controller": "0", "plant": "0", "candump": "0"}, exits
    assert "rrr_hil_plant: exit 0 (completed)" in (work / "plant.err").read_text()
    assert "rrr_hil_controller: exit 0 (completed)" in (work / "controller.err").read_text()
    n = bench_inputs["periods"]
    for name in ("plant.csv", "controller.csv"):
        mine, theirs = read_csv(work / name), read_csv(host_work / name)
        assert len(mine) == len(theirs) >= n, name
        assert mine == theirs, f"{name}: differs from the socketcand run"
    for node in ("plant", "controller"):
        guest_sum = summary_lines((work / f"{node}.out").read_text())
        host_sum = dict(c_bench["host"][node])
        assert guest_sum["transport"] == "socketcan" and host_sum["transport"] == "socketcand"
        assert guest_sum["exit"] == host_sum["exit"] == 0
        if node == "plant":  # its boot-up heartbeat: on the bus here, dropped by a
            # socketcand server that has no client yet (docs/can.md, Heartbeats)
            assert (host_sum["tx_dropped"], guest_sum["tx_dropped"]) == (1, 0)
            for k in ("tx_frames", "frames_logged", "tx_dropped"):
                host_sum[k] += 1 if k != "tx_dropped" else -1
        diff = {k: (host_sum.get(k), v) for k, v in guest_sum.items()
                if k not in TRANSPORT_FIELDS and host_sum.get(k) != v}
        assert not diff, f"{node} summary differs from the socketcand run: {diff}"
        assert set(guest_sum) == set(host_sum)
    assert summary_lines((work / "plant.out").read_text())["periods"] == n - 1
    ref = bench_inputs["ref"]
    mine, theirs = (log_metrics(work / "controller.csv", ref),
                    log_metrics(host_work / "controller.csv", ref))
    assert mine == theirs and all(math.isfinite(v) for v in mine.values())


#: The controller's frames (Sync, StopCmd, VoltageCmd, HeartbeatCtrl); the rest are the plant's.
CONTROLLER_IDS = {0x080, 0x090, 0x100, 0x701}


def test_candump_log_equals_node_frame_logs(c_bench: dict[str, Any]) -> None:
    """candump -L (can-utils) recorded the run with no frame dropped; python-can reads its log
    and cantools decodes every frame with the bench's DBC. Frame for frame (identifier, data,
    order), each node's frames on the bus are its frame log's Tx records and the other node's
    Rx records, but for the documented ends: the plant's boot-up heartbeat precedes the
    controller, the plant may end before the controller's last heartbeat reaches it, and the
    controller stops reading after the last joint state (docs/can.md, Frame logs)."""
    work = c_bench["work"]
    assert "" == (work / "candump.err").read_text().strip()  # -d: it reports drops there
    bus = candump_messages(work / "candump.log")
    db = cantools.database.load_file(str(DBC_PATH))
    names = [db.get_message_by_frame_id(m.arbitration_id).name for m in bus]
    decoded = [db.decode_message(m.arbitration_id, m.data, decode_choices=False) for m in bus]
    assert names[0] == "HeartbeatPlant" and decoded[0]["NmtState"] == 0  # boot-up
    assert names.count("VoltageCmd") == names.count("JointState1") == names.count("Sync") + 1
    assert names.count("VoltageCmd") > 5000
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


# ---- the same bench as CAN FD frames on vcan1 ------------------------------------------------

#: The data bit rate of the CAN FD figures (1 Mbit/s nominal): rrr hil busload --fd's argument.
FD_DATA_BITRATE = 5_000_000


@pytest.fixture(scope="module")
def c_bench_fd(guest: CanGuest, bench_inputs: dict[str, Any],
               c_bench: dict[str, Any]) -> dict[str, Any]:
    """The all-C lockstep bench of c_bench again, both nodes with --fd on vcan1 (MTU 72)."""
    work = bench_inputs["work"] / "vcan_fd"
    work.mkdir()
    script = work / "bench.sh"
    script.write_text(c_bench_script(work, bench_inputs["plant_args"], bench_inputs["ctrl_args"],
                                     bench_inputs["ref_csv"], channel="vcan1", fd=True))
    r = run(guest, f"sh {shlex.quote(str(script))}", "C bench over vcan1, CAN FD (with candump)",
            timeout=240)
    return {"result": r, "work": work}


def test_c_bench_fd_over_vcan1_equals_classical(c_bench_fd: dict[str, Any],
                                                c_bench: dict[str, Any],
                                                bench_inputs: dict[str, Any]) -> None:
    """rrr_hil_plant and rrr_hil_controller with --socketcan vcan1 --fd: both exit 0; the
    payloads are the classical frames' (same DBC, same quantisation), so the run is the
    classical run over vcan0 bit for bit: equal logs, equal metrics, equal summaries but for
    the transport's name (socketcan-fd); no frame was malformed or of the wrong format."""
    r, work, classical = c_bench_fd["result"], c_bench_fd["work"], c_bench["work"]
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


def test_c_bench_fd_frames_and_busload(c_bench_fd: dict[str, Any], c_bench: dict[str, Any],
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
    classical = candump_messages(c_bench["work"] / "candump.log")
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


# ---- hostile traffic from can-utils while the plant runs --------------------------------------

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
def hostile(guest: CanGuest, bench_inputs: dict[str, Any],
            c_bench: dict[str, Any]) -> dict[str, Any]:
    """One guest job: the C bench over vcan0 on the first HOSTILE_PERIODS periods, once per
    case of HOSTILE, with its traffic injected mid-run."""
    work = bench_inputs["work"] / "hostile"
    work.mkdir()
    ref_lines = read_csv(bench_inputs["ref_csv"])[: HOSTILE_PERIODS + 1]
    ref_csv = work / "reference.csv"
    ref_csv.write_text("\n".join(ref_lines) + "\n")
    # a valid VoltageCmd of the clean run (period 100): CRC and counter right, but old
    replay = next(m for m in candump_messages(c_bench["work"] / "candump.log")
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
        work / "realtime", [*bench_inputs["plant_args"], "--realtime", "--duration", "5"],
        [*bench_inputs["ctrl_args"], "--realtime"], ref_csv) + " )")
    script = work / "hostile.sh"
    script.write_text("\n".join(scripts) + "\n")
    r = run(guest, f"sh {shlex.quote(str(script))}",
            f"{len(HOSTILE)} hostile runs and one in real time of {HOSTILE_PERIODS} periods",
            timeout=400)
    return {"result": r, "work": work}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_hostile_traffic(hostile: dict[str, Any], c_bench: dict[str, Any], case: str) -> None:
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
        clean = read_csv(c_bench["work"] / "plant.csv")[: HOSTILE_PERIODS]
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
                                          c_bench: dict[str, Any]) -> None:
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
    clean = read_csv(c_bench["work"] / "plant.csv")[: HOSTILE_PERIODS]
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


def test_realtime_over_vcan(hostile: dict[str, Any]) -> None:
    """Both C nodes in real time (--realtime, 1 kHz of CLOCK_MONOTONIC) over vcan0 in the guest
    for HOSTILE_PERIODS periods: the run completes, with status 0, or 7 when the plant's safety
    policy fired (under emulation a node may miss its periods long enough for the plant's
    timeout: the summary then says so). Its wake-up latencies are the emulator's: printed, not
    asserted."""
    work = hostile["work"] / "realtime"
    exits = dict(line.split() for line in (work / "exit").read_text().splitlines())
    s = summary_lines((work / "plant.out").read_text())
    c = summary_lines((work / "controller.out").read_text())
    fired = s["fault_events"] > 0 or s["zero_periods"] > 0
    assert exits["plant"] == str(EXIT_SAFETY if fired else 0), (exits, s)
    assert exits["controller"] in ("0", str(EXIT_SAFETY)), exits
    assert c["states"] > 0 and s["periods"] > 0
    for node in ("plant", "controller"):
        rt = [ln for ln in (work / f"{node}.out").read_text().splitlines()
              if ln.startswith("RRR_HIL_RT ")]
        assert len(rt) == 1, node
        r = json.loads(rt[0][len("RRR_HIL_RT "):])
        assert r["rt_periods"] > 0
        print(f"  real time over vcan0, {node} (the emulator's latencies, TCG): exit "
              f"{exits[node]}, {r['rt_periods']} periods, wake-up p50 "
              f"{r['rt_latency_p50_us']:.0f} us, p99 {r['rt_latency_p99_us']:.0f} us, max "
              f"{r['rt_latency_max_us']:.0f} us, {r['rt_deadline_misses']} deadline misses")
    print(f"  real time over vcan0: plant faults {s['faults']:#04x}, {s['cmd_missed']} periods "
          f"without a command, {s['zero_periods']} at 0 V; controller: {c['stale']} stale")


# ---- rrr hil bench --interface socketcan and the Python sides over python-can's socketcan ---

#: Seconds of the writing task the Python cases run (their time is mostly Python's start-up and
#: FMPy's under emulation; the whole task runs in the all-C case above). No figures are drawn in
#: the guest (matplotlib took about 30 s there): figures_from_files draws them here.
PY_DURATION = "1"
#: Values of summary.json that time the run (wall clock), not what it computed.
TIMING = {"wall_time", "realtime_factor", "duration_s", "frames_per_second", "per_second"}


def _untimed(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k not in TIMING}
    return value


@pytest.fixture(scope="module")
def python_sides(guest: CanGuest, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """guest_python_sides.py in one Python process in the guest, and meanwhile the same three
    runs here over socketcand (rrr hil bench|controller|plant, the other node started by rrr;
    the emulator runs on one host CPU, these on the other)."""
    out = guest.scratch / "python_sides"
    out.mkdir()
    host = tmp_path_factory.mktemp("socketcand_sides")
    common = ["--duration", PY_DURATION, "--scenario", "ctc", "-q", "--no-figures"]

    def host_runs() -> dict[str, int]:
        t0 = time.monotonic()
        rc = {side: subprocess.run([sys.executable, "-m", "rrr_robot", "hil", side, "--out",
                                    str(host / side), *common], capture_output=True,
                                   timeout=600).returncode
              for side in ("bench", "controller", "plant")}
        print(f"the three runs over socketcand here (meanwhile): {time.monotonic() - t0:.1f} s")
        return rc

    driver = Path(__file__).with_name("guest_python_sides.py")
    with ThreadPoolExecutor(max_workers=1) as pool:
        here = pool.submit(host_runs)
        r = guest.run(f"{shlex.join([sys.executable, str(driver), str(out), PY_DURATION])} "
                      "vcan0 vcan1 $(cut -d' ' -f1 /proc/uptime)", timeout=600)
        host_rc = here.result()
    print(f"python sides in the guest: exit {r.rc}, {r.seconds:.1f} s")
    cases = json.loads((out / "cases.json").read_text()) if (out / "cases.json").exists() \
        else {}
    for name, case in cases.items():
        print(f"  {name}: {case}")
    return {"result": r, "out": out, "cases": cases, "host": host, "host_rc": host_rc}


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


def test_rrr_hil_bench_over_socketcan(python_sides: dict[str, Any],
                                      bench_inputs: dict[str, Any]) -> None:
    """``rrr hil bench --interface socketcan`` in the guest: exit 0, its summary, figures and
    frame log written; its logs equal those of the same C nodes over socketcand here on the
    reference it wrote, bit for bit; its summary.json equals that of ``rrr hil bench`` here
    (socketcand) to SUMMARY_TOLERANCE, and exactly for every count. (The writing reference itself,
    computed with numpy, differs in its last bits between this CPU and the emulated one, which
    has no AVX-512: numpy takes other SIMD code paths; hence the rerun on the guest's file.)"""
    r, out, host = python_sides["result"], python_sides["out"], python_sides["host"]
    assert r.rc == 0, r.stderr[-3000:]
    assert python_sides["cases"]["bench"]["rc"] == 0 and python_sides["host_rc"]["bench"] == 0
    mine = out / "bench"
    for name in ("summary.json", "frames.blf", "frames.rrrcan"):
        assert (mine / name).stat().st_size > 0, name
    figures = host / "figures_of_the_guest_run"
    figures.mkdir()
    drawn = figures_from_files(mine, figures)
    assert sorted(p.name for p in drawn) == sorted(FIGURES)
    assert all(p.stat().st_size > 10_000 for p in drawn)
    ref_csv = mine / "reference.csv"
    row0 = read_csv(ref_csv)[1].split(",")
    rerun = host / "bench_on_guest_reference"
    rerun.mkdir()
    plant = start_plant(q0=[float(x) for x in row0[1:4]], qd0=[float(x) for x in row0[4:7]],
                        log_csv=rerun / "plant.csv")
    with plant, start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                 log_csv=rerun / "controller.csv",
                                 extra=bench_inputs["ctrl_args"]) as ctrl:
        assert ctrl.wait(300)["exit"] == 0 and plant.wait(60)["exit"] == 0
    for name in ("plant.csv", "controller.csv"):
        assert read_csv(mine / name) == read_csv(rerun / name), name
    s, h = (json.loads((d / "summary.json").read_text()) for d in (mine, host / "bench"))
    for key, (rtol, atol) in SUMMARY_TOLERANCE.items():
        assert _close(_untimed(s[key]), _untimed(h[key]), rtol, atol), key
    assert s["controller"]["transport"] == "socketcan"
    assert {k: v for k, v in s["controller"].items() if k not in TRANSPORT_FIELDS} == \
        {k: v for k, v in h["controller"].items() if k not in TRANSPORT_FIELDS}
    bus, hbus = _untimed(s["bus"]), _untimed(h["bus"])
    same = ("frames", "frames_per_period", "tx", "rx", "by_id", "load")
    assert {k: bus[k] for k in same} == {k: hbus[k] for k in same}
    assert framelog.compare(framelog.read_node_log(mine / "frames.rrrcan"),
                            framelog.read_can_log(mine / "frames.blf")) is None


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


@pytest.mark.parametrize("side, node_log", [("controller", "plant.csv"),
                                            ("plant", "controller.csv")])
def test_python_side_over_socketcan(python_sides: dict[str, Any], side: str,
                                    node_log: str) -> None:
    """``rrr hil controller|plant --interface socketcan`` (the FMU under FMPy, python-can's
    socketcan interface) against the C node on vcan0: both exit 0; the Python side's log and the
    C node's equal the all-C run in the guest (rrr hil bench --interface socketcan) and the same
    side's run here over socketcand to < 1e-9 rad (the references differ in their last bits:
    see test_rrr_hil_bench_over_socketcan)."""
    case = python_sides["cases"][side]
    assert (case["rc"], case["node_rc"], case.get("error")) == (0, 0, None), case
    assert python_sides["host_rc"][side] == 0
    mine = python_sides["out"] / side
    python_log = "controller.csv" if side == "controller" else "plant.csv"
    for log in ("plant.csv", "controller.csv"):
        spec = PLANT_LOG if log == "plant.csv" else CONTROLLER_LOG
        a = read_log((mine if log == python_log else mine / "node") / log, spec).rows
        # q, qd and u (plant), q, qd, u, u_n and u_c (controller)
        cols = slice(spec.index("q[1]"), spec.index("zero" if spec is PLANT_LOG else "enable"))
        for other in (python_sides["out"] / "bench", python_sides["host"] / side):
            b = read_log(other / log, spec).rows
            assert a.shape == b.shape and np.abs(a[:, cols] - b[:, cols]).max() < 1e-9, \
                (log, other)



# ---- the CANopen masters against the C plant's three CiA 402 drives over vcan0 ----------------


@pytest.mark.parametrize("master", sorted(CANOPEN_MASTERS))
def test_canopen_master_over_socketcan(python_sides: dict[str, Any], master: str,
                                       tmp_path: Path) -> None:
    """A CANopen master (``rrr hil canopen --interface socketcan``: canopen.Network on
    python-can's socketcan interface) against ``rrr_hil_plant --profile canopen`` on vcan0 in
    the guest, PY_DURATION s of the writing task in lockstep: exit 0, no drive fault; its
    summary.json, logs and frame log written; the plant's and master's logs equal, bit for bit,
    the same master over socketcand here on the reference the guest ran and the co-simulation
    with the PDOs' quantisation; summary.json equals that run's to SUMMARY_TOLERANCE, and the
    frame counts of every identifier but the heartbeats (wall-clock timed) are the same."""
    from dataclasses import replace

    from rrr_robot.core.outputs import ResultSet
    from rrr_robot.hil.canopen.c_master import run_c_master
    from rrr_robot.hil.canopen.drives import pdo_quantisation
    from rrr_robot.hil.canopen.master import run_canopen_master
    from rrr_robot.hil.canopen.results import write_master_results, writing_controller
    from rrr_robot.hil.nodes import PERIOD
    from rrr_robot.hil.results import BenchRun, bench_result, extend_reference
    from rrr_robot.sim.cosim import CosimOptions, run_cosim

    case, out = python_sides["cases"].get(f"canopen_{master}"), python_sides["out"]
    assert case is not None and case["rc"] == 0, (case, python_sides["result"].stderr[-3000:])
    mine = out / f"canopen_{master}"
    for name in ("summary.json", "plant.csv", "controller.csv", "frames.rrrcan", "frames.blf"):
        assert (mine / name).stat().st_size > 0, name
    s = json.loads((mine / "summary.json").read_text())
    assert s["side"] == "canopen" and s["controller"]["transport"] == "socketcan"
    assert s["plant_exit"] == 0 and s["missed_commands"] == 0, s
    assert framelog.compare(framelog.read_node_log(mine / "frames.rrrcan"),
                            framelog.read_can_log(mine / "frames.blf")) is None

    # the same master over socketcand here, on the guest's reference
    z = np.load(out / "canopen_reference.npz")
    wc = writing_controller(None, "ctc")
    ref = replace(extend_reference(wc.ref, float(PY_DURATION)), t=z["t"], q=z["q"], qd=z["qd"],
                  qdd=z["qdd"], x=z["x"])
    wc = replace(wc, ref=ref)
    with ResultSet(tmp_path / "host", kind="hil") as rs:
        if master == "c":
            mrun = run_c_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model,
                                wc.controller_values, rs.staging)
        else:
            mrun = run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model,
                                      wc.gains, rs.staging)
        h = write_master_results(rs, wc, mrun, scenario="ctc", figures=False)
    for name in ("plant.csv", "controller.csv"):
        assert read_csv(mine / name) == read_csv(tmp_path / "host" / name), name

    # the co-simulation with the PDOs' quantisation on that reference: bit for bit
    measure, actuate = pdo_quantisation([float(v) for v in wc.controller_model.kt],
                                        [float(v) for v in wc.model.kt],
                                        [d.rated_torque_mNm for d in mrun.drives])
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

    def counts(summary: dict[str, Any]) -> dict[str, Any]:
        return {i: v["frames"] for i, v in summary["bus"]["by_id"].items()
                if not 0x701 <= int(i, 16) <= 0x77F}

    assert counts(s) == counts(h) and counts(s)["0x080"] == ref.t.shape[0]
    print(f"  CANopen master {master} over vcan0: {ref.t.shape[0]} SYNC periods in "
          f"{case['seconds']:.1f} s in the guest; tip error max "
          f"{1e3 * s['bench']['tip_error_max']:.4f} mm")


def test_canopen_nmt_and_heartbeat_loss_on_vcan(guest: CanGuest, bench_inputs: dict[str, Any],
                                                tmp_path_factory: pytest.TempPathFactory
                                                ) -> None:
    """``rrr_hil_plant --profile canopen`` on vcan0, driven by can-utils' cansend and recorded by
    candump: the three power-on boot-ups, NMT reset node (boot-ups again), NMT start
    (heartbeats in operational, 0x05), node 2 set by an expedited SDO download to monitor a
    master heartbeat (0x1016 sub 1 = node 0x7F, 100 ms) that comes and then stops: node 2 sends
    EMCY 0x8130 with the error register 0x11 once, the others do not; NMT stop (heartbeats
    0x04); the plant then ends on the silence (10 s of it: far above the gaps between two
    cansend processes under emulation on a busy machine). One master heartbeat only: a cansend
    process takes longer than 100 ms to start under emulation, so a train of them would be lost
    between each two (measured: ten sent 20 ms apart, ten losses)."""
    work = guest.scratch / "canopen_nmt"
    work.mkdir()
    w = shlex.quote(str(work))
    plant = shlex.join([str(node_executable("plant")), *bench_inputs["plant_args"],
                        "--profile", "canopen", "--socketcan", "vcan0",
                        "--idle-timeout-ms", "10000"])
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
