"""Progress on the terminal, the one way every command shows it: tqdm bars on stderr, only when
stderr is a terminal, never with ``-q``. Library functions report progress through callbacks
(``progress(k, n)``, ``progress(name, k, n)``); a command turns them into bars with
:class:`Bars`, so the library layers never touch the terminal."""

from __future__ import annotations

import sys
from types import TracebackType
from typing import Any

__all__ = ["Bars", "shown"]


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
            self._bar.close()
            self._bar = None
            self._name = None

    def __enter__(self) -> Bars:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
