"""The ``rrr`` parser and entry point (also ``python -m rrr_robot``): ``rrr fmus`` here, the
other command groups in their modules (writing, identify, hil)."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from .. import __version__
from ..errors import RrrError
from .hil import register_cli as register_hil
from .identify import register_cli as register_identify
from .writing import register_cli as register_writing

log = logging.getLogger("rrr_robot")


def _cmd_fmus(_: argparse.Namespace) -> int:
    from ..sim.fmus import variants

    for v in variants():
        extras = [x for x, present in (("sources", v.has_sources),
                                       ("documentation", v.has_documentation)) if present]
        print(f"{v.which:<10} FMI {v.fmi_version}.0  {' + '.join(v.interfaces):<28} "
              f"{', '.join(v.platforms):<30} {', '.join(extras):<22} {v.path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rrr",
        description="Closed-form RRR robot models: FMUs, writing task, identification, CAN bench.",
        epilog="examples:\n  rrr fmus\n  rrr writing --out results",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"rrr_robot {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", required=True)
    p_fmus = sub.add_parser(
        "fmus", help="list the FMUs: plant and controller, FMI 2.0 and 3.0, with their "
        "interfaces, platforms and paths")
    p_fmus.set_defaults(func=_cmd_fmus)
    register_writing(sub)
    register_identify(sub)
    register_hil(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args))
    except (RrrError, OSError) as exc:  # OSError: an output path that cannot be written
        print(f"rrr: error: {exc}", file=sys.stderr)
        return 2

