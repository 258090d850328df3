"""``rrr writing``: the writing task (registered by :mod:`rrr_robot.cli.app`; the library is
:mod:`rrr_robot.writing`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


class _ProgressBar:
    """A one-line progress bar on stderr (only when it is a terminal or forced)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled

    def __call__(self, name: str, k: int, n: int) -> None:
        if not self.enabled:
            return
        frac = (k + 1) / n
        bar = "#" * int(30 * frac)
        end = "\n" if k + max(1, n // 100) >= n - 1 else ""
        sys.stderr.write(f"\r{name:>10} [{bar:<30}] {100 * frac:5.1f} %{end}")
        sys.stderr.flush()


def _cmd_writing(args: argparse.Namespace) -> int:
    from ..writing.job import WritingJob, run_writing
    from ..writing.scenarios import BUILTIN

    job = WritingJob(
        out=Path(args.out), text=args.text, scenarios=args.scenario or list(BUILTIN),
        robot=Path(args.robot) if args.robot else WritingJob.robot, scale=args.scale,
        figures=not args.no_figures, fmi_version=args.fmi,
    )
    summary = run_writing(job, progress=_ProgressBar(not args.quiet and sys.stderr.isatty()))
    for name, s in summary["scenarios"].items():
        rms_n = ", ".join(f"{v:.2f}" for v in s["rms_u_n"])
        rms_c = ", ".join(f"{v:.3f}" for v in s["rms_u_c"])
        print(f"{name:>10}: tip error max {1e3 * s['tip_error_max']:7.3f} mm, "
              f"rms {1e3 * s['tip_error_rms']:7.3f} mm; RMS u_n [{rms_n}] V, "
              f"u_c [{rms_c}] V; {s['realtime_factor']:.0f}x real time")
    print(f"results in {job.out}/ (summary.json, <scenario>.csv, figures)")
    return 0


def register_cli(subparsers: Any) -> None:
    """Add the ``writing`` subcommand to the ``rrr`` command line."""
    p_w = subparsers.add_parser(
        "writing", help="run the writing task: co-simulate the FMUs for each scenario",
        description="Co-simulate the controller and plant FMUs on the writing task and write "
        "summary.json, one CSV per scenario and the figures (paper Figs 2-9) into --out.",
    )
    p_w.add_argument("--text", help="text to write (default: the paper-like default text)")
    p_w.add_argument("--scenario", action="append", metavar="S",
                     help="pd, ctc, mismatch or a scenario .toml file; repeat for several "
                     "(default: pd, ctc and mismatch)")
    p_w.add_argument("--out", default="results", help="output folder (default: results)")
    p_w.add_argument("--robot", help="robot TOML file (default: the packaged default robot)")
    p_w.add_argument("--scale", type=float, default=1.0,
                     help="factor on the letter height (default 1)")
    p_w.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p_w.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                     help="FMI version of the FMUs to co-simulate (default 2; the results are "
                     "identical)")
    p_w.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p_w.set_defaults(func=_cmd_writing)
