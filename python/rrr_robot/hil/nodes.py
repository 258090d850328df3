"""The C nodes of the CAN bench as processes, and the python-can buses that talk to them (every
profile: the DBC's and CANopen's).

The C nodes (``rrr_hil_plant``, ``rrr_hil_controller``) are installed with the package in
``rrr_robot/bin`` (or found in ``$RRR_HIL_BIN_DIR``). The plant node is the socketcand server;
python-can's built-in ``socketcand`` interface connects to it (``socketcan`` where the kernel has
AF_CAN). The controller node can also listen (``--listen``) for the Python plant. Over SocketCAN
a bus opened before the plant starts (:func:`boot_up_watch`) sees its boot-up
(:func:`wait_for_boot_up`).

Every parent of nodes (``rrr hil bench``, ``rrr hil canopen --master c``, ``rrr hil
controller|plant`` for the node beside their Python side) waits for them with
:func:`watch_nodes`: it watches all of them, reaps them, reports the progress of one from its
log (:class:`LogProgress`) and, when one ends or stops answering, ends the others within a
bound counted in bench periods (:data:`GRACE_PERIODS`, :data:`STALL_PERIODS`), naming the node
at fault. :func:`quiet_bus_threads` keeps the threads of python-can and canopen from printing a
traceback when a node goes away: the run's own error names the node.
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
import threading
import time
import warnings
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core._package import PACKAGE_DIR
from ..core.outputs import STAGING_PREFIX, atomic_write_text, shown_paths
from ..core.param_names import param_index
from ..core.robot import DEFAULT_SAMPLE_TIME
from ..errors import HilError, TamperedError
from ..sim.fmus import fmu_path
from ..writing.reference_table import write_reference_table
from .channel import DEFAULT_CHANNEL

log = logging.getLogger(__name__)

__all__ = [
    "EXIT_TAMPERED",
    "GRACE_PERIODS",
    "NMT_BOOT",
    "NMT_OPERATIONAL",
    "NMT_STOPPED",
    "PERIOD",
    "STALL_PERIODS",
    "LogProgress",
    "NodeProcess",
    "boot_up_watch",
    "controller_node_args",
    "export_reference",
    "failure_folder",
    "node_executable",
    "open_bus",
    "quiet_bus_threads",
    "set_args",
    "start_controller",
    "start_listening_controller",
    "start_plant",
    "wait_for_boot_up",
    "watch_nodes",
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
#: The C nodes' exit status "peer lost" (RRR_HIL_EXIT_PEER_LOST): the node waited its timeout for
#: a silent peer, or the peer hung up.
EXIT_PEER_LOST = 3
#: The C controller's exit status "tampered input" (RRR_HIL_EXIT_TAMPERED, hil_node.h): a frame
#: the other node never sends (a second of one kind in a period, a wrong length) came.
EXIT_TAMPERED = 8
#: Bench periods the other nodes of a run get to end after one ended (5 s: as long as a node
#: waits for a silent peer, --idle-timeout-ms and --timeout-ms): a node that still runs then has
#: stopped answering and is stopped. After a node ended with "peer lost" (it has waited that long
#: for the other already) the others get PEER_LOST_GRACE_PERIODS (0.5 s).
GRACE_PERIODS = 5000
PEER_LOST_GRACE_PERIODS = 500
#: Bench periods without a new row in a running node's log (once it has begun one; 60 s before
#: its first) after which it has stopped answering: twice the nodes' own 5 s limit on a silent
#: peer, so the node that notices first names it.
STALL_PERIODS = 10_000
STARTUP_PERIODS = 60_000


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
    """A running C node (context manager; ``close()`` is idempotent and stops it). ``log_csv``:
    the CSV log it writes a row to every period (its sign of life for :func:`watch_nodes`)."""

    def __init__(self, name: str, args: Sequence[str], *, listening: bool,
                 cleanup: Path | None = None, log_csv: Path | None = None) -> None:
        self.name = name
        self.args = [str(a) for a in args]
        self.log = log_csv
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

    @property
    def returncode(self) -> int | None:
        """Its exit status (negative: the signal that killed it), None while it runs."""
        rc = self._proc.poll()
        return None if rc is None else int(rc)

    def how_it_ended(self) -> str:
        """'was killed by SIGKILL', 'exited with status 3', 'is still running'."""
        rc = self._proc.poll()
        if rc is None:
            return "is still running"
        return f"was killed by {_signal_name(-rc)}" if rc < 0 else f"exited with status {rc}"

    def stopped_by_signal(self) -> bool:
        """Whether it is stopped (SIGSTOP, SIGTSTP; a debugger) where the system tells it
        (Linux: state T or t in /proc)."""
        try:
            stat = Path(f"/proc/{self.pid}/stat").read_text(encoding="ascii", errors="replace")
        except OSError:
            return False
        return stat.rpartition(")")[2].split()[:1] in (["T"], ["t"])

    def failure(self, what: str, folder: Path | None = None, how: str | None = None
                ) -> HilError:
        """The error of a node that failed: ``what`` happened, which node, how it ended (or
        ``how``), and its output (stderr), which is written to ``folder/<node>.failed.log``
        (else its last line is quoted). TamperedError when it ended with EXIT_TAMPERED."""
        self.close()  # collect its output
        how = how or self.how_it_ended()
        text = self.stderr.strip()
        last = f": {shown_paths(' '.join(text.splitlines()[-1].split()))}" if text else ""
        tail = "" if text else "; it printed nothing"
        if folder is not None:
            path = Path(folder) / f"{self.name}.failed.log"
            try:
                atomic_write_text(path, f"# {' '.join(self.args)}\n# pid {self.pid} {how}\n"
                                  f"{text}\n")
                tail = f"; its output is in {path}" + ("" if text else " (it printed nothing)")
            except OSError as exc:
                why = os.strerror(exc.errno) if exc.errno else str(exc)
                tail = f"; its output could not be kept in {folder} ({why})"
        error = TamperedError if self._proc.poll() == EXIT_TAMPERED else HilError
        return error(f"{what}: the node {self.name} (pid {self.pid}) {how}{last}{tail}")

    def wait(self, timeout: float = 120.0) -> dict[str, Any]:
        """Wait for the exit; returns the node's summary (``RRR_HIL_SUMMARY`` JSON) with
        'exit' and, in real-time mode, the timing statistics under 'rt' (of a node already
        closed: what it printed)."""
        if not self._closed:
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
        """Stop it (SIGTERM, then SIGCONT so that a stopped node handles it, SIGKILL after 5 s)
        and collect its output."""
        if self._closed:
            return
        self._closed = True
        if self._proc.poll() is None:
            self._proc.terminate()
            with contextlib.suppress(OSError):
                self._proc.send_signal(signal.SIGCONT)
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
                           cleanup=unzip, log_csv=log_csv)
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
    return NodeProcess("rrr_hil_controller", [*args, *extra], listening=False, log_csv=log_csv)


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
    return NodeProcess("rrr_hil_controller", [*args, *extra], listening=True, log_csv=log_csv)


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


def _log_size(node: NodeProcess) -> int:
    try:
        return os.stat(node.log).st_size if node.log is not None else -1
    except OSError:
        return -1


def _stuck(nodes: Sequence[NodeProcess], ok: Collection[int], grace: float, stall: float,
           startup: float, poll: LogProgress | None,
           ended: tuple[str, int] | None) -> tuple[NodeProcess, str] | None:
    """Wait until every node has ended (None), or one stopped answering: (it, why). A node
    stopped answering when it still runs ``grace`` s after another ended with a status in
    ``ok`` (PEER_LOST_GRACE_PERIODS after one that lost its peer), or when its log did not grow
    for ``stall`` s (``startup`` s before its first row). After a node that failed otherwise
    (a bad option, a fault of its own) the others are ended: the failure is that node's.
    ``ended``: the other side, not watched here, has ended already (how, its exit status)."""
    start = time.monotonic()
    size = {id(n): _log_size(n) for n in nodes}
    grew = {id(n): start for n in nodes}
    began = {id(n): False for n in nodes}
    first = None if ended is None else (*ended, start)  # the first that ended: how, rc, when
    while True:
        if poll is not None:
            poll.poll()
        now = time.monotonic()
        running = [n for n in nodes if n.running()]
        if not running:
            return None
        for n in nodes:
            if first is None and not n.running():
                first = (f"{n.name} {n.how_it_ended()}", int(n.returncode or 0), now)
        if first is not None:
            how, rc, at = first
            lost = rc == EXIT_PEER_LOST
            bound = PEER_LOST_GRACE_PERIODS * PERIOD if lost else grace
            if now - at > bound:
                if not lost and rc not in ok:
                    for n in running:
                        n.close()
                    return None
                return running[0], f"{how} and it did not end within {bound:g} s"
        for n in running:
            now_size = _log_size(n)
            if now_size != size[id(n)]:
                began[id(n)] = began[id(n)] or size[id(n)] >= 0
                size[id(n)], grew[id(n)] = now_size, now
            limit = stall if began[id(n)] else startup
            if n.log is not None and now - grew[id(n)] > limit:
                return n, f"its log {n.log.name} did not grow for {limit:g} s"
        time.sleep(0.1)


def watch_nodes(nodes: Sequence[NodeProcess], what: str, folder: Path | None = None, *,
                ok: Collection[int] = (0,), poll: LogProgress | None = None,
                grace: float = GRACE_PERIODS * PERIOD, stall: float = STALL_PERIODS * PERIOD,
                startup: float = STARTUP_PERIODS * PERIOD,
                ended: tuple[str, int] | None = None) -> list[dict[str, Any]]:
    """Wait for every node of a run and reap it; returns their summaries (``NodeProcess.wait``)
    in order when each ended with a status in ``ok``. Otherwise the error (``what``: the run
    that failed; the node's output kept in ``folder``) names the node at fault: one that stopped
    answering (still running ``grace`` s after another ended, or its log silent for ``stall`` s;
    it is stopped), else the first killed by a signal, else the first that failed; a node that
    ended with EXIT_TAMPERED gives TamperedError. ``poll`` reports one node's progress.
    ``ended``: a side of the run that is not a node here (the Python side of ``rrr hil
    controller|plant``) has ended: how ("the Python plant lost the controller") and its exit
    status (EXIT_PEER_LOST when it lost the node)."""
    stuck = _stuck(nodes, ok, grace, stall, startup, poll, ended)
    if stuck is not None:
        node, why = stuck
        if node.stopped_by_signal():
            why += "; it was stopped by a signal (SIGSTOP?)"
        for other in nodes:
            other.close()
        raise node.failure(what, folder, how=f"stopped answering ({why}) and was ended")
    summaries = [n.wait(30.0) for n in nodes]
    if all(int(s["exit"]) in ok for s in summaries):
        return summaries
    failed = [n for n, s in zip(nodes, summaries, strict=True) if int(s["exit"]) not in ok]
    killed = [n for n in failed if int(n.returncode or 0) < 0]
    first = [n for n in failed if n.returncode != EXIT_PEER_LOST]  # not those that lost it
    raise (killed or first or failed)[0].failure(what, folder)


@contextlib.contextmanager
def quiet_bus_threads() -> Iterator[list[BaseException]]:
    """For the block: the threads of python-can and canopen (a bus's receive thread "Notifier
    for bus ...", a periodic sender "...Cyclic send task...") that end with an exception when
    their bus fails (a node that went away, a socketcand server's "< error ... >") keep it in the
    yielded list and log it as one DEBUG line instead of printing a traceback, and the ERROR
    lines those libraries log about it become DEBUG lines (shown with -v): the run's own error
    names the node and the cause. Other threads' exceptions are reported as before."""
    kept: list[BaseException] = []
    previous = threading.excepthook

    def hook(args: Any) -> None:
        name = args.thread.name if args.thread is not None else ""
        if args.exc_value is not None and ("Notifier" in name or "Cyclic" in name):
            kept.append(args.exc_value)
            log.debug("%s ended: %s", name, args.exc_value)
            return
        previous(args)

    def demote(record: logging.LogRecord) -> bool:
        if record.levelno > logging.DEBUG:
            record.levelno, record.levelname = logging.DEBUG, "DEBUG"
        return True

    loggers = [logging.getLogger(n) for n in ("can.interfaces.socketcand.socketcand",
                                              "can.notifier", "can.broadcastmanager",
                                              "canopen.network", "canopen.sdo.client")]
    threading.excepthook = hook
    for lg in loggers:
        lg.addFilter(demote)
    try:
        yield kept
    finally:
        threading.excepthook = previous
        for lg in loggers:
            lg.removeFilter(demote)
