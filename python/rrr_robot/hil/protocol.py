"""The CAN bench (hardware in the loop) from Python, with python-can and cantools.

One DBC, ``data/rrr_bench.dbc``, describes every frame; the C nodes' pack/unpack is generated
from the same file (``c_src/hil/gen``). Frames carry AUTOSAR E2E profile 2 protection: CRC-8/
AUTOSAR over bytes 1..7 and the message's DataID in byte 0, a 4-bit alive counter in byte 1.

The C nodes (``rrr_hil_plant``, ``rrr_hil_controller``) are installed with the package in
``rrr_robot/bin`` (or found in ``$RRR_HIL_BIN_DIR``). The plant node is the socketcand server;
python-can's built-in ``socketcand`` interface connects to it (``socketcan`` where the kernel has
AF_CAN). Lockstep protocol (deterministic): the controller sends its heartbeat; the plant
answers with the state of period 0; then per period k the controller sends VoltageCmd(k) and
Sync(k), and the plant advances exactly one period and answers with the state of k + 1.

Main entry points: :func:`run_fmu_controller` (the controller FMU under FMPy against the C plant
node), :func:`run_c_bench` (both C nodes), :func:`quantised_cosim` (the FMPy loop with the DBC's
quantisation, the exact reference of the bench), :func:`register_cli` (``rrr hil``).
"""

from __future__ import annotations

import functools
import json
import logging
import os
import re
import shutil
import subprocess
import tempfile
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from ._arrays import FloatArray
from .errors import RrrError
from .fmus import fmu_path

log = logging.getLogger(__name__)

__all__ = [
    "DATA_IDS",
    "DBC_PATH",
    "FAULT_BITS",
    "BenchRun",
    "FrameError",
    "HilError",
    "NodeProcess",
    "controller_node_args",
    "database",
    "decode",
    "encode",
    "export_reference",
    "node_executable",
    "open_bus",
    "quantise_command",
    "quantise_state",
    "quantised_cosim",
    "register_cli",
    "run_c_bench",
    "run_fmu_controller",
    "start_controller",
    "start_plant",
]

DBC_PATH = Path(__file__).with_name("data") / "rrr_bench.dbc"
PERIOD = 1e-3  # s
#: E2E DataIDs (also in the DBC's comment and c_src/hil/hil_codec.h).
DATA_IDS = {"VoltageCmd": 0x10, "JointState1": 0x21, "JointState2": 0x22, "JointState3": 0x23,
            "PlantStatus": 0x30}
#: Latched fault bits of PlantStatus.Faults.
FAULT_BITS = {"timeout": 1, "crc": 2, "counter": 4, "range": 8, "format": 16, "sync": 32,
              "bus": 64}
NMT_BOOT, NMT_STOPPED, NMT_OPERATIONAL = 0, 4, 5
_REF_HEADER = ["t"] + [f"{s}[{i}]" for s in ("q_ref", "qd_ref", "qdd_ref") for i in (1, 2, 3)]


class HilError(RrrError):
    """A bench node failed, or the bench protocol was violated (names the node and period)."""


class FrameError(HilError, ValueError):
    """A frame that is not a valid bench frame; ``reason`` is 'unknown id', 'wrong DLC' or
    'E2E CRC mismatch'."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


# ---- codec ----------------------------------------------------------------------------------


@functools.cache
def database() -> Any:
    """The bench's cantools database (loaded once)."""
    import cantools

    return cantools.database.load_file(str(DBC_PATH))


def _crc(payload: bytes, name: str) -> int:
    from cantools.autosar.end_to_end import compute_profile2_crc

    return int(compute_profile2_crc(payload, DATA_IDS[name]))


def encode(name: str, signals: Mapping[str, float], *, corrupt_crc: bool = False) -> Any:
    """A ``can.Message`` of message ``name`` with E2E CRC (strict: out-of-range values raise).

    ``corrupt_crc`` flips the CRC (fault injection).
    """
    import can

    msg = database().get_message_by_name(name)
    values = {"Crc": 0, **signals} if name in DATA_IDS else dict(signals)
    data = bytearray(msg.encode(values, strict=True))
    if name in DATA_IDS:
        data[0] = _crc(bytes(data), name) ^ (0xFF if corrupt_crc else 0)
    return can.Message(arbitration_id=msg.frame_id, data=data, is_extended_id=False)


def decode(message: Any) -> tuple[str, dict[str, float]]:
    """Name and physical signal values of a received frame; raises FrameError."""
    import cantools

    try:
        msg = database().get_message_by_frame_id(message.arbitration_id)
    except KeyError:
        raise FrameError(f"id 0x{message.arbitration_id:X} is not a bench frame",
                         "unknown id") from None
    if message.is_extended_id:
        raise FrameError(f"extended id 0x{message.arbitration_id:X}", "unknown id")
    data = bytes(message.data)
    if len(data) != msg.length:
        raise FrameError(f"{msg.name}: {len(data)} bytes, the DBC says {msg.length}", "wrong DLC")
    if msg.name in DATA_IDS and data[0] != _crc(data, msg.name):
        raise FrameError(f"{msg.name}: E2E CRC mismatch", "E2E CRC mismatch")
    try:
        values = msg.decode(data, decode_choices=False)
    except cantools.database.DecodeError as exc:
        raise FrameError(f"{msg.name}: {exc}", "wrong DLC") from exc
    return msg.name, values


def _quantise(name: str, signals: Mapping[str, float]) -> dict[str, float]:
    msg = database().get_message_by_name(name)
    return msg.decode(msg.encode({"Crc": 0, **signals}, strict=True), decode_choices=False)


# ---- the C nodes ----------------------------------------------------------------------------


def node_executable(which: str) -> Path:
    """Path of the C node 'plant' or 'controller' ($RRR_HIL_BIN_DIR first, then the package)."""
    if which not in ("plant", "controller"):
        raise ValueError(f"unknown node {which!r}: expected 'plant' or 'controller'")
    env = os.environ.get("RRR_HIL_BIN_DIR")
    folder = Path(env) if env else Path(__file__).with_name("bin")
    path = folder / f"rrr_hil_{which}"
    if not path.exists():
        raise HilError(f"C node {path} not found: install with 'pip install .' or set "
                       "RRR_HIL_BIN_DIR to a CMake build's c_src/hil folder")
    return path


def export_reference(t: FloatArray, q: FloatArray, qd: FloatArray, qdd: FloatArray,
                     path: Path) -> Path:
    """Write the reference table the C controller reads (every double exactly, %.17g)."""
    rows = np.column_stack([t, q, qd, qdd])
    with Path(path).open("w") as fh:
        fh.write(",".join(_REF_HEADER) + "\n")
        for row in rows:
            fh.write(",".join(f"{v:.17g}" for v in row) + "\n")
    return Path(path)


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


def start_plant(*, listen: str = "127.0.0.1:0", q0: Sequence[float] = (0.0, 0.0, 0.0),
                qd0: Sequence[float] = (0.0, 0.0, 0.0), values: Mapping[str, float] = {},
                log_csv: Path | None = None, extra: Sequence[str] = (),
                fmu: Path | None = None) -> NodeProcess:
    """Start the C plant node as socketcand server on ``listen`` (port 0: any free port, read
    back in ``.port``), on the plant FMU (default: the packaged one, unzipped to a temp dir)."""
    from fmpy import extract

    unzip = Path(extract(str(fmu or fmu_path("plant"))))
    args: list[str] = [str(node_executable("plant")), "--fmu", str(unzip), "--listen", listen,
                       "--q0", _vec(q0), "--qd0", _vec(qd0)]
    for name, v in values.items():
        args += ["--set", f"{name}={float(v):.17g}"]
    if log_csv is not None:
        args += ["--log", str(log_csv)]
    try:
        return NodeProcess("rrr_hil_plant", [*args, *extra], listening=True, cleanup=unzip)
    except BaseException:
        shutil.rmtree(unzip, ignore_errors=True)
        raise


def start_controller(reference_csv: Path, *, connect: str, log_csv: Path | None = None,
                     extra: Sequence[str] = ()) -> NodeProcess:
    """Start the C controller node as socketcand client of ``connect`` (HOST:PORT)."""
    args = [str(node_executable("controller")), "--reference", str(reference_csv),
            "--connect", connect]
    if log_csv is not None:
        args += ["--log", str(log_csv)]
    return NodeProcess("rrr_hil_controller", [*args, *extra], listening=False)


def controller_node_args(values: Mapping[str, float | bool]) -> list[str]:
    """rrr_hil_controller arguments for controller FMU start values (the same names): kp[i],
    kd[i] -> --kp/--kd, feedforward false -> --no-feedforward, model parameters -> --set."""
    args: list[str] = []
    for gain in ("kp", "kd"):
        names = [f"{gain}[{i}]" for i in (1, 2, 3)]
        given = [n for n in names if n in values]
        if given and len(given) != 3:
            raise ValueError(f"{gain}: give all three of {names} or none")
        if given:
            args += [f"--{gain}", _vec([float(values[n]) for n in names])]
    if "feedforward" in values and not values["feedforward"]:
        args.append("--no-feedforward")
    for name, v in values.items():
        if name != "feedforward" and not name.startswith(("kp[", "kd[")):
            args += ["--set", f"{name}={float(v):.17g}"]
    return args


def open_bus(interface: str = "socketcand", *, host: str = "127.0.0.1", port: int = 29536,
             channel: str = "bench0") -> Any:
    """A python-can bus: ``socketcand`` (TCP, to the C node) or ``socketcan`` (channel = vcan0)."""
    import can

    if interface == "socketcand":
        return can.Bus(interface="socketcand", host=host, port=port, channel=channel,
                       tcp_tune=True)
    if interface == "socketcan":
        return can.Bus(interface="socketcan", channel=channel)
    raise ValueError(f"interface must be 'socketcand' or 'socketcan', got {interface!r}")


# ---- runs -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class BenchRun:
    """Signals of a bench run, one row per period (the controller's view: measured q, qd)."""

    t: FloatArray
    q: FloatArray        # (n, 3) plant state (exact doubles for the C plant log)
    qd: FloatArray
    u: FloatArray        # (n, 3) commanded voltage
    plant_summary: dict[str, Any]
    controller_summary: dict[str, Any]


class _StateWaiter:
    """Collects JointState1..3 of one alive counter from a bus (lockstep controller side)."""

    def __init__(self, bus: Any, timeout: float) -> None:
        self.bus = bus
        self.timeout = timeout
        self.status: dict[str, float] = {}
        self.rejected: dict[str, int] = {}

    def wait(self, counter: int) -> tuple[FloatArray, FloatArray]:
        q, qd, have = np.zeros(3), np.zeros(3), set()
        deadline = time.monotonic() + self.timeout
        while len(have) < 3:
            msg = self.bus.recv(timeout=max(0.0, deadline - time.monotonic()))
            if msg is None:
                raise HilError(f"no joint state with counter {counter} within {self.timeout} s")
            try:
                name, sig = decode(msg)
            except FrameError as exc:
                self.rejected[exc.reason] = self.rejected.get(exc.reason, 0) + 1
                continue
            if name == "PlantStatus":
                self.status = sig
            elif name.startswith("JointState") and sig["AliveCounter"] == counter:
                j = int(name[-1]) - 1
                q[j], qd[j] = sig["Q"], sig["Qd"]
                have.add(j)
        return q, qd


def run_fmu_controller(bus: Any, t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
                       qdd_ref: FloatArray, controller_values: Mapping[str, float | bool] = {},
                       timeout: float = 5.0, controller_fmu: Path | None = None) -> BenchRun:
    """Lockstep: the controller FMU (FMPy) drives the plant node on ``bus`` along the reference."""
    from .cosim import CTRL_IN, CTRL_OUT
    from .fmu_slave import FmuSlave

    n = t.shape[0]
    ref = np.hstack([q_ref, qd_ref, qdd_ref])
    q_rec, qd_rec, u_rec = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    waiter = _StateWaiter(bus, timeout)
    with FmuSlave(controller_fmu or fmu_path("controller"), "controller") as ctrl:
        ctrl.initialize(float(t[0]), controller_values)
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_OPERATIONAL, "Counter": 0}))
        for k in range(n):
            q_rec[k], qd_rec[k] = waiter.wait(k & 15)
            c_in.values[:9] = ref[k]
            c_in.values[9:12], c_in.values[12:15] = q_rec[k], qd_rec[k]
            ctrl.set_block(c_in)
            ctrl.get_block(c_out)
            u_rec[k] = c_out.values[:3]
            u = {f"U{i + 1}": float(u_rec[k, i]) for i in range(3)}
            bus.send(encode("VoltageCmd", {"AliveCounter": k & 15, "Enable": 1,
                                           "ResetFault": 0, **u}))
            if k < n - 1:
                bus.send(encode("Sync", {"Cycle": k}))
                ctrl.do_step(PERIOD)
        bus.send(encode("HeartbeatCtrl", {"NmtState": NMT_STOPPED, "Counter": 1}))
    return BenchRun(t=t, q=q_rec, qd=qd_rec, u=u_rec, plant_summary=dict(waiter.status),
                    controller_summary={"rejected": waiter.rejected})


def _read_log(path: Path) -> FloatArray:
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def run_c_bench(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                workdir: Path | None = None, timeout: float = 300.0,
                controller_values: Mapping[str, float | bool] = {}) -> BenchRun:
    """Both C nodes in lockstep over the socketcand transport (plant = server). The plant starts
    at (q_ref[0], qd_ref[0]) on the default robot; the controller uses the default robot and
    gains changed by ``controller_values`` (controller FMU names, e.g. a scenario's)."""
    own = workdir is None
    work = Path(tempfile.mkdtemp(prefix="rrr_hil_")) if workdir is None else Path(workdir)
    try:
        ref_csv = export_reference(t, q_ref, qd_ref, qdd_ref, work / "reference.csv")
        with start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=work / "plant.csv") as plant, \
                start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                 log_csv=work / "controller.csv",
                                 extra=controller_node_args(controller_values)) as ctrl:
            cs = ctrl.wait(timeout)
            if cs["exit"] != 0:  # the plant would wait for a controller that is gone
                plant.close()
                raise HilError(f"bench failed: controller exit {cs['exit']}: "
                               f"{ctrl.stderr.strip()}")
            ps = plant.wait(timeout)
        if cs["exit"] != 0 or ps["exit"] != 0:
            raise HilError(f"bench failed: controller exit {cs['exit']}: {ctrl.stderr.strip()}; "
                           f"plant exit {ps['exit']}: {plant.stderr.strip()}")
        p, c = _read_log(work / "plant.csv"), _read_log(work / "controller.csv")
        return BenchRun(t=p[:, 1], q=p[:, 2:5], qd=p[:, 5:8], u=c[:, [8, 11, 14]],
                        plant_summary=ps, controller_summary=cs)
    finally:
        if own:
            shutil.rmtree(work, ignore_errors=True)


def quantise_state(q_qd: FloatArray) -> FloatArray:
    """(q, qd) as the controller reads them from the JointState frames (the DBC's scaling)."""
    meas = [_quantise(f"JointState{j + 1}", {"AliveCounter": 0, "Q": q_qd[j], "Qd": q_qd[3 + j]})
            for j in range(3)]
    return np.array([m["Q"] for m in meas] + [m["Qd"] for m in meas])


def quantise_command(u: FloatArray) -> FloatArray:
    """u as the plant reads it from a VoltageCmd frame (the DBC's scaling)."""
    cmd = _quantise("VoltageCmd", {"AliveCounter": 0, "Enable": 1, "ResetFault": 0,
                                   **{f"U{i + 1}": float(u[i]) for i in range(3)}})
    return np.array([cmd[f"U{i + 1}"] for i in range(3)])


def quantised_cosim(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
                    plant_values: Mapping[str, float] = {},
                    controller_values: Mapping[str, float | bool] = {}) -> BenchRun:
    """The FMPy co-simulation (cosim.run_cosim) with the bench's quantisation: the plant's q, qd
    pass through JointState and the controller's u through VoltageCmd (cantools, the same DBC).
    This is the arithmetic of the lockstep bench, so the C bench must match it to rounding."""
    from .cosim import CosimOptions, run_cosim

    options = CosimOptions(step=PERIOD, plant_values=plant_values,
                           controller_values=controller_values, measure=quantise_state,
                           actuate=quantise_command)
    r = run_cosim(t, q_ref, qd_ref, qdd_ref, np.zeros_like(q_ref), options)
    return BenchRun(t=t, q=r.q, qd=r.qd, u=r.u, plant_summary={}, controller_summary={})


# ---- command line ---------------------------------------------------------------------------


def _writing_setup(text: str | None, scenario: str) -> tuple[Any, dict[str, float | bool]]:
    """The writing reference and the controller values of a scenario (default robot)."""
    from .writing import WritingJob, controller_fmu_values, prepare

    model, tables, scenarios, ref = prepare(WritingJob(out=Path("."), text=text,
                                                       scenarios=[scenario]))
    return ref, controller_fmu_values(scenarios[0], model, tables["control"])


def _cmd_hil(args: Any) -> int:
    ref, ctrl_values = _writing_setup(args.text, args.scenario)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.side == "export-reference":
        path = export_reference(ref.t, ref.q, ref.qd, ref.qdd, out / "reference.csv")
        print(f"reference: {path} ({ref.t.size} periods)")
        return 0
    if args.side == "plant":
        from .hil_plant import cmd_plant

        return cmd_plant(args, ref, out, ctrl_values)
    if args.side == "bench":
        run = run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=out,
                          controller_values=ctrl_values)
        print(f"C bench: {run.t.size} periods; plant faults {run.plant_summary['faults']}; "
              f"logs in {out}/ (plant.csv, controller.csv)")
        return 0
    # controller: the controller FMU under FMPy against a plant node
    plant = None
    try:
        if args.connect or args.interface == "socketcan":
            # socketcan: the plant node runs elsewhere (rrr_hil_plant --socketcan IF)
            host, _, port = (args.connect or "127.0.0.1:0").rpartition(":")
        else:
            plant = start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=out / "plant.csv")
            host, port = "127.0.0.1", str(plant.port)
        with open_bus(args.interface, host=host, port=int(port), channel=args.channel) as bus:
            run = run_fmu_controller(bus, ref.t, ref.q, ref.qd, ref.qdd, ctrl_values)
        err = np.abs(run.q - ref.q).max()
        print(f"FMU controller vs plant node: {run.t.size} periods, max |q - q_ref| "
              f"{err:.3e} rad, plant status {run.plant_summary}")
        if plant is not None:
            summary = plant.wait()
            print(f"plant node: exit {summary['exit']}, faults {summary.get('faults')}")
    finally:
        if plant is not None:
            plant.close()
    return 0


def register_cli(subparsers: Any) -> None:
    """Add the ``hil`` subcommand to the ``rrr`` command line."""
    p = subparsers.add_parser(
        "hil", help="CAN bench: C nodes, either FMU side over python-can",
        description="Run the writing task on the CAN bench. 'controller': the controller FMU "
        "(FMPy) over python-can against the C plant node (started here unless --connect); "
        "'plant': the plant FMU (FMPy) behind the C supervisor (ctypes) over python-can "
        "against the C controller node (started here with --listen unless --connect; "
        "lockstep only: the Python plant has no real-time mode, use rrr_hil_plant --realtime); "
        "'bench': the C controller node against the C plant node (lockstep, socketcand "
        "transport); 'export-reference': write the reference table the C controller reads.",
    )
    p.add_argument("side", choices=["controller", "plant", "bench", "export-reference"])
    p.add_argument("--text", help="text to write (default: the writing task's default)")
    p.add_argument("--scenario", default="ctc",
                   help="controller scenario (gains, feedforward, model): pd, ctc, mismatch or "
                   "a scenario .toml (default ctc)")
    p.add_argument("--out", default="results/hil", help="output folder (default: results/hil)")
    p.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="python-can interface (default socketcand)")
    p.add_argument("--connect", metavar="HOST:PORT",
                   help="socketcand server of a running node: the plant node for 'controller', "
                   "a controller node started with --listen for 'plant' (default: start one)")
    p.add_argument("--channel", default="bench0",
                   help="socketcand bus name, or the SocketCAN interface (default bench0)")
    p.add_argument("--drop-commands-from", type=int, metavar="K",
                   help="'plant' only, fault injection: VoltageCmd frames of periods >= K do "
                   "not reach the plant (0 V at the 3rd period, timeout latched)")
    p.set_defaults(func=_cmd_hil)
