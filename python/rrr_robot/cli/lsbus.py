"""``rrr ls-bus``: the CAN bench's two nodes as FMI-LS-BUS network FMUs in an fmucontainer, run
by FMPy, directly linked or through the open CAN bus simulation FMU.

Registered by :mod:`rrr_robot.cli.app`; the library is :mod:`rrr_robot.hil.lsbus`.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ._args import add_verbosity_arguments, command_parser, quiet
from .hil import (
    NODE_FRAMES,
    _bus_lines,
    _can_log_target,
    _status,
    _writing_setup,
    add_reference_arguments,
    add_result_arguments,
    bitrate,
)

#: The bit rates of the bus simulation (bit/s): what the nodes' baudrate parameter accepts.
BITRATE_RANGE = (10_000, 1_000_000)


def _cmd_lsbus(args: argparse.Namespace) -> int:
    from ..core.outputs import ResultSet, check_folder
    from ..errors import BadInputError
    from ..hil.dbc.results import RunInfo, write_results
    from ..hil.lsbus.run import run_lsbus
    from ..hil.results import extend_reference
    from ._progress import Bars, shown

    if args.bitrate is not None and not args.bus_sim:
        raise BadInputError("--bitrate sets the bus simulation's bit rate: give --bus-sim too")
    rate = 1_000_000 if args.bitrate is None else args.bitrate
    if not BITRATE_RANGE[0] <= rate <= BITRATE_RANGE[1]:
        raise BadInputError(f"--bitrate {rate}: the nodes configure {BITRATE_RANGE[0]} to "
                            f"{BITRATE_RANGE[1]} bit/s (classical CAN)")
    out = check_folder(args.out)
    can_log = _can_log_target(args, out)
    ref, ctrl_values, model = _writing_setup(args.text, args.scenario)
    if args.duration is not None:
        ref = extend_reference(ref, args.duration)
    with ResultSet(out, kind="hil") as rs:
        with Bars(shown(quiet(args)), unit="period") as bars:
            lr = run_lsbus(ref, {}, ctrl_values, rs.staging, bus_sim=args.bus_sim,
                           bitrate=rate, progress=bars.callback("LS-BUS container"))
        view = ("the controller FMU's (Tx: its frames, Rx: "
                + ("the bus simulation's deliveries to it" if args.bus_sim else "the plant's")
                + "), from the container's data log")
        info = RunInfo(side="ls-bus", mode="bus-sim" if args.bus_sim else "lockstep",
                       scenario=args.scenario, node_log=NODE_FRAMES, view=view, bitrate=rate)
        summary = write_results(rs, info, ref, lr.run, model, ctrl_values, lr.nodes,
                                can_log=can_log, figures=not args.no_figures, mcap=args.mcap,
                                extra={"ls_bus": lr.ls_bus})
    _report(summary, out, figures=not args.no_figures)
    return _status(lr.rc)


def _report(s: Mapping[str, Any], out: Path, *, figures: bool) -> None:
    b, ls = s["bench"], s["ls_bus"]
    print(f"LS-BUS container ({ls['link']}, {ls['bitrate']} bit/s; built by {ls['built_by']}, "
          f"run by {ls['run_by']}): {s['reference']['periods']} periods; tip error max "
          f"{1e3 * b['tip_error_max']:.4f} mm, rms {1e3 * b['tip_error_rms']:.4f} mm; max "
          f"|q - q_ref| {max(b['joint_error_max']):.3e} rad")
    for key in ("controller_to_plant", "plant_to_controller"):
        d = ls[key]
        delay = (f", delay mean {1e3 * d['delay_mean_s']:.3f} ms, max "
                 f"{1e3 * d['delay_max_s']:.3f} ms" if d.get("delay_mean_s") is not None else "")
        print(f"  {key.replace('_', ' ')}: {d['sent']} frames sent, {d['delivered']} delivered, "
              f"{d['lost']} lost, {d['in_flight_at_end']} in flight at the end, "
              f"{d['delayed_to_a_later_period']} in a later period{delay}")
    f = s["faults"]
    print(f"  plant: faults latched {f.get('faults')}, fault events {f.get('fault_events')}, "
          f"missed commands {s['missed_commands']}, periods at 0 V {f.get('zero_periods')}; "
          f"periods without a command {ls['periods_without_a_command']}")
    print("\n".join(_bus_lines(s["bus"])))
    print(f"results in {out}/ (summary.json, plant.csv, controller.csv, {ls['pcap']}, "
          f"{ls['container']} with container.json and its FMUs, {ls['data_log']}"
          + (", figures)" if figures else ")"))


def register_cli(subparsers: Any) -> None:
    """Add the ``ls-bus`` command to the ``rrr`` command line."""
    p = command_parser(
        subparsers, "ls-bus",
        help="the CAN bench as FMI-LS-BUS network FMUs in an fmucontainer, run by FMPy",
        example=["rrr ls-bus --duration 2 --out results/ls-bus",
                 "rrr ls-bus --bus-sim --bitrate 250000 --duration 2 --out results/ls-bus-250k"],
        description="Run the writing task on the CAN bench inside co-simulation: the controller "
        "and the plant as network FMUs of FMI-LS-BUS 1.0 (rrr_controller_can, rrr_plant_can: the "
        "frames of rrr_bench.dbc as CAN Transmit operations, the C nodes' codec and supervisor), "
        "linked terminal to terminal (or with --bus-sim through the open CAN bus simulation FMU) "
        "in a container built by fmucontainer (fmu_manipulation_toolbox) and run by FMPy; write "
        "summary.json (with the section ls_bus: the frames each way, delivered, lost, delayed), "
        "plant.csv, controller.csv, the frame logs (frames.rrrcan, frames.blf, frames.pcap), the "
        "container (rrr_bench_can.fmu) with its data log, its description container.json and "
        "the FMUs it names, and the figures into --out "
        "(docs/ls-bus.md).")
    add_reference_arguments(p)
    g = p.add_argument_group("bus")
    g.add_argument("--bus-sim", action="store_true",
                   help="put the bus simulation FMU between the nodes: frames take their "
                   "transmission time at --bitrate and wait for the bus; the controller sends "
                   "its real-time schedule (no Sync); default: the direct link, the lockstep "
                   "schedule (the C bench's arithmetic)")
    g.add_argument("--bitrate", type=bitrate, metavar="B",
                   help="with --bus-sim: the CAN bit rate both nodes configure, bit/s "
                   f"({BITRATE_RANGE[0]} to {BITRATE_RANGE[1]}; default 1000000)")
    add_result_arguments(p)
    add_verbosity_arguments(p)
    p.set_defaults(func=_cmd_lsbus)
