"""``rrr ssp`` and ``rrr run-ssp``: the writing task as an SSP 1.0 archive, and its run in
libcosim or FMPy (registered by :mod:`rrr_robot.cli.app`; the library is :mod:`rrr_robot.ssp`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ._args import add_verbosity_arguments, command_parser, nonnegative_int, output_path, quiet
from ._progress import Bars, shown
from .writing import _scenario_line


def _cmd_ssp(args: argparse.Namespace) -> int:
    from ..ssp.export import SspJob, export_ssp

    job = SspJob(out=Path(args.out), text=args.text, scenario=args.scenario,
                 robot=Path(args.robot) if args.robot else SspJob.robot, scale=args.scale,
                 lookahead_steps=args.lookahead,
                 controller_robot=Path(args.controller_robot) if args.controller_robot else None)
    info = export_ssp(job)
    if job.controller_robot is not None:
        print(f"plant: {job.robot}; controller's model: {job.controller_robot}")
    print(f"{job.out}: scenario {info['scenario']}, {info['duration']:.3f} s at "
          f"{info['step']:g} s ({info['samples']} samples), look-ahead "
          f"{info['lookahead_steps']} step(s); run it with: rrr run-ssp {job.out} --tool "
          "libcosim|fmpy --out DIR")
    return 0


def _cmd_run_ssp(args: argparse.Namespace) -> int:
    from ..ssp.run import SspRun, run_ssp

    job = SspRun(ssp=Path(args.ssp), tool=args.tool, out=Path(args.out),
                 real_time=args.real_time, figures=not args.no_figures,
                 robot=Path(args.robot) if args.robot else None, mcap=args.mcap)
    with Bars(shown(quiet(args))) as bars:
        summary = run_ssp(job, progress=bars.callback(args.tool))
    for name, s in summary["scenarios"].items():
        print(f"{name:>10}: {_scenario_line(s)}")
    info = summary["ssp"]
    if job.real_time:
        print(f"real-time factor {info['real_time_factor']:.4f} over "
              f"{info['simulated_time']:.3f} s (simulated / wall-clock time; libcosim's own "
              f"figure at the end: {info['libcosim_real_time_factor']:.4f})")
    figures = ", figures" if job.figures else ""
    figures += ", <scenario>.mcap" if job.mcap else ""
    print(f"results in {job.out}/ (summary.json, {', '.join(summary['scenarios'])}.csv"
          f"{figures})")
    return 0


def register_cli(subparsers: Any) -> None:
    """Add the ``ssp`` and ``run-ssp`` subcommands to the ``rrr`` command line."""
    p = command_parser(
        subparsers, "ssp", help="write the writing task's closed loop as an SSP 1.0 archive",
        example="rrr ssp --scenario ctc --out ctc.ssp",
        description="Write the writing task (reference, controller and plant FMUs, their "
        "connections and parameter values, a default experiment) for one scenario as an SSP 1.0 "
        "archive that libcosim and FMPy run (rrr run-ssp).",
    )
    p.add_argument("--out", required=True, type=output_path, metavar="FILE.ssp",
                   help="the archive to write")
    p.add_argument("--text", help="text to write (default: the paper-like default text)")
    p.add_argument("--scenario", default="ctc", metavar="S",
                   help="pd, ctc (default), mismatch or a scenario .toml file")
    p.add_argument("--robot", help="robot TOML file (default: the packaged default robot): the "
                   "plant, and the controller's model unless --controller-robot")
    p.add_argument("--controller-robot", metavar="FILE",
                   help="the controller's model from this robot TOML file (e.g. the output of "
                   "rrr identify), the plant from --robot; as rrr writing --controller-robot")
    p.add_argument("--scale", type=float, default=1.0,
                   help="factor on the letter height (default 1)")
    p.add_argument("--lookahead", type=nonnegative_int, default=1, metavar="STEPS",
                   help="steps the reference FMU plays ahead and the controller predicts the "
                   "measured state (default 1: compensates the one-step delay of masters that "
                   "pass outputs on at the next step, as libcosim and FMPy do; 0: none)")
    add_verbosity_arguments(p, bars=False)
    p.set_defaults(func=_cmd_ssp)

    r = command_parser(
        subparsers, "run-ssp", help="run an SSP archive of rrr ssp in libcosim or FMPy",
        example="rrr run-ssp ctc.ssp --tool fmpy --out results/ssp",
        description="Run an archive written by rrr ssp in libcosim (CosimExecution."
        "from_ssp_file) or in FMPy's SSP support (simulate_ssp) and write summary.json and "
        "<scenario>.csv with the metrics and columns of rrr writing into --out.",
    )
    r.add_argument("ssp", metavar="FILE.ssp", help="the archive")
    r.add_argument("--tool", required=True, choices=("libcosim", "fmpy"),
                   help="the co-simulation tool that runs the archive")
    r.add_argument("--out", required=True, type=output_path,
                   help="output folder; its previous results stay as they were unless the run "
                   "succeeds")
    r.add_argument("--real-time", action="store_true",
                   help="libcosim's real-time mode (the run takes the simulated time); reports "
                   "the achieved real-time factor")
    r.add_argument("--no-figures", action="store_true",
                   help="skip the PNG figures (those of rrr writing: Figs 2-9, the tip error)")
    r.add_argument("--robot", help="the robot file the archive was written from, for the "
                   "figures and the MCAP's URDF (default: the packaged default robot)")
    r.add_argument("--mcap", action="store_true",
                   help="also write <scenario>.mcap: the run as ROS 2 messages (the topics of "
                   "rrr writing --mcap; pip install 'rrr_robot[mcap]'; docs/viewing.md)")
    add_verbosity_arguments(r)
    r.set_defaults(func=_cmd_run_ssp)
