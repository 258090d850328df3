"""``rrr identify`` and ``rrr identify-experiment`` (registered by :mod:`rrr_robot.cli.app`; the
library is :mod:`rrr_robot.identify`)."""

from __future__ import annotations

import argparse
import logging
import shlex
from pathlib import Path
from typing import Any

from ._args import (
    add_verbosity_arguments,
    command_parser,
    nonnegative_int,
    output_path,
    positive_int,
    quiet,
)
from ._progress import Bars, shown

log = logging.getLogger(__name__)


def _cmd_identify(args: argparse.Namespace) -> int:
    # the library is imported when the command runs: rrr --help loads none of it
    from ..core.model import DEFAULT_ROBOT_TOML
    from ..core.param_names import group_names
    from ..identify.jobs import IdentifyJob, run_identify
    from ..identify.pipeline import Identified, Settings

    job = IdentifyJob(
        log=Path(args.log), out=args.out,
        friction_log=Path(args.friction_log) if args.friction_log else None,
        robot=Path(args.robot) if args.robot else DEFAULT_ROBOT_TOML,
        settings=Settings(derivatives=args.derivatives, cutoff=args.cutoff,
                          friction_method=args.friction_method, weighting=args.weighting,
                          v_min=args.v_min),
        report=args.report, validate=args.validate,
        truth=Path(args.truth) if args.truth else None)

    with Bars(shown(quiet(args)), unit="joint") as fits, Bars(shown(quiet(args))) as steps:
        def progress(phase: str, done: int, total: int) -> None:
            (fits if phase == "friction fits" else steps)(phase, done, total)

        def estimated(result: Identified) -> None:
            fits.close()  # the estimate's lines below the finished bar, never on it
            est = result.base.wls if job.settings.weighting == "wls" else result.base.ls
            print(f"cond(W) = {result.base.cond:.1f} from {result.base.rows} rows; "
                  f"{est.method}:")
            if result.truth is not None:  # each estimate beside the truth, with its interval
                print("\n".join(result.truth.lines()))
                return
            for name, p, s in zip(group_names("p"), est.p, est.std, strict=True):
                print(f"  {name:<5} = {p: .6g} +/- {1.96 * s:.2g} (95 %)")

        outcome = run_identify(job, progress, estimated)
    if job.validate:
        w = outcome.report["writing"]
        print(f"writing task (ctc, plant: the {w['plant']}): tip error max "
              f"{1e3 * w['identified']['tip_error_max']:.4f} mm with the identified controller "
              f"model, {1e3 * w['true']['tip_error_max']:.4f} mm with the {w['plant']}'s: ratio "
              f"identified/{w['plant']} {w['tip_error_ratio']:.2f}")
    print(f"identified robot written to {args.out}")
    return 0


def _cmd_experiment(args: argparse.Namespace) -> int:
    from ..identify.jobs import ExperimentJob, run_experiment

    job = ExperimentJob(out=args.out, robot=Path(args.robot) if args.robot else None,
                        noise_free=args.noise_free, seed=args.seed, speeds=args.speeds,
                        periods=args.periods)
    with Bars(shown(quiet(args))) as bars:
        outcome = run_experiment(job, progress=bars)
    print(f"cond(W) of the excitation: {outcome.cond:.2f}; logs in {outcome.out}/ "
          "(friction.csv, excitation.csv, excitation.json)")
    print("identify from them with: " + identify_command(outcome.out, args.robot))
    return 0


def _sweep_speeds(text: str) -> int:
    """--speeds: an integer >= 8 (the friction fit has 7 unknowns per joint, and each speed
    above rrr identify's --v-min gives two points: 8 speeds from 0.002 rad/s give 4 or 5)."""
    value = positive_int(text)
    if value < 8:
        raise argparse.ArgumentTypeError(f"an integer >= 8 expected, got {value}")
    return value


def identify_command(out: Path, robot: str | None) -> str:
    """The ``rrr identify`` command that reads the logs of ``rrr identify-experiment --out
    OUT`` (with its robot as the prior, whose kinematics and motors identification keeps, and
    as the truth each estimate is shown beside: the experiment was simulated on it)."""
    from ..core.model import DEFAULT_ROBOT_TOML

    words = ["rrr", "identify", "--log", str(out / "excitation.csv"), "--friction-log",
             str(out / "friction.csv")]
    if robot:
        words += ["--robot", robot]
    words += ["--truth", robot or str(DEFAULT_ROBOT_TOML), "--out", str(out / "identified.toml")]
    return shlex.join(words)


def register_cli(sub: Any) -> None:
    """Add the identification subcommands to the ``rrr`` parser's subparsers."""
    p = command_parser(
        sub, "identify", help="identify friction and the 16 base parameters from logs",
        description="Estimate eq 9 friction from a constant-velocity sweep log and the base "
        "parameters p from an excitation log (CSV, columns documented in "
        "rrr_robot.identify.logs) and write a robot TOML with [base_parameters] and [friction].",
        example="rrr identify --log logs/excitation.csv --friction-log logs/friction.csv "
        "--out identified.toml --validate")
    p.add_argument("--log", required=True, help="excitation log CSV (t, q[i], u[i])")
    p.add_argument("--friction-log", help="friction sweep CSV (adds column joint); without "
                   "it the prior's friction is used")
    p.add_argument("--robot", help="prior robot TOML: kinematics, k_t, u_max (default: packaged)")
    p.add_argument("--out", required=True, type=output_path,
                   help="identified robot TOML to write")
    p.add_argument("--derivatives", choices=("butter", "savgol", "log"), default="butter",
                   help="zero-phase Butterworth, Savitzky-Golay, or the logged qd/qdd")
    p.add_argument("--cutoff", type=float, default=15.0, help="filter cutoff, Hz (default 15)")
    p.add_argument("--friction-method", choices=("nls", "ls"), default="nls",
                   help="nls: f, w, b; ls: f, b with the prior's w")
    p.add_argument("--weighting", choices=("ls", "wls"), default="ls",
                   help="ls (default; honest 95 %% intervals) or wls (one noise level per joint)")
    p.add_argument("--v-min", type=float, default=0.05,
                   help="drop rows of joints slower than this, rad/s")
    p.add_argument("--report", type=output_path, help="write the figures of merit as JSON")
    p.add_argument("--validate", action="store_true",
                   help="run the writing task (ctc) with the identified controller model and "
                   "with the plant's own model (the plant: --truth, else the prior)")
    p.add_argument("--truth", metavar="FILE",
                   help="the true robot TOML of a simulated experiment (rrr identify-experiment "
                   "--robot FILE): print each estimate beside its true value and its 95 %% "
                   "interval, and write the comparison into --out and --report")
    add_verbosity_arguments(p)
    p.set_defaults(func=_cmd_identify)
    e = command_parser(
        sub, "identify-experiment", help="simulate friction and excitation logs on the plant "
        "FMU",
        description="Design an excitation, run the friction sweep and the excitation on the "
        "plant FMU with encoder quantisation and noise, and write the logs (friction.csv, "
        "excitation.csv, excitation.json); its last line is the rrr identify command that "
        "reads them.",
        example="rrr identify-experiment --out logs")
    e.add_argument("--out", required=True, type=output_path,
                   help="output folder (its previous logs stay as they were unless every "
                   "experiment succeeds)")
    e.add_argument("--robot", help="true robot TOML (default: packaged)")
    e.add_argument("--noise-free", action="store_true", help="ideal sensors (logs qd, qdd)")
    e.add_argument("--seed", type=nonnegative_int, default=1,
                   help="seed of the sensor noise and of the excitation design (>= 0)")
    e.add_argument("--speeds", type=_sweep_speeds, default=14,
                   help="constant speeds of the friction sweep, from 0.002 to 4 rad/s, each "
                   "joint and direction (default 14; at least 8, of which rrr identify fits those "
                   "above --v-min: fewer make a quicker, rougher friction fit)")
    e.add_argument("--periods", type=positive_int, default=1,
                   help="excitation periods of 10 s (an experiment has at most 1,000,000 "
                   "samples: 1000 s at 1 ms)")
    add_verbosity_arguments(e)
    e.set_defaults(func=_cmd_experiment)
