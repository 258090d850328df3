"""``rrr hil``: the writing task on the CAN bench (the C nodes, either FMU side over python-can).

Registered by :mod:`rrr_robot.cli.app`; the library is :mod:`rrr_robot.hil`.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..hil import PROFILES
from ..hil.channel import DEFAULT_CHANNEL
from ._args import (
    add_verbosity_arguments,
    command_parser,
    host_port,
    nonnegative_int,
    output_path,
    positive_int,
    quiet,
)

if TYPE_CHECKING:
    from ..core.model import Model
    from ..core.outputs import ResultSet
    from ..hil.dbc.sides import SideRun
    from ..hil.results import BenchRun
    from ..writing.trajectory import Reference


#: Bounds of --duration (s): a run of the bench holds its logs in memory and on disk.
MAX_DURATION = 3600.0
#: The node's own frame log (hil_framelog.h) in the output folder, and the standard log.
NODE_FRAMES = "frames.rrrcan"
DEFAULT_CAN_LOG = "frames.blf"
#: --spin-us without the option: sleep until 100 us before each release, then spin.
DEFAULT_SPIN_US = 100


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


def sync_period_ms(text: str) -> float:
    """--sync-period-ms: a finite period in (0, 1000] ms."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"ms expected (a number), got {text!r}") from None
    if not 0.0 < value <= 1000.0:
        raise argparse.ArgumentTypeError(f"a SYNC period in (0, 1000] ms expected, got {text}")
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


def _add_rt_tuning(group: argparse._ArgumentGroup, before: str) -> None:
    """--no-fifo and --spin-us of a real-time run (the spin ends at each ``before``)."""
    group.add_argument("--no-fifo", action="store_true",
                       help="with --realtime: the default scheduler instead of SCHED_FIFO")
    group.add_argument("--spin-us", type=spin_us, metavar="N",
                       help=f"with --realtime: sleep until N us before each {before}, then spin "
                       f"(0: sleep only; default {DEFAULT_SPIN_US})")


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

    if not getattr(args, "realtime", False):
        for option, given in (("--no-fifo", getattr(args, "no_fifo", False)),
                              ("--spin-us", getattr(args, "spin_us", None) is not None)):
            if given:
                raise BadInputError(f"{option}: an option of 'rrr hil bench --realtime'")
    if getattr(args, "fd", None) is True and args.interface != "socketcan":
        raise BadInputError("--fd: CAN FD needs --interface socketcan (an interface with MTU "
                            "72, e.g. vcan1): the socketcand protocol carries classical CAN "
                            "frames only")


def _can_log_target(args: argparse.Namespace, out: Path) -> Path | None:
    """Where the standard frame log goes (None: --no-can-log); refused before the run when its
    format is not .asc/.blf or its folder cannot be written."""
    from ..errors import BadInputError
    from ..hil.logs.frames import check_can_log_path

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
    """``rrr hil bench|controller|plant|export-reference``."""
    from ..core.outputs import ResultSet, check_folder

    _check_options(args)
    out = check_folder(args.out)  # before anything is read or run
    if getattr(args, "mcap", False):
        from ..core.mcap_log import require_mcap

        require_mcap()  # without the mcap package: refused before the run
    can_log = None if args.side == "export-reference" else _can_log_target(args, out)
    ref, ctrl_values, model = _writing_setup(args.text, args.scenario)
    realtime = getattr(args, "realtime", False)
    if args.duration is not None or realtime:
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
    """One side of ``rrr hil`` (rrr_robot.hil.dbc.sides), its files written into the result set
    (they end up in ``out``)."""
    from ..hil.dbc import sides
    from ..hil.dbc.bench import RealTime
    from ..hil.nodes import export_reference
    from ._progress import Bars, shown

    work = rs.staging
    if args.side == "export-reference":
        export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv",
                         (ref.x, ref.xd, ref.xdd))
        print(f"reference: {out / 'reference.csv'} ({ref.t.size} periods)")
        return 0
    conn = (sides.Connection() if args.side == "bench"
            else sides.Connection(args.interface, args.connect, args.channel))
    with Bars(shown(quiet(args)), unit="period") as bars:
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
                                    spin_us=DEFAULT_SPIN_US if args.spin_us is None
                                    else args.spin_us)
            side = sides.run_bench(ref, ctrl_values, work, frame_log=NODE_FRAMES,
                                   realtime=realtime, progress=progress,
                                   socketcan=args.channel if args.interface == "socketcan"
                                   else None, can_fd=args.fd)
        else:  # controller: the controller FMU under FMPy against a plant node
            side = sides.run_controller_side(ref, ctrl_values, work, conn,
                                             frame_log=NODE_FRAMES, progress=progress)
    if args.side != "bench" and conn.external:
        import numpy as np

        run = side.run
        print(f"{args.side} side against an external node: {run.t.size} periods, max |q - "
              f"q_ref| {np.abs(run.q - ref.q[: run.q.shape[0]]).max():.3e} rad; the other "
              "node keeps its logs (its frame log among them): no summary.json or figures")
        return _status(side.rc)
    _results(args, ref, side.run, ctrl_values, model, rs, can_log, side.nodes)
    return _status(side.rc)


def _status(rc: int) -> int:
    """The exit status of ``rrr hil``, said when it is not 0 (docs/can-bench.md, "Exit
    statuses")."""
    from ..hil.dbc.protocol import EXIT_SAFETY

    if rc == EXIT_SAFETY:
        print(f"exit status {rc}: the run completed, but the safety policy fired (a fault "
              "latched or 0 V forced: see the plant's faults above)", file=sys.stderr)
    elif rc != 0:
        print(f"exit status {rc}: a node ended early (docs/can-bench.md, Exit statuses)",
              file=sys.stderr)
    return rc


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
    from ..hil.dbc.results import RunInfo, write_results

    info = RunInfo(side=args.side,
                   mode="realtime" if getattr(args, "realtime", False) else "lockstep",
                   scenario=args.scenario, node_log=NODE_FRAMES, view=_VIEW[args.side])
    summary = write_results(rs, info, ref, run, model, ctrl_values, nodes, can_log=can_log,
                            figures=not args.no_figures, mcap=args.mcap)
    _report(summary, rs.folder)


_VIEW = {"bench": "the C controller node's (Tx: its frames, Rx: the plant's)",
         "pil": "the C plant node's (Tx: its frames, Rx: the firmware's)",
         "plant": "the C controller node's (Tx: its frames, Rx: the Python plant's)",
         "controller": "the C plant node's (Tx: its frames, Rx: the FMU controller's)"}


def _bus_lines(bus: Mapping[str, Any]) -> list[str]:
    """The bus traffic of a run and its loads, each named by its meaning (summary.json
    ``bus``); frames per second only in real time (a lockstep run has no wall clock)."""
    from ..hil.busload import format_loads

    fps = bus.get("frames_per_second")
    return [f"  bus: {bus['frames']} frames ({bus['tx']} Tx, {bus['rx']} Rx), "
            f"{bus['frames_per_period']:.2f} per period"
            + (f", {fps:.0f} per second" if fps else "")
            + (f"; frame log {bus['can_log']}" if "can_log" in bus else ""),
            f"  bus {format_loads(bus['load'], bus.get('load_fd'))}"]


def _report(s: Mapping[str, Any], out: Path) -> None:
    b, d = s["bench"], s["difference_to_unquantised"]
    print(f"CAN bench ({s['side']}, {s['mode']}, scenario {s['scenario']}): "
          f"{s['reference']['periods']} periods; tip error max {1e3 * b['tip_error_max']:.3f} mm, "
          f"rms {1e3 * b['tip_error_rms']:.3f} mm; max |q - q_ref| "
          f"{max(b['joint_error_max']):.3e} rad")
    unq = s["unquantised_cosim"]
    print(f"  difference to the unquantised co-simulation: max |dq| {max(d['q_max_abs']):.3e} "
          f"rad, max |du| {max(d['u_max_abs']):.3e} V; tip error max "
          f"{1e3 * b['tip_error_max']:.4f} mm on the bench against "
          f"{1e3 * unq['tip_error_max']:.4f} mm unquantised (bench - unquantised "
          f"{1e3 * d['tip_error_max_delta_m']:+.4f} mm)")
    f = s["faults"]
    print(f"  plant: faults latched {f.get('faults')}, fault events {f.get('fault_events')}, "
          f"missed commands {s['missed_commands']}")
    print("\n".join(_bus_lines(s["bus"])))
    for node, r in (s.get("realtime") or {}).items():
        if isinstance(r, dict):
            print(f"  {node}: wake-up latency p50 {r['p50_us']:.1f} us, p99 {r['p99_us']:.1f} "
                  f"us, p99.9 {r['p999_us']:.1f} us, max {r['max_us']:.1f} us; "
                  f"{r.get('rt_deadline_misses')} deadline misses; {r.get('rt_setup')}")
    print(f"results in {out}/ (summary.json, plant.csv, controller.csv, figures)")


def _cmd_pil(args: argparse.Namespace) -> int:
    """``rrr hil pil``: the controller firmware under QEMU against the C plant node."""
    from dataclasses import replace

    from ..core.outputs import ResultSet, check_folder
    from ..hil.canopen.results import writing_controller
    from ..hil.dbc.results import RunInfo
    from ..hil.pil.firmware import M4F, M7, find_image
    from ..hil.pil.loop import RUN_BLOCK, run_pil
    from ..hil.pil.results import double_law_difference, write_pil_results
    from ..hil.results import extend_reference
    from ._progress import Bars, shown

    out = check_folder(args.out)
    if args.mcap:
        from ..core.mcap_log import require_mcap

        require_mcap()
    can_log = _can_log_target(args, out)
    target = M4F if args.float else M7
    image = find_image(args.firmware, target)
    wc = writing_controller(args.text, args.scenario)
    if args.duration is not None:
        wc = replace(wc, ref=extend_reference(wc.ref, args.duration))
    with ResultSet(out, kind="hil") as rs:
        with Bars(shown(quiet(args)), unit="period") as bars:
            run = run_pil(target, image, wc.ref.t, wc.ref.q, wc.ref.qd, wc.ref.qdd,
                          wc.controller_values, rs.staging, frame_log=NODE_FRAMES,
                          progress=bars.callback(f"firmware {target.image} in QEMU"))
        double = (double_law_difference(run, wc.ref, wc.controller_model, wc.gains)
                  if target.law == "float" else None)
        info = RunInfo(side="pil", mode="lockstep", scenario=args.scenario,
                       node_log=NODE_FRAMES, view=_VIEW["pil"])
        summary = write_pil_results(rs, info, wc.ref, run, wc.model, wc.controller_values,
                                    target, image, (rs.staging / RUN_BLOCK).stat().st_size,
                                    can_log=can_log, figures=not args.no_figures,
                                    mcap=args.mcap, double_law=double)
        _report(summary, rs.folder)
        print("\n".join(_target_lines(summary)))
    return _status(run.rc)


def _target_lines(s: Mapping[str, Any]) -> list[str]:
    """What ``rrr hil pil`` prints of summary.json's target (and of the float law)."""
    t, b = s["target"], s["bench"]
    law, period = (t["instructions_per_period"][k] for k in ("law", "period"))
    share = t["share_of_1ms_period"]
    lines = [f"  target: {t['core']}: flash {t['flash_bytes'] / 1024:.1f} kB, RAM "
             f"{t['ram_bytes'] / 1024:.1f} kB (stack {t['stack_used_bytes']} bytes used, "
             f"painted); instructions per period (QEMU -icount: instructions, not cycles): "
             f"law median {law['median']:.0f}, max {law['max']:.0f}; the period's work median "
             f"{period['median']:.0f}, max {period['max']:.0f}",
             f"  at {share['clock_hz'] / 1e6:.0f} MHz and one instruction per cycle (an "
             f"optimistic bound) the law takes at most {100 * share['law_max']:.2f} % of a 1 ms "
             f"period, the period's work {100 * share['period_max']:.2f} %"]
    d = s.get("difference_to_double_law")
    if d is not None:
        unq = s["unquantised_cosim"]
        lines.append(f"  {t['law_arithmetic']} law against librrr's double law on the same "
                     f"frames: max |du| {max(d['u_max_abs']):.3e} V; tip error max "
                     f"{1e3 * b['tip_error_max']:.4f} mm against {1e3 * unq['tip_error_max']:.4f}"
                     f" mm of the double closed loop without the bench's quantisation")
    return lines


def node_ids(text: str) -> tuple[int, int, int]:
    """--node-ids: three distinct CANopen node ids 1..127, comma-separated."""
    try:
        ids = tuple(int(v) for v in text.split(","))
    except ValueError:
        ids = ()
    if len(ids) != 3 or len(set(ids)) != 3 or not all(1 <= i <= 127 for i in ids):
        raise argparse.ArgumentTypeError(f"three distinct node ids 1..127 expected (a,b,c), "
                                         f"got {text!r}")
    return (ids[0], ids[1], ids[2])


def _cmd_canopen(args: argparse.Namespace) -> int:
    """``rrr hil canopen``: the Python CANopen master against the plant's three drives."""
    from ..core.outputs import ResultSet, check_folder
    from ..hil.canopen.c_master import run_c_master
    from ..hil.canopen.drives import DEFAULT_NODE_IDS
    from ..hil.canopen.master import run_canopen_master
    from ..hil.canopen.results import write_master_results, writing_controller
    from ._progress import Bars, shown

    realtime = _canopen_realtime(args)
    out = check_folder(args.out)
    wc = writing_controller(args.text, args.scenario)
    if args.duration is not None:
        from dataclasses import replace

        from ..hil.results import extend_reference

        wc = replace(wc, ref=extend_reference(wc.ref, args.duration))
    ref = wc.ref
    with ResultSet(out, kind="hil") as rs:
        with Bars(shown(quiet(args)), unit="period") as bars:
            ids = args.node_ids or DEFAULT_NODE_IDS
            if args.master == "c":
                mrun = run_c_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model,
                                    wc.controller_values, rs.staging, node_ids=ids,
                                    timeout=args.timeout,
                                    progress=bars.callback("CANopen master (C)"),
                                    interface=args.interface, channel=args.channel,
                                    realtime=realtime)
            else:
                mrun = run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd,
                                          wc.controller_model, wc.gains, rs.staging,
                                          node_ids=ids, timeout=args.timeout,
                                          progress=bars.callback("CANopen master"),
                                          interface=args.interface, channel=args.channel,
                                          realtime=realtime)
        s = write_master_results(rs, wc, mrun, scenario=args.scenario,
                                 figures=not args.no_figures)
    b, unq = s["bench"], s["unquantised_cosim"]
    drives = ", ".join(str(d.node_id) for d in mrun.drives)
    print(f"CANopen master ({args.master}; drives {drives}, {s['mode']}, "
          f"scenario {s['scenario']}): {s['reference']['periods']} SYNC periods in "
          f"{mrun.run.wall_time:.2f} s; tip error max {1e3 * b['tip_error_max']:.3f} mm, rms "
          f"{1e3 * b['tip_error_rms']:.3f} mm (unquantised {1e3 * unq['tip_error_max']:.3f} mm); "
          f"max |q - q_ref| {max(b['joint_error_max']):.3e} rad")
    print(f"  drives: faults {s['faults'].get('faults')}, RPDO timeouts "
          f"{s['missed_commands']}; rated torque "
          f"{', '.join(str(d.rated_torque_mNm) for d in mrun.drives)} mN m")
    print("\n".join(_bus_lines(s["bus"])))
    rt = s.get("realtime")
    if rt is not None:
        d, sp, jit = rt["drives"], rt["drives"]["sync_period"], rt["drives"]["sync_jitter"]
        rpdo = rt.get("drive_rpdo_timeout_syncs")
        print(f"  real time ({rt['sync_source']} SYNC every {rt['sync_period_ms']:g} ms, master "
              f"heartbeat {rt['master_heartbeat_ms']} ms, drives' consumer "
              f"{rt['drive_consumer_ms']} ms"
              f"{'' if rpdo is None else f', RPDO timeout {rpdo} SYNCs'}): SYNC period at the "
              f"drives min "
              f"{sp['min_us']:.1f} / median {sp['median_us']:.1f} / max {sp['max_us']:.1f} us "
              f"(jitter p99 {jit['p99_us']:.1f}, max {jit['max_us']:.1f} us); "
              f"{d['deadline_misses']} deadline misses (RPDO after the next SYNC)")
        m = rt.get("master", {})
        if "wake_up" in m:  # the C master's clock
            w = m["wake_up"]
            print(f"  master: wake-up latency p50 {w['p50_us']:.1f} us, p99 {w['p99_us']:.1f} "
                  f"us, max {w['max_us']:.1f} us; {m['rt_deadline_misses']} deadline misses, "
                  f"{m['late_tpdos']} SYNCs whose TPDOs came after the next; {m['setup']}")
        elif "setup" in m:
            print(f"  master: {m['setup']}")
    print(f"results in {out}/ (summary.json, plant.csv, controller.csv, frames.rrrcan, "
          f"frames.blf{'' if args.no_figures else ', figures'})")
    return 0


def _canopen_realtime(args: argparse.Namespace) -> Any:
    """The CanopenRealTime of ``rrr hil canopen --realtime`` (None: lockstep); its options
    without --realtime, and those of the other master, are refused."""
    from ..errors import BadInputError
    from ..hil.canopen.realtime import CONSUMER_MS, CanopenRealTime

    given = {"--no-fifo": args.no_fifo, "--spin-us": args.spin_us is not None,
             "--consumer-ms": args.consumer_ms is not None,
             "--rpdo-timeout": args.rpdo_timeout is not None}
    for option, refused in given.items():
        if refused and not args.realtime:
            raise BadInputError(f"{option}: an option of 'rrr hil canopen --realtime'")
    if args.master == "python" and given["--spin-us"]:
        raise BadInputError("--spin-us: the C master's clock (--master c); the Python master's "
                            "SYNC comes from python-can's periodic sender, which sleeps only")
    if not args.realtime:
        return None
    return CanopenRealTime(fifo=0 if args.no_fifo else 80,
                           spin_us=DEFAULT_SPIN_US if args.spin_us is None else args.spin_us,
                           consumer_ms=CONSUMER_MS if args.consumer_ms is None
                           else args.consumer_ms, rpdo_timeout=args.rpdo_timeout)


def _cmd_busload(args: argparse.Namespace) -> int:
    """``rrr hil busload``: the schedule of the profile's package (``busload``), whichever."""
    from ..hil.busload import BusloadOptions, format_report, profile_load

    options = BusloadOptions(args.bitrate if args.bitrate is not None else 1_000_000, args.fd,
                             lockstep=args.lockstep, dbc=args.dbc,
                             sync_period_ms=args.sync_period_ms)
    print(format_report(profile_load(args.profile, options)))
    return 0


# ---- the parsers: one per action, each with only its own options ----------------------------
# Option groups that several actions share are added by one function each (python-can's
# add_bus_arguments), so an action never lists an option it would ignore: another action's
# option is argparse's "unrecognized arguments" error (exit 2).


def add_reference_arguments(p: argparse.ArgumentParser) -> None:
    """What the run follows: the text, the scenario, the duration, and where it writes."""
    g = p.add_argument_group("writing task")
    g.add_argument("--text", help="text to write (default: the writing task's default)")
    g.add_argument("--scenario", default="ctc",
                   help="controller scenario (gains, feedforward, model): pd, ctc, mismatch or "
                   "a scenario .toml (default ctc)")
    g.add_argument("--duration", type=duration_seconds, metavar="S",
                   help=f"run S seconds (0 < S <= {MAX_DURATION:g}): the reference cut, or held "
                   "at its last pose after its end (default: the reference's 5.9 s)")
    p.add_argument("--out", default=Path("results/hil"), type=output_path,
                   help="output folder (default: results/hil); its previous logs stay as they "
                   "were unless the run ends")


def add_bus_arguments(p: argparse.ArgumentParser) -> None:
    """How the Python side reaches the other node (python-can)."""
    g = p.add_argument_group("bus (python-can)")
    g.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="python-can interface (default socketcand)")
    g.add_argument("--connect", metavar="HOST:PORT", type=host_port,
                   help="socketcand server of a node started elsewhere (default: start the "
                   "other node here; with --connect it keeps its own logs and no summary.json "
                   "is written)")
    g.add_argument("--channel", default=DEFAULT_CHANNEL,
                   help="socketcand bus name, or the SocketCAN interface (default %(default)s)")


def add_node_bus_arguments(p: argparse.ArgumentParser) -> None:
    """The bus of both C nodes (``bench`` only)."""
    g = p.add_argument_group("bus")
    g.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="socketcand: the plant node serves the socketcand protocol on loopback "
                   "TCP, the controller connects (no kernel CAN needed; the default); "
                   "socketcan: both nodes on the SocketCAN interface --channel")
    g.add_argument("--channel", default="vcan0",
                   help="with --interface socketcan: the interface (default vcan0)")
    g.add_argument("--fd", action="store_true",
                   help="with --interface socketcan: every frame as a CAN FD frame with "
                   "bit-rate switch, same identifiers and data (the interface needs MTU 72, "
                   "e.g. vcan1; docs/socketcan.md)")


def add_result_arguments(p: argparse.ArgumentParser) -> None:
    """The files of a run beside summary.json: the frame log and the figures."""
    g = p.add_argument_group("results")
    g.add_argument("--can-log", type=output_path, metavar="FILE",
                   help=f"the frame log, .blf or .asc (default: {DEFAULT_CAN_LOG} in --out)")
    g.add_argument("--no-can-log", action="store_true",
                   help="no .blf/.asc frame log (the node's own frames.rrrcan is still written)")
    g.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    g.add_argument("--mcap", action="store_true",
                   help="also write bench.mcap: the run as ROS 2 messages (the writing task's "
                   "topics, /can/frames, /can/decoded/<Message>, /bench/faults) for Foxglove, "
                   "Rerun or ros2 bag (pip install 'rrr_robot[mcap]'; docs/viewing.md)")


def add_realtime_arguments(p: argparse.ArgumentParser) -> None:
    """Real time (``bench`` only)."""
    g = p.add_argument_group("real time")
    g.add_argument("--realtime", action="store_true",
                   help="both C nodes in real time at 1 kHz (SCHED_FIFO 80, mlockall, one CPU "
                   "each, sleep-then-spin: each when permitted, with a warning and the "
                   "fallback otherwise); latency figures in summary.json (default: lockstep)")
    _add_rt_tuning(g, "release")


_RESULTS = ("summary.json (the writing task's metrics, the difference to the unquantised "
            "co-simulation of the scenario, faults, missed commands, bus traffic), the figures, "
            "the nodes' logs and a frame log (.blf or .asc) into --out.")


def _action(actions: Any, name: str, help: str, description: str,
            example: str) -> argparse.ArgumentParser:
    return command_parser(actions, name, help=help, description=description, example=example)


def register_cli(subparsers: Any) -> None:
    """Add ``hil`` and its actions to the ``rrr`` command line."""
    p = command_parser(
        subparsers, "hil", help="CAN bench: C nodes, either FMU side over python-can, bus load",
        description="The writing task on a (virtual) CAN bench: the C controller and plant "
        "nodes, or either FMU under FMPy over python-can against the other C node, over the "
        "socketcand protocol (or SocketCAN); and the load of the bench's schedule on a bus. "
        "'rrr hil ACTION --help' gives each action's options.",
        example="rrr hil bench --out results/hil")
    actions = p.add_subparsers(dest="side", metavar="ACTION", required=True)

    b = _action(actions, "bench", "the C controller node against the C plant node",
                "Run the C controller node against the C plant node (socketcand transport, or "
                "SocketCAN with --interface socketcan; lockstep, or --realtime) and write "
                + _RESULTS,
                "rrr hil bench --realtime --duration 20 --out results/hil-rt")
    add_reference_arguments(b)
    add_node_bus_arguments(b)
    add_realtime_arguments(b)
    add_result_arguments(b)
    add_verbosity_arguments(b)
    b.set_defaults(func=_cmd_hil)

    c = _action(actions, "controller", "the controller FMU (FMPy, python-can) vs the C plant",
                "Run the controller FMU under FMPy over python-can against the C plant node "
                "(started here unless --connect; lockstep) and write " + _RESULTS,
                "rrr hil controller --out results/hil")
    add_reference_arguments(c)
    add_bus_arguments(c)
    add_result_arguments(c)
    add_verbosity_arguments(c)
    c.set_defaults(func=_cmd_hil)

    pl = _action(actions, "plant", "the plant FMU (FMPy, python-can) vs the C controller",
                 "Run the plant FMU under FMPy behind the C command supervisor (ctypes) over "
                 "python-can against the C controller node (started here with --listen unless "
                 "--connect; lockstep only) and write " + _RESULTS + " Exit status 3 when the "
                 "plant latched a fault.",
                 "rrr hil plant --drop-commands-from 2000 --out results/hil-fault")
    add_reference_arguments(pl)
    add_bus_arguments(pl)
    pl.add_argument_group("fault injection").add_argument(
        "--drop-commands-from", type=nonnegative_int, metavar="K",
        help="VoltageCmd frames of periods >= K do not reach the plant (0 V at the 3rd "
        "period, timeout latched)")
    add_result_arguments(pl)
    add_verbosity_arguments(pl)
    pl.set_defaults(func=_cmd_hil)

    e = _action(actions, "export-reference", "write the reference table the C controller reads",
                "Write reference.csv, the writing reference (t, q, qd, qdd per period) that "
                "rrr_hil_controller --reference reads, into --out.",
                "rrr hil export-reference --scenario pd --out results/hil")
    add_reference_arguments(e)
    add_verbosity_arguments(e, bars=False)
    e.set_defaults(func=_cmd_hil)

    pil = _action(actions, "pil", "the controller firmware on a Cortex-M (QEMU) vs the C plant",
                  "Processor in the loop: run the controller firmware (c_src/firmware: eq 15 on "
                  "a Cortex-M7 with double-precision FPU, or with --float on a Cortex-M4F in "
                  "single precision) in qemu-system-arm, its SLCAN line bridged to the C plant "
                  "node (lockstep, the firmware's Sync), and write " + _RESULTS + " summary.json "
                  "adds the target: flash, RAM, stack, instructions per period "
                  "(docs/microcontroller.md).",
                  "rrr hil pil --duration 2 --out results/pil")
    add_reference_arguments(pil)
    g = pil.add_argument_group("firmware")
    g.add_argument("--float", action="store_true",
                   help="the Cortex-M4F image (QEMU mps2-an386): the law in single precision "
                   "(default: the Cortex-M7 image, mps2-an500, in double)")
    g.add_argument("--firmware", type=Path, default=Path("build-firmware"), metavar="DIR",
                   help="the build folder of c_src/firmware (default: build-firmware, as "
                   "'cmake -S c_src/firmware -B build-firmware' makes it)")
    add_result_arguments(pil)
    add_verbosity_arguments(pil)
    pil.set_defaults(func=_cmd_pil)

    co = _action(actions, "canopen", "a CANopen master (canopen package) vs the plant's drives",
                 "Start the C plant node as three CiA 402 drives (its CANopen profile, over "
                 "socketcand) and master them with the canopen package: NMT reset and start, SDO "
                 "configuration (mode CST, rated torque, encoder resolution), the PDO mapping read "
                 "back, BaseNode402 to OPERATION ENABLED, then the computed-torque law of eq 15 in "
                 "lockstep (one SYNC per period, target torques in RPDOs, position and velocity "
                 "from TPDOs) or with --realtime (a SYNC every 1 ms on the wall clock), NMT stop "
                 "at the end; write summary.json, plant.csv, "
                 "controller.csv, the plant's frame log (frames.rrrcan, frames.blf) and the "
                 "figures into --out (docs/canopen.md).",
                 "rrr hil canopen --duration 2 --out results/hil-canopen")
    add_reference_arguments(co)
    r = co.add_argument_group("real time")
    r.add_argument("--realtime", action="store_true",
                   help="a SYNC every 1 ms on the wall clock (not lockstep: the Python master's "
                   "from python-can's periodic sender, the C master's from its own clock), "
                   "the master's heartbeat (20 ms) watched by each drive's consumer 0x1016, the "
                   "law on the newest TPDOs; SCHED_FIFO 80 when permitted; SYNC period jitter "
                   "and deadline misses in summary.json")
    _add_rt_tuning(r, "SYNC of the C master")
    r.add_argument("--consumer-ms", type=positive_int, metavar="MS",
                   help="with --realtime: each drive's heartbeat consumer time 0x1016 of the "
                   "master, above the heartbeat's 20 ms (default 100; generous values for a "
                   "busy machine)")
    r.add_argument("--rpdo-timeout", type=positive_int, metavar="N",
                   help="with --realtime: each drive's RPDO timeout 0x2001, SYNC periods without "
                   "an RPDO before it faults, 1..255 (default: the EDS's, 3)")
    g = co.add_argument_group("CANopen")
    g.add_argument("--node-ids", type=node_ids, metavar="A,B,C",
                   help="the drives' node ids, axes 1..3 (default 1,2,3: the plant's)")
    g.add_argument("--timeout", type=duration_seconds, default=5.0, metavar="S",
                   help="seconds to wait for a boot-up, an SDO answer or a period's TPDOs "
                   "(default 5)")
    g.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="socketcand: the plant node serves the socketcand protocol on loopback "
                   "TCP (the default); socketcan: the plant and the master (python-can's "
                   "socketcan interface) on the SocketCAN interface --channel")
    g.add_argument("--channel", default="vcan0",
                   help="with --interface socketcan: the interface (default vcan0)")
    g.add_argument("--master", default="python", choices=["python", "c"],
                   help="python: the canopen package's master in this process (the default); "
                   "c: the C controller node in its CANopen profile (the same sequence and "
                   "law)")
    co.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    add_verbosity_arguments(co)
    co.set_defaults(func=_cmd_canopen)

    bl = _action(actions, "busload", "the load of the DBC's schedule on a CAN or CAN FD bus",
                 "Compute the load of the DBC's schedule (frame lengths with worst-case and "
                 "without bit stuffing, periods from GenMsgCycleTime) on a classical CAN or CAN "
                 "FD bus; the last line is the worst-case load in percent.",
                 "rrr hil busload --bitrate 500000 --fd 2000000")
    bl.add_argument("--bitrate", type=bitrate, metavar="B",
                    help="the (nominal) bit rate, bit/s (default 1000000)")
    bl.add_argument("--fd", type=bitrate, metavar="DATA_BITRATE",
                    help="CAN FD with bit-rate switch to DATA_BITRATE bit/s")
    bl.add_argument("--lockstep", action="store_true",
                    help="include the lockstep-only frames (Sync)")
    bl.add_argument("--dbc", type=Path, metavar="FILE",
                    help="another DBC (default: the bench's rrr_bench.dbc)")
    bl.add_argument("--profile", choices=tuple(PROFILES), default="dbc",
                    help="canopen: the schedule of three CiA 402 drives of rrr_cia402.eds "
                         "(SYNC, RPDO, TPDOs every period; heartbeats) instead of the DBC's")
    bl.add_argument("--sync-period-ms", type=sync_period_ms, metavar="MS",
                    help="--profile canopen: the SYNC period, ms (default 1)")
    add_verbosity_arguments(bl, bars=False)
    bl.set_defaults(func=_cmd_busload)
