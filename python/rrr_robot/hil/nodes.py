"""The C nodes of the CAN bench as processes, and the python-can buses that talk to them (every
profile: the DBC's and CANopen's).

The C nodes (``rrr_hil_plant``, ``rrr_hil_controller``) are installed with the package in
``rrr_robot/bin`` (or found in ``$RRR_HIL_BIN_DIR``). The plant node is the socketcand server;
python-can's built-in ``socketcand`` interface connects to it (``socketcan`` where the kernel has
AF_CAN). The controller node can also listen (``--listen``) for the Python plant. Over SocketCAN
a bus opened before the plant starts (:func:`boot_up_watch`) sees its boot-up
(:func:`wait_for_boot_up`); :func:`wait_node` reports a node's progress from its log
(:class:`LogProgress`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import os
import re
import shutil
import signal
import subprocess
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core._package import PACKAGE_DIR
from ..core.outputs import STAGING_PREFIX, atomic_write_text
from ..core.param_names import param_index
from ..core.robot import DEFAULT_SAMPLE_TIME
from ..errors import HilError
from ..sim.fmus import fmu_path
from ..writing.reference_table import write_reference_table
from .channel import DEFAULT_CHANNEL

log = logging.getLogger(__name__)

__all__ = [
    "NMT_BOOT",
    "NMT_OPERATIONAL",
    "NMT_STOPPED",
    "PERIOD",
    "LogProgress",
    "NodeProcess",
    "boot_up_watch",
    "controller_node_args",
    "export_reference",
    "failure_folder",
    "node_executable",
    "open_bus",
    "set_args",
    "start_controller",
    "start_listening_controller",
    "start_plant",
    "wait_for_boot_up",
    "wait_node",
]

#: s: the period of the bench's C nodes, RRR_SAMPLE_TIME_DEFAULT (rrr_control.h, 1 ms), the
#: package's default sample time; a reference for the bench must be sampled at it.
PERIOD = DEFAULT_SAMPLE_TIME
#: Heartbeat NMT state of a node that has booted (CANopen's NMT state numbers, which the DBC's
#: heartbeats carry too).
NMT_BOOT = 0
#: Heartbeat NMT state of a stopped node.
NMT_STOPPED = 4
#: Heartbeat NMT state of an operational node.
NMT_OPERATIONAL = 5
#: Progress of a run: progress(periods done, periods in all).
Progress = Callable[[int, int], None]


def node_executable(which: str) -> Path:
    """Path of the C node 'plant' or 'controller' ($RRR_HIL_BIN_DIR first, then the package)."""
    if which not in ("plant", "controller"):
        raise ValueError(f"unknown node {which!r}: expected 'plant' or 'controller'")
    env = os.environ.get("RRR_HIL_BIN_DIR")
    folder = Path(env) if env else PACKAGE_DIR / "bin"
    path = folder / f"rrr_hil_{which}"
    if not path.exists():
        raise HilError(f"C node {path} not found: install with 'pip install .' or set "
                       "RRR_HIL_BIN_DIR to a CMake build's c_src/hil folder")
    return path


def export_reference(t: FloatArray, q: FloatArray, qd: FloatArray, qdd: FloatArray,
                     path: Path, tip: tuple[FloatArray, FloatArray, FloatArray] | None = None,
                     ) -> Path:
    """Write the reference table the C controller reads, in the reference FMU's format
    (writing.reference_table: 19 columns, every double exactly); the tip's columns are ``tip``
    (x, xd, xdd of the writing reference) or the default robot's forward kinematics. It must be
    sampled at the bench's period PERIOD (HilError otherwise)."""
    steps = np.diff(np.asarray(t, dtype=float))
    if steps.size and not np.allclose(steps, PERIOD, rtol=1e-9, atol=1e-12):
        raise HilError(f"the CAN bench's nodes run at {PERIOD:g} s: the reference is sampled at "
                       f"{float(steps[0]):g} s (the robot file's [control] sample_time)")
    return write_reference_table(path, t, q, qd, qdd, tip)  # atomically (core.outputs)


def failure_folder(work: Path) -> Path:
    """Where the log of a node that failed goes: the output folder when ``work`` is a result
    set's staging folder (which goes with the failed run), else ``work`` itself."""
    work = Path(work)
    return work.parent if work.name.startswith(STAGING_PREFIX) else work


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class NodeProcess:
    """A running C node (context manager; ``close()`` is idempotent and stops it)."""

    def __init__(self, name: str, args: Sequence[str], *, listening: bool,
                 cleanup: Path | None = None) -> None:
        self.name = name
        self.args = [str(a) for a in args]
        self.port: int | None = None
        self._cleanup = cleanup
        self._closed = False
        self.stdout = ""
        self.stderr = ""
        log.debug("starting %s", " ".join(self.args))
        self._proc = subprocess.Popen(self.args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True)
        if listening:
            line = self._proc.stdout.readline() if self._proc.stdout else ""
            m = re.search(r"listening on [\d.]+:(\d+)", line)
            if m is None:
                self.close()
                raise HilError(f"{name} did not start listening: {line.strip()} "
                               f"{self.stderr.strip()}")
            self.port = int(m.group(1))

    def running(self) -> bool:
        """Whether the process has not ended yet."""
        return self._proc.poll() is None

    @property
    def pid(self) -> int:
        return int(self._proc.pid)

    def died(self, grace: float = 0.5) -> bool:
        """Whether the process ended by a signal (waiting up to ``grace`` s for its end)."""
        try:
            self._proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            return False
        return self._proc.returncode < 0

    def how_it_ended(self) -> str:
        """'was killed by SIGKILL', 'exited with status 3', 'is still running'."""
        rc = self._proc.poll()
        if rc is None:
            return "is still running"
        return f"was killed by {_signal_name(-rc)}" if rc < 0 else f"exited with status {rc}"

    def failure(self, what: str, folder: Path | None = None) -> HilError:
        """The error of a node that failed: ``what`` happened, which node, how it ended, and
        its output (stderr), which is written to ``folder/<node>.failed.log`` (else its last
        line is quoted)."""
        self.close()  # collect its output
        how = self.how_it_ended()
        text = self.stderr.strip()
        last = f": {' '.join(text.splitlines()[-1].split())}" if text else ""
        tail = "" if text else "; it printed nothing"
        if folder is not None:
            path = Path(folder) / f"{self.name}.failed.log"
            try:
                atomic_write_text(path, f"# {' '.join(self.args)}\n# pid {self.pid} {how}\n"
                                  f"{text}\n")
                tail = f"; its output is in {path}" + ("" if text else " (it printed nothing)")
            except OSError as exc:
                tail = f"; its output could not be kept ({exc.strerror or exc})"
        return HilError(f"{what}: the node {self.name} (pid {self.pid}) {how}{last}{tail}")

    def wait(self, timeout: float = 120.0) -> dict[str, Any]:
        """Wait for the exit; returns the node's summary (``RRR_HIL_SUMMARY`` JSON) with
        'exit' and, in real-time mode, the timing statistics under 'rt'."""
        try:
            out, err = self._proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.close()
            raise HilError(f"{self.name} did not finish within {timeout} s") from None
        self.stdout += out
        self.stderr += err
        summary: dict[str, Any] = {"exit": self._proc.returncode}
        for line in self.stdout.splitlines():
            if line.startswith("RRR_HIL_SUMMARY "):
                summary |= json.loads(line[len("RRR_HIL_SUMMARY "):])
            elif line.startswith("RRR_HIL_RT "):
                summary["rt"] = json.loads(line[len("RRR_HIL_RT "):])
        summary["exit"] = self._proc.returncode
        self._closed = True
        self._remove_cleanup()
        return summary

    def _remove_cleanup(self) -> None:
        if self._cleanup is not None:
            shutil.rmtree(self._cleanup, ignore_errors=True)
            self._cleanup = None

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                out, err = self._proc.communicate(timeout=5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                out, err = self._proc.communicate()
        else:
            out, err = self._proc.communicate()
        self.stdout += out or ""
        self.stderr += err or ""
        self._remove_cleanup()

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        if not getattr(self, "_closed", True):
            warnings.warn(f"{self.name} node was not closed", ResourceWarning, stacklevel=2)
            self.close()


def _vec(v: Sequence[float]) -> str:
    return ",".join(f"{float(x):.17g}" for x in v)


def set_args(values: Mapping[str, float | bool]) -> list[str]:
    """``--set NAME=VALUE`` arguments of a C node for model parameters; the names must be rows of
    the C parameter table (rrr_params.h), as the nodes' --set expects (HilError otherwise)."""
    args: list[str] = []
    for name, v in values.items():
        if param_index(name) < 0:
            raise HilError(f"--set {name}: not a model parameter of the C parameter table "
                           "(rrr_params.h: d1, a2, a3, d2, d3, g, p[k], kt[i], f[i,k], w[i,k], "
                           "b[i], u_max)")
        args += ["--set", f"{name}={float(v):.17g}"]
    return args


def start_plant(*, listen: str = "127.0.0.1:0", q0: Sequence[float] = (0.0, 0.0, 0.0),
                qd0: Sequence[float] = (0.0, 0.0, 0.0), values: Mapping[str, float] = {},
                log_csv: Path | None = None, extra: Sequence[str] = (),
                fmu: Path | None = None, frame_log: Path | None = None,
                socketcan: str | None = None) -> NodeProcess:
    """Start the C plant node as socketcand server on ``listen`` (port 0: any free port, read
    back in ``.port``), or on the SocketCAN interface ``socketcan`` (e.g. vcan0: then wait for
    its boot-up heartbeat with :func:`wait_for_boot_up` before starting a controller), on the
    plant FMU (default: the packaged one, unzipped to a temp dir); ``frame_log``: its log of
    every frame (rrr_robot.hil.logs.frames)."""
    from ..core.archives import extract_to_temp

    unzip = extract_to_temp(fmu or fmu_path("plant"), "FMU", prefix="rrr-fmu-")
    link = ["--socketcan", socketcan] if socketcan else ["--listen", listen]
    args: list[str] = [str(node_executable("plant")), "--fmu", str(unzip), *link,
                       "--q0", _vec(q0), "--qd0", _vec(qd0)]
    args += set_args(values)
    if log_csv is not None:
        args += ["--log", str(log_csv)]
    if frame_log is not None:
        args += ["--frame-log", str(frame_log)]
    try:
        return NodeProcess("rrr_hil_plant", [*args, *extra], listening=not socketcan,
                           cleanup=unzip)
    except BaseException:
        shutil.rmtree(unzip, ignore_errors=True)
        raise


def start_controller(reference_csv: Path, *, connect: str = "", log_csv: Path | None = None,
                     extra: Sequence[str] = (), frame_log: Path | None = None,
                     socketcan: str | None = None) -> NodeProcess:
    """Start the C controller node as socketcand client of ``connect`` (HOST:PORT), or on the
    SocketCAN interface ``socketcan``."""
    if not socketcan and not connect:
        raise ValueError("start_controller: give connect=HOST:PORT or socketcan=INTERFACE")
    link = ["--socketcan", socketcan] if socketcan else ["--connect", connect]
    args = [str(node_executable("controller")), "--reference", str(reference_csv), *link]
    if log_csv is not None:
        args += ["--log", str(log_csv)]
    if frame_log is not None:
        args += ["--frame-log", str(frame_log)]
    return NodeProcess("rrr_hil_controller", [*args, *extra], listening=False)


def start_listening_controller(reference_csv: Path, *, listen: str = "127.0.0.1:0",
                               log_csv: Path | None = None,
                               extra: Sequence[str] = (),
                               frame_log: Path | None = None) -> NodeProcess:
    """Start the C controller node as socketcand server on ``listen`` (port 0: any free port,
    read back in ``.port``); it waits for the plant's boot-up heartbeat."""
    args = [str(node_executable("controller")), "--reference", str(reference_csv),
            "--listen", listen]
    if log_csv is not None:
        args += ["--log", str(log_csv)]
    if frame_log is not None:
        args += ["--frame-log", str(frame_log)]
    return NodeProcess("rrr_hil_controller", [*args, *extra], listening=True)


def controller_node_args(values: Mapping[str, float | bool]) -> list[str]:
    """rrr_hil_controller arguments for controller FMU start values (the same names): kp[i],
    kd[i] -> --kp/--kd, feedforward false -> --no-feedforward, model parameters (names of the C
    parameter table) -> --set; any other name raises HilError."""
    args: list[str] = []
    for gain in ("kp", "kd"):
        names = fv.names("controller", gain)
        given = [n for n in names if n in values]
        if given and len(given) != 3:
            raise ValueError(f"{gain}: give all three of {names} or none")
        if given:
            args += [f"--{gain}", _vec([float(values[n]) for n in names])]
    if "feedforward" in values and not values["feedforward"]:
        args.append("--no-feedforward")
    return args + set_args({name: v for name, v in values.items()
                            if name != "feedforward" and not name.startswith(("kp[", "kd["))})


def open_bus(interface: str = "socketcand", *, host: str = "127.0.0.1", port: int = 29536,
             channel: str = DEFAULT_CHANNEL) -> Any:
    """A python-can bus: ``socketcand`` (TCP, to the C node) or ``socketcan`` (channel = vcan0)."""
    import can

    if interface == "socketcand":
        return can.Bus(interface="socketcand", host=host, port=port, channel=channel,
                       tcp_tune=True)
    if interface == "socketcan":
        return can.Bus(interface="socketcan", channel=channel)
    raise ValueError(f"interface must be 'socketcand' or 'socketcan', got {interface!r}")


def wait_for_boot_up(bus: Any, node: NodeProcess | None, boot_id: int,
                     timeout: float = 60.0) -> None:
    """Wait for the plant's boot-up heartbeat ``boot_id`` (NMT state 0; the DBC's
    HeartbeatPlant, or the CANopen profile's boot-up of a drive, 0x700 + its node id) on ``bus``
    (a python-can bus opened before the plant started): on SocketCAN a frame sent before a node
    has bound its socket is lost to it, and the plant listens once it has sent this. HilError
    when ``node`` ends first or nothing comes within ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = bus.recv(timeout=0.2)
        if (msg is not None and msg.arbitration_id == boot_id and len(msg.data) >= 1
                and msg.data[0] == NMT_BOOT):
            return
        if node is not None and not node.running():
            raise node.failure("the plant node ended before it was on the bus")
    raise HilError(f"no boot-up heartbeat of the plant node within {timeout:g} s")


@contextlib.contextmanager
def boot_up_watch(socketcan: str | None, boot_id: int, can_fd: bool = False) -> Iterator[Any]:
    """A python-can bus on ``socketcan`` that receives only the plant's boot-up ``boot_id``
    (:func:`wait_for_boot_up`; ``can_fd``: CAN FD frames too), opened before the plant starts
    (None without SocketCAN)."""
    if not socketcan:
        yield None
        return
    import can

    try:
        bus = can.Bus(interface="socketcan", channel=socketcan, fd=can_fd,
                      can_filters=[{"can_id": boot_id, "can_mask": 0x7FF, "extended": False}])
    except (OSError, can.CanError) as exc:
        hint = (" (this kernel has no AF_CAN: use the socketcand transport; docs/socketcan.md)"
                if getattr(exc, "errno", None) == errno.EAFNOSUPPORT else "")
        raise HilError(f"cannot open the SocketCAN interface {socketcan}: {exc}{hint}") from exc
    try:
        yield bus
    finally:
        bus.shutdown()


class LogProgress:
    """Reports the rows a node has written to its --log CSV (its periods done) while it runs:
    ``poll()`` reads what was appended since the last call (up to the node's stdio buffer)."""

    def __init__(self, path: Path, total: int, progress: Progress | None) -> None:
        self.path, self.total, self.progress = Path(path), total, progress
        self._offset = 0
        self._rows = -1  # the header line

    def poll(self) -> None:
        if self.progress is None:
            return
        try:
            with open(self.path, "rb") as fh:
                fh.seek(self._offset)
                chunk = fh.read()
        except OSError:
            return
        self._offset += len(chunk)
        self._rows += chunk.count(b"\n")
        self.progress(max(0, min(self._rows, self.total)), self.total)


def wait_node(node: NodeProcess, timeout: float, poll: LogProgress | None) -> dict[str, Any]:
    """node.wait(timeout), reporting progress every 0.2 s."""
    if poll is None or poll.progress is None:
        return node.wait(timeout)
    deadline = time.monotonic() + timeout
    while node.running() and time.monotonic() < deadline:
        poll.poll()
        time.sleep(0.2)
    poll.poll()
    return node.wait(max(1.0, deadline - time.monotonic()))
