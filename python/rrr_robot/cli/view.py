"""``rrr view``: a run's results as one self-contained HTML page with the arm in 3-D, its time
slider and its signals (registered by :mod:`rrr_robot.cli.app`; the library is
:mod:`rrr_robot.writing.view`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ._args import add_verbosity_arguments, command_parser, output_path


def _cmd_view(args: argparse.Namespace) -> int:
    from ..core.model import DEFAULT_ROBOT_TOML
    from ..core.robot import read_robot_file
    from ..writing.view import write_view

    robot = read_robot_file(Path(args.robot) if args.robot else DEFAULT_ROBOT_TOML)
    page = write_view(Path(args.folder), robot, out=args.out, scenarios=args.scenario)
    print(f"view of {args.folder} written to {page} (open it in a browser; it needs no network)")
    if args.open:
        import webbrowser

        webbrowser.open(page.resolve().as_uri())
    return 0


def register_cli(sub: Any) -> None:
    """Add the ``view`` subcommand to the ``rrr`` parser's subparsers."""
    p = command_parser(
        sub, "view", help="write a run's results as an HTML page: the arm moving in 3-D with a "
        "time slider, the pen trace, the reference and the signals",
        example=["rrr view results", "rrr view results --scenario ctc --out ctc.html --open"],
        description="Write one self-contained HTML page (no network, no CDN: everything is in "
        "the file) that shows the runs of a result folder of rrr writing (its <scenario>.csv or "
        ".parquet tables): the arm from the URDF (rrr urdf) moving along the run with a time "
        "slider and play button, the pen trace and the reference, and the joint angles, "
        "voltages and tip error beside it. The arm's poses are computed by librrr's FK; the "
        "page only draws them. Controls: docs/viewing.md.")
    p.add_argument("folder", type=output_path, help="a result folder (rrr writing --out)")
    p.add_argument("--out", type=output_path,
                   help="HTML file to write (default: FOLDER/view.html)")
    p.add_argument("--scenario", action="append", metavar="S",
                   help="show only this scenario (repeat for several; default: every scenario "
                   "of FOLDER/summary.json)")
    p.add_argument("--robot", help="robot TOML file the run used (default: the packaged "
                   "default robot)")
    p.add_argument("--open", action="store_true", help="open the page in the web browser")
    add_verbosity_arguments(p, bars=False)
    p.set_defaults(func=_cmd_view)
