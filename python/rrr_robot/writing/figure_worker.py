"""The figures that depend on the writing reference only (Figs 2, 3, 4 and, with their numeric
references, 5 and 6), drawn by a forked worker while the co-simulations run.

They need nothing of the co-simulations, and they are half of the figures phase: the Robotics
Toolbox's import and IK and Pinocchio's rnea for Figs 5 and 6 (about 1.5 s) and five figures.
On Linux :class:`ReferenceFigures` forks a worker as soon as the run's staging folder exists;
it draws them there (each PNG written atomically, core.outputs) on the other core while this
process co-simulates, and :meth:`ReferenceFigures.finish` waits for it. Where fork is not
available, or when the worker fails in any way, ``finish`` draws them in this process, so the
figures and the errors are those of a run without the worker. The worker ignores SIGINT (Ctrl-C
is the parent's to handle), dies with its parent (PR_SET_PDEATHSIG) and is stopped by
:meth:`ReferenceFigures.close` (the end of the ``with`` block), also when the run fails.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import signal
import sys
from pathlib import Path
from typing import Any

from ..core.model import Model
from ..core.robot import RobotFile
from .trajectory import Reference

log = logging.getLogger(__name__)

__all__ = ["ReferenceFigures"]


def _die_with_parent() -> None:
    """Linux: this process gets SIGKILL when the process that started it ends (a killed run
    leaves no worker behind). Elsewhere nothing."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _draw(out: Path, model: Model, robot: RobotFile, ref: Reference) -> None:
    from .plots import write_reference_figures  # matplotlib: in the process that draws

    write_reference_figures(out, model, robot, ref)


class _Records(logging.Handler):
    """The worker's log records, kept to be sent to the parent, which logs them: the worker
    never writes to the terminal itself (its lines would land on the parent's progress bar)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        record.msg, record.args = record.getMessage(), None  # picklable, formatted here
        record.exc_info = record.exc_text = None
        self.records.append(record)


def _keep_logs() -> _Records:
    """In the worker: the root logger's handlers (inherited from the parent) replaced by one
    that keeps the records."""
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    keep = _Records()
    root.addHandler(keep)
    return keep


def _worker(conn: Any, out: Path, model: Model, robot: RobotFile, ref: Reference) -> None:
    """The forked process: draw, report (with its log records), exit quietly (never a
    traceback of its own)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent()
    logs = _keep_logs()
    try:
        _draw(out, model, robot, ref)
        conn.send(("ok", logs.records))
    except BaseException as exc:  # any failure: the parent draws again and raises it
        with contextlib.suppress(BaseException):
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


class ReferenceFigures:
    """Figs 2-6 of a run, drawn into ``out`` by a forked worker started here (Linux; see the
    module docstring). ``start=False``: no worker (:meth:`finish` draws them here)."""

    def __init__(self, out: Path, model: Model, robot: RobotFile, ref: Reference,
                 start: bool = True) -> None:
        self._args = (Path(out), model, robot, ref)
        self._proc: Any = None
        self._conn: Any = None
        if start and sys.platform.startswith("linux"):
            import multiprocessing  # here: a run without figures does not import it

            ctx = multiprocessing.get_context("fork")
            self._conn, child = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_worker, args=(child, *self._args), daemon=True,
                                     name="rrr-reference-figures")
            self._proc.start()
            child.close()

    @property
    def running(self) -> bool:
        """Whether a worker was started and not yet collected."""
        return self._proc is not None

    def finish(self) -> None:
        """Wait for the worker; if there was none, or it did not draw every figure, draw them
        in this process (errors are raised here)."""
        if self._conn is not None:
            try:
                status, detail = self._conn.recv()
            except (EOFError, OSError):
                status, detail = "error", "the worker ended without a word"
            finally:
                self.close()
            if status == "ok":
                for record in detail:  # the worker's log lines, logged here
                    logging.getLogger(record.name).handle(record)
                return
            log.debug("reference figures drawn again in this process: %s", detail)
        _draw(*self._args)

    def close(self) -> None:
        """Stop the worker if it still runs; idempotent."""
        proc, self._proc = self._proc, None
        conn, self._conn = self._conn, None
        if conn is not None:
            conn.close()
        if proc is not None:
            if proc.is_alive():
                proc.terminate()
            proc.join(5.0)
            if proc.is_alive():
                proc.kill()
                proc.join()

    def __enter__(self) -> ReferenceFigures:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
