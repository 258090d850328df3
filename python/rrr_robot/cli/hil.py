"""``rrr hil``: the writing task on the CAN bench (the C nodes, either FMU side over python-can).

Registered by :mod:`rrr_robot.cli.app`; the library is :mod:`rrr_robot.hil`.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._args import host_port, nonnegative_int, output_path

if TYPE_CHECKING:
    from ..core.model import Model
    from ..core.outputs import ResultSet
    from ..hil.bench import BenchRun
    from ..hil.sides import SideRun
    from ..writing.trajectory import Reference


#: Bounds of --duration (s): a run of the bench holds its logs in memory and on disk.
MAX_DURATION = 3600.0
#: The node's own frame log (hil_framelog.h) in the output folder, and the standard log.
NODE_FRAMES = "frames.rrrcan"
DEFAULT_CAN_LOG = "frames.blf"


def duration_seconds(text: str) -> float:
    """--duration: seconds, finite, > 0 and at most MAX_DURATION."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds expected, got {text!r}") from None
    if not math.isfinite(value) or not 0.0 < value <= MAX_DURATION:
        raise argparse.ArgumentTypeError(f"seconds in (0, {MAX_DURATION:g}] expected, got "
                                         f"{text!r}")
    return value


def bitrate(text: str) -> int:
    """A bit rate in bit/s: an integer >= 1 (the upper bounds are checked by busload)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"bit/s expected (an integer), got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"a bit rate >= 1 bit/s expected, got {value}")
    return value


def spin_us(text: str) -> int:
    """--spin-us: 0 .. 250 us."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"microseconds expected, got {text!r}") from None
    if not 0 <= value <= 250:
        raise argparse.ArgumentTypeError(f"0 to 250 us expected, got {value}")
    return value


def _writing_setup(text: str | None, scenario: str,
                   ) -> tuple[Reference, dict[str, float | bool], Model]:
    """The writing reference, the controller values of a scenario and the model (default
    robot)."""
    from ..writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), text=text,
                                                      scenarios=[scenario]))
    return ref, controller_fmu_values(scenarios[0], model, robot.require_control()), model


def _check_options(args: argparse.Namespace) -> None:
    """What argparse cannot check, before anything is read, run or written."""
    from ..errors import BadInputError

    if args.realtime and args.side != "bench":
        raise BadInputError(f"--realtime: only 'rrr hil bench' runs both C nodes in real time "
                            f"(the {args.side} side runs in lockstep)")
    for name in ("bitrate", "fd", "lockstep", "dbc"):
        if getattr(args, name) not in (None, False):
            raise BadInputError(f"--{name}: an option of 'rrr hil busload'")


def _can_log_target(args: argparse.Namespace, out: Path) -> Path | None:
    """Where the standard frame log goes (None: --no-can-log); refused before the run when its
    format is not .asc/.blf or its folder cannot be written."""
    from ..errors import BadInputError
    from ..hil.framelog import check_can_log_path

    if args.no_can_log:
        if args.can_log is not None:
            raise BadInputError("give --can-log FILE or --no-can-log, not both")
        return None
    target = check_can_log_path(args.can_log if args.can_log is not None
                                else out / DEFAULT_CAN_LOG)
    folder = target.parent if str(target.parent) else Path(".")
    if target.exists() and target.is_dir():
        raise BadInputError(f"--can-log {target}: is a folder")
    if folder.resolve() != out.resolve():
        if folder.exists() and not folder.is_dir():
            raise BadInputError(f"--can-log {target}: {folder} is not a folder")
        if not folder.is_dir():
            raise BadInputError(f"--can-log {target}: the folder {folder} does not exist")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise BadInputError(f"--can-log {target}: the folder {folder} is not writable")
    return target


def _cmd_hil(args: argparse.Namespace) -> int:
    from ..core.outputs import ResultSet, check_folder

    if args.side == "busload":
        return _cmd_busload(args)
    _check_options(args)
    out = check_folder(args.out)  # before anything is read or run
    can_log = None if args.side == "export-reference" else _can_log_target(args, out)
    ref, ctrl_values, model = _writing_setup(args.text, args.scenario)
    if args.duration is not None or args.realtime:
        from ..hil.results import extend_reference

        ref = extend_reference(ref, args.duration or float(ref.t[-1] - ref.t[0]))
    # the nodes write into the result set's staging folder; the logs of the run appear in out
    # together when it ended, and an interrupted or failed run leaves the previous ones as they
    # were (rrr_robot.core.outputs)
    with ResultSet(out, kind="hil") as rs:
        return _run_side(args, ref, ctrl_values, model, rs, out, can_log)


def _cpus() -> tuple[int, int] | None:
    """CPUs for the controller and the plant in real time (two of ours), None with one."""
    mine = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    return (mine[-1], mine[-2]) if len(mine) >= 2 else None


def _run_side(args: argparse.Namespace, ref: Reference, ctrl_values: dict[str, float | bool],
              model: Model, rs: ResultSet, out: Path, can_log: Path | None) -> int:
    """One side of ``rrr hil`` (rrr_robot.hil.sides), its files written into the result set
    (they end up in ``out``)."""
    from ..hil import sides
    from ..hil.bench import RealTime
    from ..hil.nodes import export_reference
    from ._progress import Bars, shown

    work = rs.staging
    if args.side == "export-reference":
        export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv")
        print(f"reference: {out / 'reference.csv'} ({ref.t.size} periods)")
        return 0
    conn = sides.Connection(args.interface, args.connect, args.channel)
    with Bars(shown(args.quiet), unit="period") as bars:
        progress = bars.callback("CAN bench")
        if args.side == "plant":
            side = sides.run_plant_side(ref, ctrl_values, work, conn, frame_log=NODE_FRAMES,
                                        drop_from=args.drop_commands_from, progress=progress,
                                        announce=lambda text: print(text, flush=True))
            _plant_lines(side, ref, out)
        elif args.side == "bench":
            realtime = None
            if args.realtime:
                realtime = RealTime(duration=float(ref.t[-1] - ref.t[0]) + 5.0,
                                    fifo=0 if args.no_fifo else 80, mlock=True, cpus=_cpus(),
                                    spin_us=args.spin_us)
            side = sides.run_bench(ref, ctrl_values, work, frame_log=NODE_FRAMES,
                                   realtime=realtime, progress=progress)
        else:  # controller: the controller FMU under FMPy against a plant node
            side = sides.run_controller_side(ref, ctrl_values, work, conn,
                                             frame_log=NODE_FRAMES, progress=progress)
    if args.side != "bench" and conn.external:
        import numpy as np

        run = side.run
        print(f"{args.side} side against an external node: {run.t.size} periods, max |q - "
              f"q_ref| {np.abs(run.q - ref.q[: run.q.shape[0]]).max():.3e} rad; the other "
              "node keeps its logs (its frame log among them): no summary.json or figures")
        return side.rc
    _results(args, ref, side.run, ctrl_values, model, rs, can_log, side.nodes)
    return side.rc


def _plant_lines(side: SideRun, ref: Reference, out: Path) -> None:
    """What ``rrr hil plant`` prints of the Python plant and the controller node."""
    import numpy as np

    s, cs, run = side.nodes["plant"], side.nodes["controller"], side.run
    err = np.abs(run.q[: ref.q.shape[0]] - ref.q[: run.q.shape[0]]).max()
    print(f"python plant: exit {s['exit']}, {s['periods']} periods, max |q - q_ref| "
          f"{err:.3e} rad, faults latched {s['faults']} (events {s['fault_events']}, "
          f"timeout {s['timeout']}, crc {s['crc']}, counter {s['counter']}, "
          f"range {s['range']}, bus {s['bus']}), periods at 0 V {s['zero_periods']}; "
          f"log {out / 'plant.csv'}")
    if "plant_faults" in cs:
        print(f"controller node: exit {cs['exit']}, plant faults seen {cs['plant_faults']}")


def _results(args: argparse.Namespace, ref: Reference, run: BenchRun,
             ctrl_values: Mapping[str, float | bool], model: Model, rs: ResultSet,
             can_log: Path | None, nodes: Mapping[str, Mapping[str, Any]]) -> None:
    """summary.json, the figures and the standard frame log of a run, into the result set."""
    from ..hil.results import RunInfo, write_results

    info = RunInfo(side=args.side, mode="realtime" if args.realtime else "lockstep",
                   scenario=args.scenario, node_log=NODE_FRAMES, view=_VIEW[args.side])
    summary = write_results(rs, info, ref, run, model, ctrl_values, nodes, can_log=can_log,
                            figures=not args.no_figures)
    _report(summary, rs.folder)


_VIEW = {"bench": "the C controller node's (Tx: its frames, Rx: the plant's)",
         "plant": "the C controller node's (Tx: its frames, Rx: the Python plant's)",
         "controller": "the C plant node's (Tx: its frames, Rx: the FMU controller's)"}


def _report(s: Mapping[str, Any], out: Path) -> None:
    b, d = s["bench"], s["difference_to_unquantised"]
    bus = s["bus"]
    fps = bus.get("frames_per_second")
    print(f"CAN bench ({s['side']}, {s['mode']}, scenario {s['scenario']}): "
          f"{s['reference']['periods']} periods; tip error max {1e3 * b['tip_error_max']:.3f} mm, "
          f"rms {1e3 * b['tip_error_rms']:.3f} mm; max |q - q_ref| "
          f"{max(b['joint_error_max']):.3e} rad")
    print(f"  vs unquantised co-simulation: max |dq| {max(d['q_max_abs']):.3e} rad, max |du| "
          f"{max(d['u_max_abs']):.3e} V, tip error max {1e3 * d['tip_error_max_delta_m']:+.4f} mm")
    f = s["faults"]
    print(f"  plant: faults latched {f.get('faults')}, fault events {f.get('fault_events')}, "
          f"missed commands {s['missed_commands']}")
    print(f"  bus: {bus['frames']} frames ({bus['tx']} Tx, {bus['rx']} Rx), "
          + (f"{fps:.0f} frames/s, " if fps else "")
          + f"{bus['measured_1mbit']['frames_per_period']:.2f} per period, "
          f"{bus['measured_1mbit']['load_percent']:.1f} % of 1 Mbit/s at 1 kHz (schedule worst "
          f"case {bus['schedule_worst_percent_1mbit']:.1f} %)"
          + (f"; frame log {bus['can_log']}" if "can_log" in bus else ""))
    for node, r in (s.get("realtime") or {}).items():
        if isinstance(r, dict):
            print(f"  {node}: wake-up latency p50 {r['p50_us']:.1f} us, p99 {r['p99_us']:.1f} "
                  f"us, p99.9 {r['p999_us']:.1f} us, max {r['max_us']:.1f} us; "
                  f"{r.get('rt_deadline_misses')} deadline misses; {r.get('rt_setup')}")
    print(f"results in {out}/ (summary.json, plant.csv, controller.csv, figures)")


def _cmd_busload(args: argparse.Namespace) -> int:
    import cantools

    from ..hil.busload import check_bitrates, format_report, schedule_load
    from ..hil.protocol import DBC_PATH, database

    rate = args.bitrate if args.bitrate is not None else 1_000_000
    check_bitrates(rate, args.fd)  # before the DBC is read
    if args.dbc is not None:
        try:
            db = cantools.database.load_file(str(args.dbc))
        except (cantools.database.errors.Error, ValueError, KeyError) as exc:
            from ..errors import BadInputError

            raise BadInputError(f"--dbc {args.dbc}: not a DBC cantools reads: "
                           f"{' '.join(str(exc).split())}") from exc
    else:
        db = database()
    load = schedule_load(db, rate, args.fd, lockstep=args.lockstep,
                         dbc_name=str(args.dbc or DBC_PATH))
    print(format_report(load))
    return 0


def register_cli(subparsers: Any) -> None:
    """Add the ``hil`` subcommand to the ``rrr`` command line."""
    p = subparsers.add_parser(
        "hil", help="CAN bench: C nodes, either FMU side over python-can, bus load",
        description="Run the writing task on the CAN bench and write summary.json (the writing "
        "task's metrics, the difference to the unquantised co-simulation of the scenario, "
        "faults, missed commands, bus traffic, real-time latencies), the figures, the nodes' "
        "logs and a frame log (.blf or .asc) into --out. 'bench': the C controller node "
        "against the C plant node (socketcand transport; lockstep, or --realtime); "
        "'controller': the controller FMU (FMPy) over python-can against the C plant node "
        "(started here unless --connect); 'plant': the plant FMU (FMPy) behind the C "
        "supervisor (ctypes) over python-can against the C controller node (started here "
        "with --listen unless --connect; lockstep only); 'export-reference': write the "
        "reference table the C controller reads; 'busload': the load of the DBC's schedule on "
        "a classical CAN or CAN FD bus (its last line: the worst-case load in percent).",
    )
    p.add_argument("side", choices=["controller", "plant", "bench", "export-reference",
                                    "busload"])
    p.add_argument("--text", help="text to write (default: the writing task's default)")
    p.add_argument("--scenario", default="ctc",
                   help="controller scenario (gains, feedforward, model): pd, ctc, mismatch or "
                   "a scenario .toml (default ctc)")
    p.add_argument("--out", default=Path("results/hil"), type=output_path,
                   help="output folder (default: results/hil); its previous logs stay as they "
                   "were unless the run ends")
    p.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="python-can interface (default socketcand)")
    p.add_argument("--connect", metavar="HOST:PORT", type=host_port,
                   help="socketcand server of a running node: the plant node for 'controller', "
                   "a controller node started with --listen for 'plant' (default: start one; "
                   "then the other node keeps its logs and no summary.json is written)")
    p.add_argument("--channel", default="bench0",
                   help="socketcand bus name, or the SocketCAN interface (default bench0)")
    p.add_argument("--drop-commands-from", type=nonnegative_int, metavar="K",
                   help="'plant' only, fault injection: VoltageCmd frames of periods >= K do "
                   "not reach the plant (0 V at the 3rd period, timeout latched)")
    p.add_argument("--duration", type=duration_seconds, metavar="S",
                   help=f"run S seconds (0 < S <= {MAX_DURATION:g}): the reference cut, or held "
                   "at its last pose after its end (default: the reference's 5.9 s)")
    p.add_argument("--realtime", action="store_true",
                   help="'bench' only: both C nodes in real time at 1 kHz (SCHED_FIFO 80, "
                   "mlockall, one CPU each, sleep-then-spin: each when permitted, with a "
                   "warning and the fallback otherwise); latency figures in summary.json")
    p.add_argument("--no-fifo", action="store_true",
                   help="--realtime without SCHED_FIFO (the default scheduler)")
    p.add_argument("--spin-us", type=spin_us, default=100, metavar="N",
                   help="--realtime: sleep until N us before each release, then spin (0: sleep "
                   "only; default 100)")
    p.add_argument("--can-log", type=output_path, metavar="FILE",
                   help=f"the frame log, .blf or .asc (default: {DEFAULT_CAN_LOG} in --out)")
    p.add_argument("--no-can-log", action="store_true",
                   help="no .blf/.asc frame log (the node's own frames.rrrcan is still written)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--bitrate", type=bitrate, metavar="B",
                   help="'busload': the (nominal) bit rate, bit/s (default 1000000)")
    p.add_argument("--fd", type=bitrate, metavar="DATA_BITRATE",
                   help="'busload': CAN FD with bit-rate switch to DATA_BITRATE bit/s")
    p.add_argument("--lockstep", action="store_true",
                   help="'busload': include the lockstep-only frames (Sync)")
    p.add_argument("--dbc", type=Path, metavar="FILE",
                   help="'busload': another DBC (default: the bench's rrr_bench.dbc)")
    p.set_defaults(func=_cmd_hil)
