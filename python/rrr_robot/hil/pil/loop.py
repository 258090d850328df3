"""Processor in the loop (``rrr hil pil``): the controller firmware (c_src/firmware) in
``qemu-system-arm`` against the C plant node, in the DBC profile's lockstep.

The firmware speaks SLCAN, the serial-line protocol of CANable-type USB adapters, on its UART,
which QEMU serves as a TCP socket; python-can's ``slcan`` interface opens it
(``channel="socket://127.0.0.1:PORT"``) as it would open an adapter, and two python-can
notifiers pass every frame between it and the plant node's socketcand server, unchanged. The
bench's time base is the firmware's Sync, as with the C controller node: the plant integrates
one period per Sync. QEMU runs with ``-icount shift=0`` (one instruction, 1 ns of virtual
time), so the firmware counts the instructions of its law on the board's timer.

The firmware's other UARTs are files: its controller log (the C node's --log format) and its
instruction counts; its console (the summary line, ``RRR_HIL_SUMMARY``) is QEMU's stdout. The
run block (gains, model, reference) is loaded into its flash with QEMU's generic loader. Both
processes are watched with :func:`rrr_robot.hil.nodes.watch_nodes`.
"""

from __future__ import annotations

import contextlib
import shutil
import socket
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...core.outputs import atomic_path
from ...errors import HilError
from ..dbc.protocol import EXIT_SAFETY, frame_id
from ..logs.specs import CONTROLLER_LOG, PLANT_LOG, read_log
from ..nodes import (
    NMT_STOPPED,
    LogProgress,
    NodeProcess,
    Progress,
    failure_folder,
    open_bus,
    quiet_bus_threads,
    start_plant,
    watch_nodes,
)
from ..results import BenchRun
from .firmware import RUN_BLOCK_ADDRESS, Target, write_run_block

__all__ = ["INSTRUCTIONS_LOG", "PilRun", "open_slcan", "qemu_command", "qemu_executable",
           "run_pil", "start_firmware"]

#: The firmware's instruction counts (its timing UART): k, law, period (instructions).
INSTRUCTIONS_LOG = "instructions.csv"
#: The run block written for QEMU's loader.
RUN_BLOCK = "run_block.bin"
#: Seconds to wait for QEMU's SLCAN socket to accept.
CONNECT_TIMEOUT = 20.0


@dataclass(frozen=True)
class PilRun:
    """A processor-in-the-loop run: the exit status (the plant's first, then the firmware's),
    the bench run, the nodes' summaries (the firmware's as "controller"), the firmware's
    instruction counts, one row per period: (law, period's work), and the state it measured
    each period (its log's q, qd: the JointState frames' values)."""

    rc: int
    run: BenchRun
    nodes: dict[str, Mapping[str, Any]]
    instructions: FloatArray
    measured: tuple[FloatArray, FloatArray]


def qemu_executable() -> str:
    """qemu-system-arm on PATH; HilError saying how to install it otherwise."""
    path = shutil.which("qemu-system-arm")
    if path is None:
        raise HilError("rrr hil pil runs the firmware in qemu-system-arm, which is not on PATH "
                       "(Debian: apt-get install qemu-system-arm)")
    return path


def _qemu_path(path: Path) -> str:
    """A path in a QEMU option: its commas doubled (QEMU's escape)."""
    return str(path).replace(",", ",,")


def qemu_command(target: Target, image: Path, run_block: Path, port: int, log: Path,
                 instructions: Path) -> list[str]:
    """The QEMU command of a run: the target's board, -icount shift=0, semihosting (the
    firmware's exit status becomes QEMU's), the run block at its flash address and the four
    UARTs: SLCAN on TCP PORT (server), the controller log, the console (stdout), the
    instruction counts."""
    return [qemu_executable(), "-M", target.machine, "-display", "none", "-monitor", "none",
            "-icount", "shift=0", "-semihosting-config", "enable=on,target=native",
            "-kernel", _qemu_path(image),
            "-device", f"loader,file={_qemu_path(run_block)},addr=0x{RUN_BLOCK_ADDRESS:08x}",
            "-serial", f"tcp:127.0.0.1:{port},server=on,wait=off,nodelay=on",
            "-serial", f"file:{_qemu_path(log)}", "-serial", "file:/dev/stdout",
            "-serial", f"file:{_qemu_path(instructions)}"]


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_firmware(target: Target, image: Path, run_block: Path, log: Path,
                   instructions: Path) -> tuple[NodeProcess, int]:
    """QEMU running ``image`` with ``run_block`` in its flash (qemu_command), as a node
    process whose log is the controller log, and the TCP port of its SLCAN line."""
    port = _free_port()
    return NodeProcess(target.image.removesuffix(".elf"),
                       qemu_command(target, image, run_block, port, log, instructions),
                       listening=False, log_csv=log), port


def open_slcan(port: int, qemu: NodeProcess) -> Any:
    """python-can's slcan bus on QEMU's SLCAN socket (it opens the channel at 1 Mbit/s), once
    QEMU accepts connections."""
    import can

    deadline = time.monotonic() + CONNECT_TIMEOUT
    while True:
        try:
            bus = can.Bus(interface="slcan", channel=f"socket://127.0.0.1:{port}",
                          bitrate=1_000_000, sleep_after_open=0.0)
        except can.CanError as exc:
            if not qemu.running():
                raise qemu.failure("qemu-system-arm ended before its SLCAN line was up") from exc
            if time.monotonic() > deadline:
                raise HilError(f"qemu-system-arm did not accept the SLCAN connection on port "
                               f"{port} within {CONNECT_TIMEOUT:g} s: {exc}") from exc
            time.sleep(0.05)
            continue
        # each frame is a small write: without TCP_NODELAY, Nagle's algorithm holds the next one
        # until QEMU's delayed ACK (40 ms on Linux), one stall per period. pyserial's socket://
        # port keeps its socket in _socket and has no option for it.
        sock = getattr(getattr(bus, "serialPortOrig", None), "_socket", None)
        if isinstance(sock, socket.socket):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return bus


class _Forward:
    """A python-can listener that sends every frame it receives on to another bus; ``done``
    (the firmware's side): after the controller's last frame, its heartbeat "stopped", the SLCAN
    channel is closed (``C``), which ends the firmware."""

    def __init__(self, to: Any, done: Any = None) -> None:
        self.to, self.done = to, done
        self.last_id = frame_id("HeartbeatCtrl")

    def __call__(self, msg: Any) -> None:
        self.to.send(msg)
        if (self.done is not None and msg.arbitration_id == self.last_id and len(msg.data) >= 1
                and msg.data[0] == NMT_STOPPED):
            self.done.close()  # python-can's slcan: writes "C" (the line stays open)


@contextlib.contextmanager
def _bridge(slcan: Any, plant: Any) -> Iterator[None]:
    """Both directions forwarded by python-can notifiers for the block."""
    import can

    up = can.Notifier(slcan, [_Forward(plant, done=slcan)], timeout=0.1)
    down = can.Notifier(plant, [_Forward(slcan)], timeout=0.1)
    try:
        yield
    finally:
        up.stop()
        down.stop()


def _status(plant: Mapping[str, Any], firmware: Mapping[str, Any]) -> int:
    rc = int(plant.get("exit", 0))
    return rc if rc != 0 else int(firmware.get("exit", 0))


def run_pil(target: Target, image: Path, t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
            qdd_ref: FloatArray, controller_values: Mapping[str, float | bool], work: Path, *,
            frame_log: str, progress: Progress | None = None) -> PilRun:
    """The firmware ``image`` of ``target`` in QEMU against the C plant node (started here at
    (q_ref[0], qd_ref[0]), its frame log ``frame_log``), lockstep along the reference with the
    controller FMU's start values ``controller_values`` (gains, feedforward, model: as the
    controller node takes them). Logs in ``work``: plant.csv, controller.csv (the firmware's),
    INSTRUCTIONS_LOG, the plant's frame log and the run block. A run that completed while the
    safety policy fired is a run; any other non-zero status raises (watch_nodes)."""
    import can

    qemu_executable()  # before anything starts
    work = Path(work)
    n = int(t.shape[0])
    block = work / RUN_BLOCK
    write_run_block(block, t, q_ref, qd_ref, qdd_ref, controller_values)
    with atomic_path(work / "plant.csv") as plant_log, \
            atomic_path(work / "controller.csv") as ctrl_log, \
            atomic_path(work / INSTRUCTIONS_LOG) as counts, \
            atomic_path(work / frame_log) as frames, \
            quiet_bus_threads(), \
            start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=plant_log,
                        frame_log=frames) as plant:
        qemu, port = start_firmware(target, image, block, ctrl_log, counts)
        with qemu:
            slcan = open_slcan(port, qemu)
            try:
                plant_bus = open_bus("socketcand", host="127.0.0.1", port=int(plant.port or 0))
                try:
                    with _bridge(slcan, plant_bus):
                        fs, ps = watch_nodes([qemu, plant], "the processor-in-the-loop bench "
                                             "failed", failure_folder(work),
                                             ok=(0, EXIT_SAFETY),
                                             poll=LogProgress(ctrl_log, n, progress))
                finally:
                    with contextlib.suppress(can.CanError, OSError):
                        plant_bus.shutdown()
            finally:
                with contextlib.suppress(can.CanError, OSError):
                    slcan.shutdown()
        p, c = read_log(plant_log, PLANT_LOG), read_log(ctrl_log, CONTROLLER_LOG)
        counted = np.loadtxt(counts, delimiter=",", skiprows=1, ndmin=2)
    if p.rows.shape[0] != n or c.rows.shape[0] != n or counted.shape[0] != n:
        raise HilError(f"the run logged {p.rows.shape[0]} plant, {c.rows.shape[0]} controller "
                       f"and {counted.shape[0]} instruction rows of {n} periods")
    run = BenchRun(t=p.col("t"), q=p.group("q"), qd=p.group("qd"), u=c.group("u"),
                   plant_summary=ps, controller_summary=fs, u_n=c.group("u_n"),
                   u_c=c.group("u_c"))
    return PilRun(_status(ps, fs), run, {"plant": ps, "controller": fs}, counted[:, 1:3],
                  (c.group("q"), c.group("qd")))
