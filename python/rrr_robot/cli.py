"""The ``rrr`` command line (also ``python -m rrr_robot``)."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from . import __version__
from .errors import RrrError

log = logging.getLogger("rrr_robot")


def _cmd_fmus(_: argparse.Namespace) -> int:
    from .fmus import fmu_path

    for which in ("plant", "controller"):
        print(f"{which}: {fmu_path(which)}")
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
    p_fmus = sub.add_parser("fmus", help="print the paths of the plant and controller FMUs")
    p_fmus.set_defaults(func=_cmd_fmus)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args))
    except RrrError as exc:
        print(f"rrr: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
