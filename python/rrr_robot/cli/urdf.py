"""``rrr urdf``: the robot as a URDF file (registered by :mod:`rrr_robot.cli.app`; the library is
:mod:`rrr_robot.core.urdf`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import BadInputError
from ._args import add_verbosity_arguments, command_parser, output_path


def _cmd_urdf(args: argparse.Namespace) -> int:
    from ..core.model import DEFAULT_ROBOT_TOML
    from ..core.outputs import atomic_write_text
    from ..core.robot import read_robot_file
    from ..core.urdf import robot_urdf

    out = Path(args.out)
    if out.is_dir():
        raise BadInputError(f"cannot write {out} (--out): it is a folder")
    if not out.resolve().parent.is_dir():
        raise BadInputError(f"cannot write {out}: the folder {out.resolve().parent} does not "
                            "exist")
    robot = read_robot_file(Path(args.robot) if args.robot else DEFAULT_ROBOT_TOML)
    text = robot_urdf(robot, name=args.name, continuous=args.continuous)
    atomic_write_text(out, text)
    print(f"URDF of {robot.source} written to {out} (links base_link, link1..3, tool; rotor "
          "inertias not representable in URDF: see the file's comment)")
    return 0


def register_cli(sub: Any) -> None:
    """Add the ``urdf`` subcommand to the ``rrr`` parser's subparsers."""
    p = command_parser(
        sub, "urdf", help="write the robot as a URDF file (Pinocchio, MuJoCo, Drake, ROS)",
        example="rrr urdf --out rrr.urdf",
        description="Write the robot of a robot file as URDF: links with masses, centres of mass "
        "and inertias from the link tables, revolute joints on the DH axes (joint angles = the "
        "model's q), a 'tool' frame at the pen tip. Rotor inertias have no place in URDF (the "
        "file says so). A robot file with [base_parameters] only cannot be exported.")
    p.add_argument("--out", required=True, type=output_path, help="URDF file to write")
    p.add_argument("--robot", help="robot TOML file with link tables (default: the packaged "
                   "default robot)")
    p.add_argument("--name", default="rrr", help="robot name in the file (default rrr)")
    p.add_argument("--continuous", action="store_true",
                   help="continuous joints (no position limits, as the real joints) instead of "
                   "revolute joints limited to +-2 pi")
    add_verbosity_arguments(p, bars=False)
    p.set_defaults(func=_cmd_urdf)
