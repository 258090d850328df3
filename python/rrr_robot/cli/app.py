"""The ``rrr`` parser and entry point (also ``python -m rrr_robot``): ``rrr fmus`` here, the
other command groups in their modules (writing, identify, hil, lsbus, urdf, ssp, sweep)."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from types import FrameType
from typing import Any

from .. import __version__
from ..errors import RrrError, one_line, without_traceback
from ._args import HelpFormatter, add_verbosity_arguments, command_parser, quiet

log = logging.getLogger("rrr_robot")

#: The command groups in the order of ``rrr --help``: the module (of this package) whose
#: ``register_cli`` adds them, and the commands it adds ("" for ``rrr fmus``, added here).
COMMAND_MODULES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("", ("fmus",)),
    (".writing", ("writing",)),
    (".identify", ("identify", "identify-experiment")),
    (".hil", ("hil",)),
    (".lsbus", ("ls-bus",)),
    (".urdf", ("urdf",)),
    (".view", ("view",)),
    (".ssp", ("ssp", "run-ssp")),
    (".sweep", ("sweep",)),
)
#: Every command, as ``rrr --help`` lists them.
COMMANDS: tuple[str, ...] = tuple(c for _, names in COMMAND_MODULES for c in names)


def _cmd_fmus(_: argparse.Namespace) -> int:
    from ..sim.fmus import variants

    for v in variants():
        extras = [x for x, present in (("sources", v.has_sources),
                                       ("documentation", v.has_documentation)) if present]
        print(f"{v.which:<10} FMI {v.fmi_version}.0  {' + '.join(v.interfaces):<28} "
              f"{', '.join(v.platform_labels()):<44} {', '.join(extras):<22} {v.path}")
    return 0


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of ``rrr`` with every subcommand (nothing heavy is imported: each command
    imports its library when it runs). With ``command`` (one of ``COMMANDS``), only the
    group that adds it is registered (and imported): the parser :func:`main` builds for a
    command line naming it, which parses and reports it as the whole parser does (the list of
    commands in the usage line is spelled out, so that it stays the whole list)."""
    parser = argparse.ArgumentParser(
        prog="rrr",
        description="Closed-form RRR robot models: FMUs, writing task, identification, CAN bench, "
        "sweeps.",
        epilog="examples:\n  rrr fmus\n  rrr writing --out results\n\n'rrr COMMAND --help' "
        "describes each command with an example.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"rrr_robot {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print only the results and errors: no INFO lines, no progress "
                        "bars (also after the command: rrr writing -q)")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="also log DEBUG lines (also after the command)")
    # one group only: its usage line lists every command all the same (what argparse writes
    # for the whole parser; a metavar there would also rename the argument in its errors)
    named = {} if command is None else {"metavar": "{" + ",".join(COMMANDS) + "}"}
    sub = parser.add_subparsers(dest="command", required=True, **named)
    groups = [(module, names) for module, names in COMMAND_MODULES
              if command is None or command in names]
    if not groups:
        raise ValueError(f"build_parser: unknown command {command!r}")
    for module, _ in groups:
        if module:
            importlib.import_module(module, __package__).register_cli(sub)
        else:
            _register_fmus(sub)
    return parser


def _register_fmus(sub: Any) -> None:
    from ..core.fmu_vars import FMUS

    p_fmus = command_parser(
        sub, "fmus", help=f"list the FMUs: {', '.join(FMUS)}, FMI 2.0 and 3.0 (and the FMI 2.0 "
        "archives for aarch64 Linux hosts)",
        description=f"List the FMUs the package ships: {', '.join(f'rrr_{w}' for w in FMUS)} "
        "(what each one is: the description in its modelDescription.xml, and the manual's page "
        "on the FMUs), each for FMI 2.0 and FMI 3.0, with their interfaces (Model Exchange, "
        "Co-Simulation), platforms, extras and paths.",
        example="rrr fmus")
    add_verbosity_arguments(p_fmus, bars=False)
    p_fmus.set_defaults(func=_cmd_fmus)


def _command_of(argv: Sequence[str]) -> str | None:
    """The command an ``rrr`` command line names: its first word that is not an option (the
    options before the command take no value), if that is one of ``COMMANDS``."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


class _Terminated(BaseException):
    """SIGTERM, turned into an exception so that the running command cleans up (its result set
    is discarded, its C nodes are stopped) as it does for Ctrl-C."""


def _on_sigterm(signum: int, frame: FrameType | None) -> None:
    raise _Terminated


class _LineFormatter(logging.Formatter):
    """``LEVEL logger: message`` on one line. Without ``-v`` a record's traceback is left out,
    whether it comes as the record's exception or inside the message (python-can's socketcand
    bus writes one into the message when its peer goes away): the exception is kept as one
    line, so the error the command reports stays the one that reads as the cause."""

    def __init__(self, tracebacks: bool) -> None:
        super().__init__("%(levelname)s %(name)s: %(message)s")
        self._tracebacks = tracebacks

    def format(self, record: logging.LogRecord) -> str:
        if self._tracebacks:
            return super().format(record)
        record.message = record.getMessage()
        line = without_traceback(self.formatMessage(record).split("\n", 1)[0])
        exc = record.exc_info[1] if record.exc_info else None
        return f"{line} ({one_line(exc)})" if exc is not None else line


@contextlib.contextmanager
def _logging(verbose: bool, quiet: bool) -> Iterator[None]:
    """The log lines of a command on stderr: WARNING and above with ``-q``, INFO by default,
    DEBUG with ``-v`` (which wins over ``-q`` for the log; ``-q`` still hides the bars); written
    so that they never break a progress bar (:class:`_progress.LogHandler`). The INFO lines are
    the package's own: the libraries' (canopen's NMT state changes, python-can's, Dask's) show
    from WARNING, or with ``-v``. Undone at the end, so that ``main`` can run again in the same
    process."""
    from ._progress import LogHandler

    root = logging.getLogger()
    handler = LogHandler()
    handler.setFormatter(_LineFormatter(tracebacks=verbose))
    if not verbose:
        handler.addFilter(lambda r: r.levelno >= logging.WARNING
                          or r.name.partition(".")[0] == "rrr_robot")
    level = logging.DEBUG if verbose else logging.WARNING if quiet else logging.INFO
    handler.setLevel(level)  # also for the libraries whose loggers set their own level (Dask)
    previous = root.level
    root.addHandler(handler)
    root.setLevel(level)
    try:
        yield
    finally:
        root.removeHandler(handler)
        root.setLevel(previous)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``rrr``; returns the exit status: 0 success, 2 bad input or a failure of the run
    (one line ``rrr: error: ...``; argparse's own errors also exit 2), 8 a CAN bench run whose
    inputs were tampered with (TamperedError, the same one line), 130 Ctrl-C (``rrr:
    interrupted``), 143 SIGTERM (``rrr: terminated``); a command may return others (``rrr hil
    plant``: 3 when the plant latched a fault). Nothing is printed as a traceback for these:
    every error of the package (:class:`~rrr_robot.errors.RrrError`), of the file system
    (OSError: a path that cannot be read or written) and of decoding (UnicodeError: a binary
    file given as text) ends here, and an interrupted run leaves its previous results as they were
    (rrr_robot.core.outputs)."""
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        words = sys.argv[1:] if argv is None else argv
        parser = build_parser(_command_of(words))  # only the command's group: a faster start
        args = parser.parse_args(words)
        with _logging(bool(getattr(args, "verbose", False)), quiet(args)):
            return int(args.func(args))
    except KeyboardInterrupt:
        print("rrr: interrupted", file=sys.stderr)
        return 130
    except _Terminated:
        print("rrr: terminated", file=sys.stderr)
        return 143
    except (RrrError, OSError, UnicodeError) as exc:
        print(f"rrr: error: {one_line(exc)}", file=sys.stderr)
        return int(getattr(exc, "exit_status", 2))
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
