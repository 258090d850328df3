"""Argument types and parser helpers of the ``rrr`` command line.

Types: a malformed value is an argparse error (one line, exit 2) before the command runs, so
nothing is read, simulated or written. Helpers: every command's parser is made by
:func:`command_parser` (a description and one example in its help) and carries the verbosity
options of :func:`add_verbosity_arguments`; option groups shared by several commands are added
by one function each, as python-can's ``add_bus_arguments`` does, so no command lists an option
it would ignore.
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path
from typing import Any

__all__ = ["HelpFormatter", "add_verbosity_arguments", "command_parser", "host_port",
           "nonnegative_int", "output_path", "positive_int", "quiet"]


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that lines of the description and the epilog that start
    with blanks (the examples, tables) are kept as written; the other lines are wrapped."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        lines: list[str] = []
        for line in text.splitlines():
            if not line.strip() or line[:1].isspace():
                lines.append(indent + line)
            else:
                lines.extend(textwrap.wrap(line, width, initial_indent=indent,
                                           subsequent_indent=indent))
        return "\n".join(lines)


def command_parser(subparsers: Any, name: str, *, help: str, description: str,
                   example: str | list[str], epilog: str = "") -> argparse.ArgumentParser:
    """The parser of one command: ``help`` for the list of commands, ``description`` and the
    example(s) for its own ``--help`` (``epilog`` goes before the examples)."""
    examples = [example] if isinstance(example, str) else example
    label = "example:" if len(examples) == 1 else "examples:"
    tail = "\n".join([label, *(f"  {e}" for e in examples)])
    parser: argparse.ArgumentParser = subparsers.add_parser(
        name, help=help, description=description,
        epilog=f"{epilog.rstrip()}\n\n{tail}" if epilog else tail,
        formatter_class=HelpFormatter)
    return parser


def add_verbosity_arguments(parser: argparse.ArgumentParser, bars: bool = True) -> None:
    """``-q`` (no INFO lines, no progress bars: only the results and errors) and ``-v`` (DEBUG
    lines too). Given before the command (``rrr -v writing``) they mean the same; the
    command's own default never overrides them (SUPPRESS)."""
    group = parser.add_argument_group("output")
    group.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                       help="print only the results and errors: no INFO lines"
                       + (", no progress bars" if bars else ""))
    group.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS,
                       help="also log DEBUG lines (more detail)")


def quiet(args: argparse.Namespace) -> bool:
    """``-q`` given (before or after the command; False for a namespace of a parser without the
    verbosity options)."""
    return bool(getattr(args, "quiet", False))


def output_path(text: str) -> Path:
    """A file or folder to write: not empty (an empty path would mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an output path must not be empty")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"not a path: {text!r}")
    return Path(text)


def _integer(text: str, least: int, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} expected, got {text!r}") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"{what} expected, got {value}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _integer(text, 1, "an integer >= 1")


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    return _integer(text, 0, "an integer >= 0")


def host_port(text: str) -> str:
    """``HOST:PORT`` with a host and a port from 1 to 65535; returned as given."""
    host, sep, port = text.rpartition(":")
    if not sep or not host.strip() or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(f"HOST:PORT expected (port 1 to 65535), got {text!r}")
    return text
