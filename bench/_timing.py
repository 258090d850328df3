"""Timing and statistics shared by the bench scripts: the clocks, interleaved blocks, series of
per-repeat values with their min / median / max, the progress log on stderr, and ``--quick``
(the same script on small inputs, so that the test command runs each one end to end: it prints
its tables; nothing about the figures is asserted).

The machines these scripts run on are shared and noisy, so a figure is never one timing: each
is a :class:`Series` over repeats, and a ratio is taken within a repeat of blocks that ran
alternately (:func:`interleaved`), so that a change of load affects both sides alike.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

T = TypeVar("T")

#: The clocks of the blocks, in ns: the CPU time of the calling thread (the time spent waiting
#: for a core on a loaded machine is left out; every call timed so runs on the calling thread)
#: or the wall clock.
CLOCKS: dict[str, Callable[[], int]] = {"cpu": time.thread_time_ns, "wall": time.perf_counter_ns}
#: The same clocks in seconds.
CLOCKS_S: dict[str, Callable[[], float]] = {"cpu": time.thread_time, "wall": time.perf_counter}


def logger(name: str) -> Callable[[str], None]:
    """A ``log(msg)`` that prints ``[name] msg`` on stderr (the tables go to stdout)."""

    def log(msg: str) -> None:
        print(f"[{name}] {msg}", file=sys.stderr, flush=True)

    return log


@dataclass(frozen=True)
class Series:
    """Values per repeat (seconds, ns per call, or ratios) with their min / median / max."""

    values: tuple[float, ...]

    @classmethod
    def of(cls, values: Iterable[float]) -> Series:
        return cls(tuple(float(v) for v in values))

    @property
    def min(self) -> float:
        return min(self.values)

    @property
    def median(self) -> float:
        return statistics.median(self.values)

    @property
    def max(self) -> float:
        return max(self.values)

    def over(self, other: Series) -> Series:
        """The per-repeat ratio self / other (both of the same interleaved repeats)."""
        return Series(tuple(a / b for a, b in zip(self.values, other.values, strict=True)))

    def format(self, fmt: str | Callable[[float], str] = ".3g", sep: str = " / ") -> str:
        """``min / median / max``, each formatted by ``fmt`` (a format spec or a function)."""
        f = fmt if callable(fmt) else (lambda v: format(v, fmt))
        return sep.join(f(v) for v in (self.min, self.median, self.max))


def mmm(values: Iterable[float], fmt: str | Callable[[float], str] = ".3g",
        sep: str = " / ") -> str:
    """``min / median / max`` of ``values``: see :meth:`Series.format`."""
    return Series.of(values).format(fmt, sep)


def interleaved(blocks: Sequence[Callable[[], float]], repeats: int,
                warmup: bool = True) -> list[Series]:
    """Run one block of each callable per repeat (in order on even repeats, reversed on odd
    ones), after one warm-up block each unless ``warmup`` is false; each block returns its own
    measure (ns per call, seconds, ...). The garbage collector is off while the blocks run."""
    if warmup:
        for run in blocks:
            run()
    out: list[list[float]] = [[] for _ in blocks]
    gc.disable()
    try:
        for r in range(repeats):
            order = range(len(blocks)) if r % 2 == 0 else reversed(range(len(blocks)))
            for j in order:
                out[j].append(blocks[j]())
    finally:
        gc.enable()
    return [Series(tuple(v)) for v in out]


def timed(fn: Callable[[], T], clock: Callable[[], float] = time.perf_counter
          ) -> tuple[T, float]:
    """``fn()``'s result and the seconds it took by ``clock`` (the wall clock by default)."""
    start = clock()
    result = fn()
    return result, clock() - start


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
