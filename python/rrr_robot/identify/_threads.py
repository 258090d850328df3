"""BLAS threads of the identification's least-squares phases: one.

The problems are small and tall (the stacked regressor has 16 columns, the friction regression
a few dozen, the excitation design's regressor 300 rows): a BLAS thread pool cannot speed them
up, and on a loaded machine its threads wait for cores, so a fit that takes milliseconds took
a hundred (bench/bench_identify.py: the 16 base parameters from 10 s of 1 kHz data with two
CPU hogs running, numpy's and scipy's OpenBLAS at 2 threads against 1). :func:`one_blas_thread`
limits every BLAS library loaded (numpy's and scipy's OpenBLAS, MKL, ...) to one thread for
the duration of a call, through threadpoolctl, and restores them afterwards.
"""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Callable, Iterator
from typing import ParamSpec, TypeVar

from threadpoolctl import threadpool_limits

__all__ = ["BLAS_THREADS", "blas_threads", "one_blas_thread"]

P = ParamSpec("P")
R = TypeVar("R")

#: BLAS threads in the least-squares phases; None leaves the libraries as they are (the
#: comparison in bench/bench_identify.py).
BLAS_THREADS: int | None = 1


class _Inside(threading.local):
    """Whether this thread is within blas_threads() (nested calls then do nothing)."""

    depth: int = 0


_inside = _Inside()


@contextlib.contextmanager
def blas_threads() -> Iterator[None]:
    """A context in which the BLAS libraries use :data:`BLAS_THREADS` threads (threadpoolctl
    looks the libraries up anew each time, about a millisecond: nested contexts skip it)."""
    if BLAS_THREADS is None or _inside.depth:
        yield
        return
    with threadpool_limits(limits=BLAS_THREADS, user_api="blas"):
        _inside.depth = 1
        try:
            yield
        finally:
            _inside.depth = 0


def one_blas_thread(func: Callable[P, R]) -> Callable[P, R]:
    """Run ``func`` within :func:`blas_threads` (the limit is set when it is called, not when
    the module is imported; nested calls keep it)."""

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with blas_threads():
            return func(*args, **kwargs)

    return wrapper
