"""Progress and log lines on the terminal, the one way every command shows them: tqdm bars on
stderr, only when stderr is a terminal, never with ``-q``; log lines through :class:`LogHandler`,
which writes them above an open bar (tqdm.write) instead of onto its line. Library functions
report progress through callbacks (``progress(k, n)``, ``progress(name, k, n)``) and log through
``logging``; a command turns the callbacks into bars with :class:`Bars`, so the library layers
never touch the terminal."""

from __future__ import annotations

import logging
import sys
from types import TracebackType
from typing import Any

__all__ = ["Bars", "LogHandler", "shown"]

#: The bars open now (tqdm instances) in this process.
_open: list[Any] = []


class LogHandler(logging.Handler):
    """Log records as lines on stderr (the stderr of the moment, so a redirected or captured
    stderr is followed). While a progress bar is open, a line goes through ``tqdm.write``: the
    bar is cleared, the line written, the bar drawn again below it, so a log line never shares
    a line with a bar."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            line = self.format(record)
            if _open:
                from tqdm import tqdm

                tqdm.write(line, file=sys.stderr)
            else:
                sys.stderr.write(line + "\n")
                sys.stderr.flush()
        except Exception:  # logging's own rule: a failing handler never raises
            self.handleError(record)


def shown(quiet: bool) -> bool:
    """Whether a command shows progress: not ``-q`` and stderr is a terminal."""
    return not quiet and sys.stderr.isatty()


class Bars:
    """Named progress bars: ``bars(name, done, total)`` moves the bar ``name`` to ``done`` of
    ``total`` (a new name starts a new bar and ends the previous one); a context manager that
    closes the bars. Disabled, it does nothing and imports nothing."""

    def __init__(self, enabled: bool, unit: str = "step") -> None:
        self.enabled = enabled
        self.unit = unit
        self._bar: Any = None
        self._name: str | None = None

    def __call__(self, name: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        if name != self._name or self._bar is None:
            self.close()
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=name, unit=self.unit, file=sys.stderr,
                             leave=True, dynamic_ncols=True)
            _open.append(self._bar)
            self._name = name
        self._bar.total = total
        self._bar.n = min(max(done, 0), total)
        self._bar.refresh()

    def callback(self, name: str) -> Any:
        """``progress(done, total)`` for a library function with one task."""
        return lambda done, total: self(name, done, total)

    def close(self) -> None:
        """End the current bar (idempotent)."""
        if self._bar is not None:
            bar, self._bar = self._bar, None
            if bar in _open:
                _open.remove(bar)
            bar.close()
            self._name = None

    def __enter__(self) -> Bars:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
