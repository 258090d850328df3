"""``--quick`` for the bench scripts: the same script on small inputs, so that the test command
runs each one end to end (it prints its tables; nothing about the figures is asserted)."""

from __future__ import annotations

import argparse
from typing import Any


def add_quick(parser: argparse.ArgumentParser) -> None:
    """The ``--quick`` flag (its values: :func:`apply_quick`)."""
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run on small inputs (what the test command runs): the "
                        "same code and tables, numbers not worth reading")


def apply_quick(parser: argparse.ArgumentParser, args: argparse.Namespace,
                values: dict[str, Any]) -> argparse.Namespace:
    """With ``--quick``: ``values`` for every option left at its default."""
    if args.quick:
        for name, value in values.items():
            if getattr(args, name) == parser.get_default(name):
                setattr(args, name, value)
    return args
