"""``rrr identify`` and ``rrr identify-experiment`` (registered by :mod:`rrr_robot.cli.app`; the
library is :mod:`rrr_robot.identify`)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import shlex
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import BadInputError
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
    from ..core.outputs import atomic_path, strict_json
    from ..core.param_names import group_names
    from ..core.robot import read_robot_file
    from ..identify.logs import read_log
    from ..identify.pipeline import Settings, identify, write_robot

    prior_robot = read_robot_file(Path(args.robot) if args.robot else DEFAULT_ROBOT_TOML)
    prior = prior_robot.model
    if args.validate:
        prior_robot.require_control()
    _check_outputs(args)  # fail before the estimation, not after it
    settings = Settings(derivatives=args.derivatives, cutoff=args.cutoff,
                        friction_method=args.friction_method, weighting=args.weighting,
                        v_min=args.v_min)
    friction = read_log(args.friction_log, friction=True) if args.friction_log else None
    with Bars(shown(quiet(args)), unit="joint") as bars:
        result = identify(read_log(args.log), prior, friction, settings, progress=bars)
    report: dict[str, Any] = result.report()
    est = result.base.wls if settings.weighting == "wls" else result.base.ls
    print(f"cond(W) = {result.base.cond:.1f} from {result.base.rows} rows; {est.method}:")
    for name, p, s in zip(group_names("p"), est.p, est.std, strict=True):
        print(f"  {name:<5} = {p: .6g} +/- {1.96 * s:.2g} (95 %)")
    if args.validate:
        from ..identify.validation import validate_writing

        with Bars(shown(quiet(args))) as bars:
            report["writing"] = validate_writing(
                prior, result.model, prior_robot,
                progress=lambda name, k, n: bars(name, k + 1, n))
        ratio = report["writing"]["tip_error_ratio"]
        print(f"writing task: tip error ratio identified/prior {ratio:.2f}")
    # the robot file and the report together at the end, each complete or not at all: an
    # interrupted run (also during --validate) leaves the previous files as they were
    with contextlib.ExitStack() as outputs:
        write_robot(result, outputs.enter_context(atomic_path(args.out)), prior_robot)
        if args.report:
            outputs.enter_context(atomic_path(args.report)).write_text(
                strict_json(report) + "\n", encoding="utf-8")
    print(f"identified robot written to {args.out}")
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """The files ``rrr identify`` will write, checked before it reads or estimates anything:
    each in an existing folder, not a folder itself, not one of the input logs, and not the
    same file twice."""
    inputs = {Path(f).resolve(): f for f in (args.log, args.friction_log) if f}
    seen: dict[Path, str] = {}
    for option, path in (("--out", args.out), ("--report", args.report)):
        if path is None:
            continue
        target = Path(path).resolve()
        if target.is_dir():
            raise BadInputError(f"cannot write {path} ({option}): it is a folder")
        if not target.parent.is_dir():
            raise BadInputError(f"cannot write {path}: the folder {target.parent} does not exist")
        if not os.access(target.parent, os.W_OK | os.X_OK):
            raise BadInputError(f"cannot write {path}: the folder {target.parent} is not "
                                "writable")
        if target in inputs:
            raise BadInputError(f"{option} {path} is the input log {inputs[target]}: it would "
                                "be overwritten")
        if target in seen:
            raise BadInputError(f"{option} {path} is also {seen[target]}: give two files")
        seen[target] = option


def _cmd_experiment(args: argparse.Namespace) -> int:
    import numpy as np

    from ..core.model import Model
    from ..core.outputs import ResultSet, check_folder
    from ..core.robot import read_robot_file
    from ..core.robot_file import DEFAULT_SAMPLE_TIME
    from ..identify import experiments as ex
    from ..identify.excitation import design_excitation

    out = check_folder(args.out)  # before anything is read or run
    robot = read_robot_file(args.robot) if args.robot else None
    model = robot.model if robot is not None else Model.default()
    step = robot.sample_time if robot is not None else DEFAULT_SAMPLE_TIME
    ex.check_experiments(args.periods, step)  # the bounds, before anything runs
    sensors = ex.IDEAL if args.noise_free else replace(ex.NOISY, seed=args.seed)
    # the three files appear together when every experiment succeeded (core.outputs)
    with ResultSet(out, kind="identify-experiment") as rs, Bars(shown(quiet(args))) as bars:
        traj, cond = design_excitation(model, np.array(ex.SweepDesign().pose), seed=args.seed)
        traj.to_json(rs.path("excitation.json"))
        note = f"simulated, sensors: {sensors}"
        design = ex.SweepDesign(speeds=tuple(np.geomspace(0.002, 4.0, args.speeds)))
        ex.friction_experiment(model, design, step=step, sensors=sensors,
                               progress=bars.callback("friction sweep")).to_csv(
            rs.path("friction.csv"), note)
        ex.excitation_experiment(model, traj, args.periods, step=step, sensors=sensors,
                                 progress=bars.callback("excitation")).to_csv(
            rs.path("excitation.csv"), f"{note}; cond(W) = {cond:.2f}")
    print(f"cond(W) of the excitation: {cond:.2f}; logs in {out}/ (friction.csv, "
          "excitation.csv, excitation.json)")
    print("identify from them with: " + identify_command(out, args.robot))
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
    OUT`` (with its robot as the prior, whose kinematics and motors identification keeps)."""
    words = ["rrr", "identify", "--log", str(out / "excitation.csv"), "--friction-log",
             str(out / "friction.csv")]
    if robot:
        words += ["--robot", robot]
    words += ["--out", str(out / "identified.toml")]
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
                   help="run the writing task with the prior and the identified model")
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
