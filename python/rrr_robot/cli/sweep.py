"""``rrr sweep``: Monte Carlo scenario sweeps on Dask (registered by :mod:`rrr_robot.cli.app`;
the library is :mod:`rrr_robot.sweep`)."""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

from ._args import add_verbosity_arguments, command_parser, output_path, positive_int, quiet
from ._progress import Bars, shown

_ADDRESS = re.compile(r"^(?:(?:tcp|tls|ws|wss)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):\d{1,5}$")


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address: ``tcp://host:port`` (or tls://, ws://, wss://, or
    ``host:port``), port 1 to 65535."""
    port = text.rsplit(":", 1)[-1]
    if not _ADDRESS.match(text) or not 1 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(
            f"a scheduler address tcp://HOST:PORT expected (port 1 to 65535), got {text!r}")
    return text


def _mm(stats: dict[str, Any], key: str) -> str:
    return f"{1e3 * stats[key]:.3f} mm" if key in stats else "n/a"


def _examples_epilog() -> str:
    """The shipped example specs, for ``--help`` (reads only their first lines)."""
    from ..sweep.examples import EXAMPLES_DIR, example_summary, examples

    found = examples()
    if not found:
        return ""
    width = max(len(n) for n in found)
    lines = [f"  {name:<{width}}  {example_summary(path)}" for name, path in found.items()]
    return ("example specs (rrr sweep --example NAME prints one; the files are in "
            f"{EXAMPLES_DIR}):\n" + "\n".join(lines))


def _cmd_sweep(args: argparse.Namespace) -> int:
    if args.example is not None:
        if args.spec is not None or args.out is not None:
            args.parser.error("--example prints an example spec: give it alone (save the spec "
                              "with > FILE.toml, then run rrr sweep FILE.toml --out DIR)")
        from ..sweep.examples import example_path

        sys.stdout.write(example_path(args.example).read_text(encoding="utf-8"))
        return 0
    missing = [name for name, value in (("spec", args.spec), ("--out", args.out))
               if value is None]
    if missing:
        args.parser.error(f"the following arguments are required: {', '.join(missing)} (or "
                          "--example NAME)")
    from ..sweep.job import SweepJob, run_sweep

    job = SweepJob(spec=Path(args.spec), out=Path(args.out), workers=args.workers,
                   scheduler=args.scheduler, engine=args.engine, resume=args.resume,
                   batch=args.batch, figures=not args.no_figures)
    with Bars(shown(quiet(args)), unit="run") as bars:
        summary = run_sweep(job, progress=lambda done, total: bars("sweep", done, total))
    counts = ", ".join(f"{k} {v}" for k, v in summary["status"].items() if v)
    tip = summary["tip_error_max"]
    print(f"{summary['runs']} runs: {counts}")
    if tip["runs"]:
        print(f"max tip error: median {_mm(tip, 'median')}, 95th percentile {_mm(tip, 'p95')}, "
              f"largest {_mm(tip, 'max')} ({tip['runs']} runs with a finite error)")
    for i, s in enumerate(summary["sensitivity"]["ranking"][:5]):
        rho = "" if s["spearman"] is None else f", Spearman {s['spearman']:+.2f}"
        print(f"  {i + 1}. {s['input']}: S1 {s['s1']:.2f}{rho}")
    this = summary["this_invocation"]
    if this["runs"]:
        print(f"ran {this['runs']} runs in {this['wall_time']:.1f} s "
              f"({this['runs_per_second']:.1f} runs/s on {this['worker_threads']} worker "
              f"threads; the cluster took {this['cluster_start']:.1f} s to start or connect)")
    print(f"results in {job.out}/ (results.parquet, summary.json"
          f"{', figures' if job.figures else ''})")
    return 0


def register_cli(subparsers: Any) -> None:
    """Add the ``sweep`` subcommand to the ``rrr`` command line."""
    p = command_parser(
        subparsers, "sweep", help="run a Monte Carlo sweep of writing-task scenarios on Dask",
        example=["rrr sweep spec.toml --out results/sweep --engine native",
                 "rrr sweep --example monte_carlo > mc.toml"],
        epilog=_examples_epilog(),
        description="Run the writing task for every sample of a sweep spec (a base scenario "
        "with fields drawn from distributions, a Latin hypercube or a grid) on a Dask cluster: "
        "a local one, or a running one with --scheduler. Writes results.parquet (one row per "
        "run, written batch by batch), summary.json with a sensitivity ranking, and the "
        "figures into --out. Needs the sweep extra: pip install 'rrr_robot[sweep]'.",
    )
    p.add_argument("spec", nargs="?", help="the sweep spec (TOML: [sweep] and [vary])")
    p.add_argument("--out", type=output_path,
                   help="output folder (a new one, or with --resume the sweep's own); required "
                   "with a spec")
    p.add_argument("--example", metavar="NAME", choices=sorted(_example_names()),
                   help="print the shipped example spec NAME (listed below) and exit")
    p.add_argument("--workers", type=positive_int, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--scheduler", type=scheduler_address, metavar="ADDRESS",
                   help="run on the Dask cluster of this scheduler (tcp://host:port) instead "
                   "of a local cluster; rrr_robot must be installed on its workers")
    p.add_argument("--engine", choices=("fmpy", "native"), default="fmpy",
                   help="fmpy (default): the FMUs through FMPy; native: the same closed loop "
                   "in the C library (rr.simulate), bit-identical, several times faster")
    p.add_argument("--resume", action="store_true",
                   help="complete the sweep in --out: skip the runs it recorded")
    p.add_argument("--batch", type=positive_int, metavar="N",
                   help="runs per Dask task (default: from the number of runs and workers)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    add_verbosity_arguments(p)
    p.set_defaults(func=_cmd_sweep, parser=p)


def _example_names() -> list[str]:
    from ..sweep.examples import examples

    return list(examples())
