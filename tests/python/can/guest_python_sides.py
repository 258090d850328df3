"""The Python cases of test_bench_transports.py over SocketCAN, run by ONE Python process inside
the CAN test guest (Python starts slowly under emulation: its imports take many seconds there).

    guest_python_sides.py OUT DURATION CHANNEL FD_CHANNEL [UPTIME_AT_START]

Runs, one after the other, on the SocketCAN interface CHANNEL, for DURATION seconds of the
writing task (scenario ctc), each in a folder of OUT:

- ``bench``: ``rrr hil bench --interface socketcan --no-figures`` (both C nodes; summary, frame
  log; the figures of its files are drawn on the host, where Python and matplotlib are fast);
- ``bench_fd``: the same on FD_CHANNEL (an interface with MTU 72) with ``--fd``: CAN FD frames;
- ``bench_fault``: the same with a VoltageCmd of a wrong CRC put on the bus at period 200 (the
  safety policy fires: exit status 7);
- ``controller``: the C plant node on CHANNEL, then ``rrr hil controller --interface socketcan``
  (the controller FMU under FMPy over python-can's socketcan interface) once the plant's
  boot-up heartbeat is on the bus; the C plant's logs go to ``controller/node``;
- ``plant``: ``rrr hil plant --interface socketcan`` (the plant FMU behind the C supervisor)
  and the C controller node, started when the Python plant's boot-up heartbeat is on the bus;
  the C controller's logs go to ``plant/node``.
- ``canopen_python``: ``rrr hil canopen --interface socketcan`` (the Python CANopen master on
  python-can's socketcan interface) against the C plant's three CiA 402 drives, which it
  starts; the reference it ran goes to ``canopen_reference.npz``.

Writes OUT/cases.json: each case's exit statuses and seconds. The nodes' stdout and stderr go
to files beside their logs.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import can
from rrr_robot.cli.app import main as rrr
from rrr_robot.hil.dbc.protocol import frame_id
from rrr_robot.hil.nodes import (
    NodeProcess,
    controller_node_args,
    node_executable,
    start_plant,
    wait_for_boot_up,
)
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare


def boot_up_bus(channel: str) -> can.BusABC:
    return can.Bus(interface="socketcan", channel=channel,
                   can_filters=[{"can_id": 0x702, "can_mask": 0x7FF, "extended": False}])


def inject_bad_crc(channel: str, injected: dict[str, Any], listening: threading.Event) -> None:
    """Once the bench's Sync of period INJECT_AT is on the bus, send one VoltageCmd (0x100) of
    eight zero bytes (a wrong CRC); says in ``injected`` when, or why not."""
    try:
        with can.Bus(interface="socketcan", channel=channel,
                     can_filters=[{"can_id": 0x80, "can_mask": 0x7FF, "extended": False}]) as bus:
            listening.set()
            deadline = time.monotonic() + 300
            while time.monotonic() < deadline:
                msg = bus.recv(1.0)
                if msg is not None and int.from_bytes(msg.data[:4], "little") >= INJECT_AT:
                    bus.send(can.Message(arbitration_id=0x100, data=bytes(8),
                                         is_extended_id=False))
                    injected["injected_after_sync"] = int.from_bytes(msg.data[:4], "little")
                    return
            injected["error"] = f"no Sync of period {INJECT_AT}"
    except BaseException as exc:  # reported in cases.json
        injected["error"] = repr(exc)
        listening.set()


#: Period after whose Sync the bad frame goes on the bus (of the 501 of a 0.5 s run).
INJECT_AT = 200
#: The CANopen masters run against the C plant node (``rrr_hil_plant --profile canopen``) over
#: SocketCAN: kind -> the rrr command (``--channel``, ``--out`` and the duration are added).
CANOPEN_MASTERS = {"python": ["hil", "canopen", "--interface", "socketcan"],
                   "c": ["hil", "canopen", "--master", "c", "--interface", "socketcan"]}


def main(argv: list[str]) -> int:
    out, duration, channel, fd_channel = Path(argv[0]), argv[1], argv[2], argv[3]
    t_start = time.monotonic()
    cases: dict[str, Any] = {}
    if len(argv) > 4:  # the guest's uptime when the process was started: the imports' time
        cases["imports_s"] = float(Path("/proc/uptime").read_text().split()[0]) - float(argv[4])
    common = ["--duration", duration, "--scenario", "ctc", "-q"]

    t0 = time.monotonic()
    rc = rrr(["hil", "bench", "--interface", "socketcan", "--channel", channel,
              "--out", str(out / "bench"), "--no-figures", *common])
    cases["bench"] = {"rc": rc, "seconds": time.monotonic() - t0}

    t0 = time.monotonic()
    rc = rrr(["hil", "bench", "--interface", "socketcan", "--channel", fd_channel, "--fd",
              "--out", str(out / "bench_fd"), "--no-figures", *common])
    cases["bench_fd"] = {"rc": rc, "seconds": time.monotonic() - t0}

    # the same bench with a VoltageCmd of a wrong CRC put on the bus at period 200 (what
    # `cansend CHANNEL 100#0000000000000000` does): the run completes, the safety policy fired
    t0 = time.monotonic()
    injected: dict[str, Any] = {}
    listening = threading.Event()
    injector = threading.Thread(target=inject_bad_crc, args=(channel, injected, listening))
    injector.start()
    listening.wait(60)
    rc = rrr(["hil", "bench", "--interface", "socketcan", "--channel", channel,
              "--out", str(out / "bench_fault"), "--no-figures", *common])
    injector.join(60)
    cases["bench_fault"] = {"rc": rc, "seconds": time.monotonic() - t0, **injected}

    # the controller FMU against the C plant node on the bus
    model, robot, scenarios, ref = prepare(WritingJob(out=out, scenarios=["ctc"]))
    values = controller_fmu_values(scenarios[0], model, robot.require_control())
    node = out / "controller" / "node"
    node.mkdir(parents=True)
    t0 = time.monotonic()
    with boot_up_bus(channel) as watch, \
            start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=node / "plant.csv",
                        frame_log=node / "frames.rrrcan", socketcan=channel) as plant:
        wait_for_boot_up(watch, plant, frame_id("HeartbeatPlant"))
        rc = rrr(["hil", "controller", "--interface", "socketcan", "--channel", channel,
                  "--out", str(out / "controller"), "--no-figures", *common])
        ps = plant.wait(120)
    (node / "plant.out").write_text(plant.stdout)
    (node / "plant.err").write_text(plant.stderr)
    cases["controller"] = {"rc": rc, "node_rc": ps["exit"], "seconds": time.monotonic() - t0}

    # the Python plant against the C controller node, started on the plant's boot-up heartbeat
    node = out / "plant" / "node"
    node.mkdir(parents=True)
    assert rrr(["hil", "export-reference", "--out", str(node), *common]) == 0
    started: dict[str, Any] = {}

    def controller_on_boot_up() -> None:
        try:
            with boot_up_bus(channel) as bus:
                ready.set()
                wait_for_boot_up(bus, None, frame_id("HeartbeatPlant"), timeout=300)
            started["node"] = NodeProcess("rrr_hil_controller", [
                str(node_executable("controller")), "--reference", str(node / "reference.csv"),
                "--socketcan", channel, "--log", str(node / "controller.csv"),
                "--frame-log", str(node / "frames.rrrcan"), *controller_node_args(values)],
                listening=False)
        except BaseException as exc:  # reported below
            started["error"] = repr(exc)
            ready.set()

    ready = threading.Event()
    watcher = threading.Thread(target=controller_on_boot_up)
    t0 = time.monotonic()
    watcher.start()
    ready.wait(60)
    rc = rrr(["hil", "plant", "--interface", "socketcan", "--channel", channel,
              "--out", str(out / "plant"), "--no-figures", *common])
    watcher.join(60)
    ctrl: NodeProcess | None = started.get("node")
    cs = ctrl.wait(120) if ctrl is not None else {"exit": None}
    if ctrl is not None:
        (node / "controller.out").write_text(ctrl.stdout)
        (node / "controller.err").write_text(ctrl.stderr)
    cases["plant"] = {"rc": rc, "node_rc": cs["exit"], "seconds": time.monotonic() - t0,
                      "error": started.get("error")}

    # the CANopen masters (CANOPEN_MASTERS) against the C plant's three CiA 402 drives on
    # CHANNEL, and the reference they ran (computed here: its last bits are this CPU's)
    import numpy as np
    from rrr_robot.hil.canopen.results import writing_controller
    from rrr_robot.hil.results import extend_reference

    ref = extend_reference(writing_controller(None, "ctc").ref, float(duration))
    np.savez(out / "canopen_reference.npz", t=ref.t, q=ref.q, qd=ref.qd, qdd=ref.qdd, x=ref.x)
    for kind, argv in CANOPEN_MASTERS.items():
        t0 = time.monotonic()
        rc = rrr([*argv, "--channel", channel, "--out", str(out / f"canopen_{kind}"),
                  "--no-figures", *common])
        cases[f"canopen_{kind}"] = {"rc": rc, "seconds": time.monotonic() - t0}
    cases["total_s"] = time.monotonic() - t_start
    (out / "cases.json").write_text(json.dumps(cases, indent=1))
    subprocess.run(["sync"], check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
