"""``rrr writing``: the writing task (registered by :mod:`rrr_robot.cli.app`; the library is
:mod:`rrr_robot.writing`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ._args import add_verbosity_arguments, command_parser, output_path, quiet
from ._progress import Bars, shown


def _num(value: float | None, fmt: str, scale: float = 1.0) -> str:
    """A number of summary.json (null when it was not finite)."""
    return "n/a" if value is None else format(scale * value, fmt)


def _scenario_line(s: dict[str, Any]) -> str:
    """One scenario of summary.json for the terminal (non-finite metrics are null there)."""
    if s.get("status") == "diverged":
        return f"DIVERGED: non-finite {', '.join(s['non_finite'])} (see summary.json)"
    rms_n = ", ".join(_num(v, ".2f") for v in s["rms_u_n"])
    rms_c = ", ".join(_num(v, ".3f") for v in s["rms_u_c"])
    return (f"tip error max {_num(s['tip_error_max'], '7.3f', 1e3)} mm, "
            f"rms {_num(s['tip_error_rms'], '7.3f', 1e3)} mm; RMS u_n [{rms_n}] V, "
            f"u_c [{rms_c}] V; {_num(s['realtime_factor'], '.0f')}x real time")


def _text(text: str | None) -> str | None:
    """--text as written: a newline, or the two characters backslash n (what a shell passes for
    'a\\nb'), starts a new line."""
    return None if text is None else text.replace("\\n", "\n")


def _fps(text: str) -> float:
    """--fps: a finite number > 0 and <= 1000."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of frames per second expected, got "
                                         f"{text!r}") from None
    if not 0 < value <= 1000:  # also NaN
        raise argparse.ArgumentTypeError(f"a frame rate > 0 and <= 1000 expected, got {text}")
    return value


def _cmd_writing(args: argparse.Namespace) -> int:
    from ..writing.job import WritingJob, run_writing
    from ..writing.scenarios import BUILTIN

    job = WritingJob(
        out=Path(args.out), text=_text(args.text), scenarios=args.scenario or list(BUILTIN),
        robot=Path(args.robot) if args.robot else WritingJob.robot, scale=args.scale,
        figures=not args.no_figures, fmi_version=args.fmi, table_format=args.format,
        engine=args.engine, animate=args.animate, fps=args.fps, mcap=args.mcap,
        view=args.view,
        controller_robot=Path(args.controller_robot) if args.controller_robot else None,
    )
    with Bars(shown(quiet(args))) as bars:
        summary = run_writing(job, progress=lambda name, k, n: bars(name, k + 1, n))
    if job.controller_robot is not None:
        print(f"plant: {job.robot}; controller's model: {job.controller_robot}")
    for name, s in summary["scenarios"].items():
        print(f"{name:>10}: {_scenario_line(s)}")
    figures = ", figures" if job.figures else ""
    figures += ", <scenario>.mcap" if job.mcap else ""
    figures += ", view.html" if job.view else ""
    animations = sorted({Path(f).suffix for f in summary["files"] if f.startswith("anim_")})
    if animations:
        figures += f", anim_<scenario>{animations[0]}"
    print(f"results in {job.out}/ (summary.json, <scenario>.{job.table_format}{figures})")
    return 0


#: The writing area and the glyphs, for ``rrr writing --help`` (the default robot's [writing]
#: values and WritingSpec's defaults; tests/python/jobs/test_text_layout.py checks them).
WRITING_EPILOG = """\
writing area (default robot; a robot file's [writing] plane_y, x_range, z_range change it):
  x from 0.35 to 0.65 m and z from 0.35 to 0.60 m (0.30 m x 0.25 m) in the vertical plane
  y = -0.25 m; capital letters 0.07 m high (letter_height); lines 1.6 letter heights apart
  (line_spacing), left-aligned. A text that does not fit is scaled down until it fits, down
  to letters 0.02 m high (min_letter_height); below that it is refused with the numbers.
glyphs: printable ASCII (space to ~) in the cursive Hershey font 'scripts', and the Greek
  alphabet (Unicode, upper and lower case) in the Hershey font 'greek'; at most 200
  characters.
"""
WRITING_EXAMPLES = ["rrr writing --out results --text \"Hello, world\"",
                    "rrr writing --out results --text 'Hello\\nworld' --scenario ctc",
                    "rrr writing --out results --scenario ctc --controller-robot identified.toml"]


def register_cli(subparsers: Any) -> None:
    """Add the ``writing`` subcommand to the ``rrr`` command line."""
    p_w = command_parser(
        subparsers, "writing", help="run the writing task: co-simulate the FMUs for each "
        "scenario",
        description="Co-simulate the controller and plant FMUs on the writing task and write "
        "summary.json, one table of every signal per scenario (CSV, or Parquet with --format "
        "parquet) and the figures (paper Figs 2-9) into --out.",
        epilog=WRITING_EPILOG, example=WRITING_EXAMPLES,
    )
    p_w.add_argument("--text", help="text to write (default: the paper-like default text "
                     "'a\u03c9m\u03b3'); a newline or \\n starts a new line")
    p_w.add_argument("--scenario", action="append", metavar="S",
                     help="pd, ctc, mismatch or a scenario .toml file; repeat for several "
                     "(default: pd, ctc and mismatch)")
    p_w.add_argument("--out", default=Path("results"), type=output_path,
                     help="output folder (default: results); its previous results stay as they "
                     "were unless the run succeeds")
    p_w.add_argument("--robot", help="robot TOML file (default: the packaged default robot): "
                     "the plant, and the controller's model unless --controller-robot")
    p_w.add_argument("--controller-robot", metavar="FILE",
                     help="the controller's model from this robot TOML file instead of --robot's "
                     "(e.g. the output of rrr identify: the identified controller against the "
                     "true plant); a scenario's [mismatch] perturbs it; gains, sample time and "
                     "the writing task stay --robot's")
    p_w.add_argument("--scale", type=float, default=1.0,
                     help="factor on the letter height the text is written at (after the fit "
                     "to the writing area; default 1); a scaled text that does not fit is "
                     "refused")
    p_w.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p_w.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                     help="FMI version of the FMUs to co-simulate (default 2; the results are "
                     "identical)")
    p_w.add_argument("--engine", choices=("fmpy", "native"), default="fmpy",
                     help="fmpy (default): co-simulate the controller and plant FMUs through "
                     "FMPy; native: run the same closed loop in the C library (rr.simulate), "
                     "bit-identical results, several times faster (--fmi does not apply)")
    p_w.add_argument("--format", choices=("csv", "parquet"), default="csv",
                     help="format of the per-scenario signal tables <scenario>.csv or "
                     "<scenario>.parquet (default csv; parquet needs pyarrow: pip install "
                     "'rrr_robot[parquet]'); the same columns and values")
    p_w.add_argument("--animate", nargs="?", const="auto", choices=("auto", "gif", "mp4"),
                     metavar="FORMAT",
                     help="also write anim_<scenario>.gif or .mp4: the arm in 3-D writing (links, "
                     "pen trace, reference), 15 frames per simulated second; FORMAT auto "
                     "(default: mp4 when imageio-ffmpeg is installed, pip install "
                     "'rrr_robot[mp4]', else gif), gif or mp4")
    p_w.add_argument("--fps", type=_fps, default=15.0, metavar="F",
                     help="frames per simulated second of --animate (default 15); an animation "
                     "has at most 3000 frames: lower it for long texts")
    p_w.add_argument("--mcap", action="store_true",
                     help="also write <scenario>.mcap: the run as ROS 2 messages (/joint_states, "
                     "/tf, /robot_description, the reference, the tip path, the voltages) for "
                     "Foxglove, Lichtblick, Rerun or ros2 bag (needs pip install "
                     "'rrr_robot[mcap]'; docs/viewing.md)")
    p_w.add_argument("--view", action="store_true",
                     help="also write view.html: the runs in a browser, the arm moving with a "
                     "time slider beside its signals (rrr view; docs/viewing.md)")
    add_verbosity_arguments(p_w)
    p_w.set_defaults(func=_cmd_writing)
