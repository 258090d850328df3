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
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import cantools
import numpy as np
import pytest
from can_guest import CanGuest, GuestError, GuestUnavailable, Result
from rrr_robot.hil import framelog
from rrr_robot.hil.nodes import (
    controller_node_args,
    export_reference,
    node_executable,
    start_controller,
    start_plant,
)
from rrr_robot.hil.protocol import DBC_PATH
from rrr_robot.sim.fmus import fmu_path
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

#: Summary fields that name or count the transport itself (socketcan has no connection).
TRANSPORT_FIELDS = {"transport", "connects", "disconnects"}
#: Identifiers the guest scripts put on the bus around a run (never used by the bench): a probe
#: that tells when candump is reading, and the end marker after which its log is complete.
PROBE_ID, END_ID = 0x7FE, 0x7FF


@pytest.fixture(scope="module")
def guest(tmp_path_factory: pytest.TempPathFactory) -> Iterator[CanGuest]:
    scratch = tmp_path_factory.mktemp("can_guest")
    try:
        g = CanGuest(scratch).start()
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
    r = run(guest, f"{sys.executable} -c 'import socket; socket.socket(socket.PF_CAN, "
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
    r = run(guest, f"echo from the guest > {target}; uname -r", "scratch")
    assert r.rc == 0 and target.read_text() == "from the guest\n"
    assert r.stdout.strip() == guest.kernel_release
    r = run(guest, "sleep 60 & sleep 60; echo never", "timeout", timeout=2)
    assert r.rc == 137 and r.stdout == "" and r.seconds < 20
    r = run(guest, "pgrep -c -x -f 'sleep 60' || true", "leftovers")  # killed with the job
    assert r.stdout.strip() == "0"


def test_guest_bad_use(guest: CanGuest, tmp_path: Path) -> None:
    """A scratch path with blanks is refused before anything boots; a stopped guest refuses."""
    with pytest.raises(ValueError, match="whitespace"):
        CanGuest(tmp_path / "a b")
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
                   channel: str = "vcan0") -> str:
    """Both C nodes over SocketCAN with candump recording the bus: candump first, the plant next
    (its boot-up heartbeat on the bus tells that it listens), then the controller."""
    q = shlex.quote
    plant = shlex.join([str(node_executable("plant")), *plant_args, "--socketcan", channel,
                        "--log", str(work / "plant.csv"), "--frame-log",
                        str(work / "plant.rrrcan")])
    ctrl = shlex.join([str(node_executable("controller")), "--reference", str(ref_csv),
                       *ctrl_args, "--socketcan", channel, "--log", str(work / "controller.csv"),
                       "--frame-log", str(work / "controller.rrrcan")])
    w = q(str(work))
    return RECORDER + f"""
record_start {channel}
{plant} > {w}/plant.out 2> {w}/plant.err &
P=$!
wait_for ' 702#00' $L || {{ echo "no boot-up heartbeat of the plant" >&2; exit 91; }}
T0=$(cut -d' ' -f1 /proc/uptime)
{ctrl} > {w}/controller.out 2> {w}/controller.err
echo "controller $?" > {w}/exit
wait $P
echo "plant $?" >> {w}/exit
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
    c = np.loadtxt(controller_csv, delimiter=",", skiprows=1)
    n = min(c.shape[0], ref.q.shape[0])
    out = {}
    for j in range(3):
        out[f"rms_e[{j + 1}]"] = float(np.sqrt(np.mean((c[:n, 2 + j] - ref.q[:n, j]) ** 2)))
        for name, col in (("u", 8), ("u_n", 9), ("u_c", 10)):
            out[f"rms_{name}[{j + 1}]"] = float(np.sqrt(np.mean(c[:n, col + 3 * j] ** 2)))
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
    r = run(guest, f"sh {script}", "C bench over vcan0 (with candump)", timeout=240)
    times = (work / "times").read_text().split() if (work / "times").exists() else []
    if times:
        print(f"  the two nodes: {float(times[2]) - float(times[1]):.1f} s in the guest for "
              f"{bench_inputs['periods']} periods")
    host = host_socketcand_bench(bench_inputs, bench_inputs["work"] / "socketcand")
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
            # socketcand server that has no client yet (c_src/hil/README.md)
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
    controller stops reading after the last joint state (c_src/hil/README.md)."""
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
    assert stop["Reason"] == 0 and names[-1] == "HeartbeatCtrl" and decoded[-1]["NmtState"] == 4
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
