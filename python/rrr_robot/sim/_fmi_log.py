"""FMI 2.0 log messages routed to the right receiver, safely.

An FMI 2.0 logger is variadic (printf-like), which ctypes cannot receive, so FMPy formats the
message in a native proxy (``fmpy.logging.addLoggerProxy``). That proxy keeps ONE Python
callback per process: every call replaces it, and an FMU that logs after the callback it was
given has been garbage-collected calls freed memory (a crash seen when a test ran FMPy slaves
after an earlier co-simulation had ended). So this module installs one permanent dispatcher and
gives every instance its own ``fmi2CallbackFunctions`` whose ``componentEnvironment`` is a key
that finds the receiver of its messages; receivers are held weakly and drop out when they die.
"""

from __future__ import annotations

import ctypes as ct
import itertools
import logging
import weakref
from collections.abc import Callable

from fmpy.fmi2 import (
    defaultCallbacks,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

log = logging.getLogger(__name__)

#: A receiver: (status, category, message) -> None.
Receiver = Callable[[int, str, str], None]

_RECEIVERS: dict[int, weakref.ReferenceType[Receiver] | Callable[[], Receiver]] = {}
_KEYS = itertools.count(1)


def _text(value: bytes | None) -> str:
    return value.decode("utf-8", "replace") if value is not None else ""


def _dispatch(env: int | None, instance: bytes | None, status: int, category: bytes | None,
              message: bytes | None) -> None:
    ref = _RECEIVERS.get(env or 0)
    receiver = ref() if ref is not None else None
    if receiver is None:
        log.debug("FMU %s (no receiver): %s", _text(instance), _text(message))
        return
    receiver(int(status), _text(category), _text(message))


# Module level: alive as long as the process, so the native proxy never calls freed memory.
_DISPATCH = fmi2CallbackLoggerTYPE(_dispatch)


def fmi2_callbacks(receiver: Receiver) -> fmi2CallbackFunctions:
    """Callbacks for one fmi2Instantiate whose log messages go to ``receiver``.

    The receiver is held weakly when it is a bound method (its object owns the FMU), strongly
    otherwise; keep the returned structure alive as long as the instance.
    """
    key = next(_KEYS)
    try:
        _RECEIVERS[key] = weakref.WeakMethod(receiver)
    except TypeError:
        _RECEIVERS[key] = lambda: receiver
    cb = fmi2CallbackFunctions()
    cb.logger = _DISPATCH
    cb.allocateMemory = defaultCallbacks.allocateMemory
    cb.freeMemory = defaultCallbacks.freeMemory
    cb.componentEnvironment = ct.c_void_p(key)
    addLoggerProxy(ct.byref(cb))  # the proxy's one callback is (again) the permanent dispatcher
    return cb


def release(cb: fmi2CallbackFunctions) -> None:
    """Forget the receiver of callbacks made by :func:`fmi2_callbacks` (after fmi2FreeInstance)."""
    _RECEIVERS.pop(int(cb.componentEnvironment or 0), None)
