"""``rrr hil``: the writing task on the CAN bench (the C nodes, either FMU side over python-can).

Registered by :mod:`rrr_robot.cli.app`; the library is :mod:`rrr_robot.hil`.
"""

from __future__ import annotations

import argparse
import errno
import logging
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._args import host_port, nonnegative_int, output_path

if TYPE_CHECKING:
    from ..writing.trajectory import Reference


def _writing_setup(text: str | None, scenario: str) -> tuple[Reference, dict[str, float | bool]]:
    """The writing reference and the controller values of a scenario (default robot)."""
    from ..writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), text=text,
                                                      scenarios=[scenario]))
    return ref, controller_fmu_values(scenarios[0], model, robot.require_control())


def _cmd_hil(args: argparse.Namespace) -> int:
    from ..core.outputs import ResultSet, check_folder

    out = check_folder(args.out)  # before anything is read or run
    ref, ctrl_values = _writing_setup(args.text, args.scenario)
    # the nodes write into the result set's staging folder; the logs of the run appear in out
    # together when it ended, and an interrupted or failed run leaves the previous ones as they
    # were (rrr_robot.core.outputs)
    with ResultSet(out, kind="hil") as rs:
        return _run_side(args, ref, ctrl_values, rs.staging, out)


def _run_side(args: argparse.Namespace, ref: Reference, ctrl_values: dict[str, float | bool],
              work: Path, out: Path) -> int:
    """One side of ``rrr hil``, writing its files into ``work`` (they end up in ``out``)."""
    import numpy as np

    from ..hil.bench import run_c_bench, run_fmu_controller
    from ..hil.nodes import export_reference, start_plant

    if args.side == "export-reference":
        export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv")
        print(f"reference: {out / 'reference.csv'} ({ref.t.size} periods)")
        return 0
    if args.side == "plant":
        return _cmd_plant(args, ref, work, ctrl_values, out)
    if args.side == "bench":
        run = run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=work,
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
            plant = start_plant(q0=ref.q[0], qd0=ref.qd[0], log_csv=work / "plant.csv")
            host, port = "127.0.0.1", str(plant.port)
        with _open(args.interface, host, int(port), args.channel) as bus:
            run = run_fmu_controller(bus, ref.t, ref.q, ref.qd, ref.qdd, ctrl_values)
        err = np.abs(run.q - ref.q).max()
        print(f"FMU controller vs plant node: {run.t.size} periods, max |q - q_ref| "
              f"{err:.3e} rad, plant status {run.plant_summary}")
        if plant is not None:
            summary = plant.wait()
            print(f"plant node: exit {summary['exit']}, faults {summary.get('faults')}")
            if summary["exit"] != 0:  # the exit status reflects every node's
                return int(summary["exit"])
    finally:
        if plant is not None:
            plant.close()
    return 0


def _open(interface: str, host: str, port: int, channel: str) -> Any:
    import can

    from ..hil.nodes import open_bus
    from ..hil.protocol import HilError

    # python-can's socketcand client logs a warning per failed connection attempt (thousands in
    # its 10 s of retries); the one error raised at the end says it all
    retries = logging.getLogger("can.interfaces.socketcand.socketcand")
    level = retries.level
    if not logging.getLogger("rrr_robot").isEnabledFor(logging.DEBUG):
        retries.setLevel(logging.ERROR)
    try:
        return open_bus(interface, host=host, port=port, channel=channel)
    except can.CanError as exc:
        raise HilError(f"cannot open the {interface} bus {channel or ''} at {host}:{port}: "
                       f"{exc}") from exc
    except OSError as exc:
        hint = (" (this kernel has no AF_CAN: use --interface socketcand)"
                if exc.errno == errno.EAFNOSUPPORT else "")
        raise HilError(f"cannot open the {interface} bus {channel or ''}: {exc}{hint}") from exc
    finally:
        retries.setLevel(level)


def _cmd_plant(args: argparse.Namespace, ref: Reference, work: Path,
               controller_values: Mapping[str, float | bool] = {},
               out: Path | None = None) -> int:
    """``rrr hil plant``: the Python plant against the C controller node along ``ref``. Without
    --connect (socketcand) the controller is started here with --listen; with --connect it is a
    running ``rrr_hil_controller --listen HOST:PORT``; with --interface socketcan it is a running
    ``rrr_hil_controller --socketcan IF`` started after this plant. The files go to ``work``
    (the staging folder of the run's result set) and end up in ``out`` (default: ``work``)."""
    out = work if out is None else out
    import numpy as np

    from ..hil.nodes import controller_node_args, export_reference, start_listening_controller
    from ..hil.plant import PythonPlant, drop_commands_from

    rx_filter = None if args.drop_commands_from is None else drop_commands_from(
        args.drop_commands_from)
    ctrl = None
    try:
        if args.connect or args.interface == "socketcan":
            host, _, port = (args.connect or "127.0.0.1:0").rpartition(":")
        else:
            ref_csv = export_reference(ref.t, ref.q, ref.qd, ref.qdd, work / "reference.csv")
            ctrl = start_listening_controller(ref_csv, log_csv=work / "controller.csv",
                                              extra=controller_node_args(controller_values))
            host, port = "127.0.0.1", str(ctrl.port)
        with _open(args.interface, host, int(port), args.channel) as bus:
            if args.interface == "socketcan":
                print(f"python plant on {args.channel}: start rrr_hil_controller --socketcan "
                      f"{args.channel} now", flush=True)
            run = PythonPlant(bus, q0=ref.q[0], qd0=ref.qd[0], rx_filter=rx_filter,
                              start_timeout=120.0).run(work / "plant.csv")
        s = run.summary
        err = np.abs(run.q[: ref.q.shape[0]] - ref.q[: run.q.shape[0]]).max()
        print(f"python plant: exit {s['exit']}, {s['periods']} periods, max |q - q_ref| "
              f"{err:.3e} rad, faults latched {s['faults']} (events {s['fault_events']}, "
              f"timeout {s['timeout']}, crc {s['crc']}, counter {s['counter']}, "
              f"range {s['range']}, bus {s['bus']}), periods at 0 V {s['zero_periods']}; "
              f"log {out / 'plant.csv'}")
        node_exit = 0
        if ctrl is not None:
            cs = ctrl.wait()
            node_exit = int(cs["exit"])
            print(f"controller node: exit {cs['exit']}, plant faults seen {cs['plant_faults']}")
        # the exit status reflects every side's: the plant's first, then the controller node's
        return int(s["exit"]) if s["exit"] != 0 else node_exit
    finally:
        if ctrl is not None:
            ctrl.close()


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
    p.add_argument("--out", default=Path("results/hil"), type=output_path,
                   help="output folder (default: results/hil); its previous logs stay as they "
                   "were unless the run ends")
    p.add_argument("--interface", default="socketcand", choices=["socketcand", "socketcan"],
                   help="python-can interface (default socketcand)")
    p.add_argument("--connect", metavar="HOST:PORT", type=host_port,
                   help="socketcand server of a running node: the plant node for 'controller', "
                   "a controller node started with --listen for 'plant' (default: start one)")
    p.add_argument("--channel", default="bench0",
                   help="socketcand bus name, or the SocketCAN interface (default bench0)")
    p.add_argument("--drop-commands-from", type=nonnegative_int, metavar="K",
                   help="'plant' only, fault injection: VoltageCmd frames of periods >= K do "
                   "not reach the plant (0 V at the 3rd period, timeout latched)")
    p.set_defaults(func=_cmd_hil)
