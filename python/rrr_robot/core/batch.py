"""librrr's batch calls (``rrr_batch.h``): n states in one C call, with kernels vectorised over
the states (AVX2, AVX-512, with glibc's vector sin and cos) chosen from the CPU's features, or
the scalar path, bit for bit the one-state calls. :meth:`rrr_robot.Model.inverse_dynamics`
uses them for batches (its ``simd`` argument). The vector kernels' results differ from the
scalar path's by rounding only: within 1e-13 N m (tests/c/test_batch.c,
tests/python/test_batch.py); they exist in librrr built with GCC for x86-64 Linux."""

from __future__ import annotations

import ctypes as ct
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import _lib
from ._arrays import FloatArray, broadcast_rows, ptr

__all__ = ["SIMD_PATHS", "inverse_dynamics_batch", "simd_available", "simd_best"]

#: The paths by name, with their ``rrr_simd`` values.
SIMD_PATHS = {"auto": 0, "scalar": 1, "avx2": 2, "avx512": 3}
_NAMES = {v: k for k, v in SIMD_PATHS.items()}


def simd_available() -> tuple[str, ...]:
    """The paths this librrr and this CPU can run ("auto" and "scalar" always)."""
    return tuple(name for name, v in SIMD_PATHS.items() if _lib.LIB.rrr_simd_available(v))


def simd_best() -> str:
    """The path "auto" means here: "avx512", "avx2" or "scalar"."""
    return _NAMES[int(_lib.LIB.rrr_simd_best())]


def _path(simd: str) -> int:
    if simd not in SIMD_PATHS:
        raise BadInputError(f"simd must be one of {', '.join(SIMD_PATHS)}, got {simd!r}")
    if not _lib.LIB.rrr_simd_available(SIMD_PATHS[simd]):
        raise BadInputError(f"simd={simd!r} is not available here (this librrr and CPU run: "
                            f"{', '.join(simd_available())})")
    return SIMD_PATHS[simd]


def inverse_dynamics_batch(raw: Any, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                           simd: str = "auto") -> FloatArray | None:
    """tau rows of ``rrr_inverse_dynamics_batch`` for (n, 3) inputs (rows broadcast as the
    one-state calls do) on the model ``raw`` (a :class:`_lib.RawModel`); None when a row fails
    (the caller's one-state path then raises its error for that row)."""
    path = _path(simd)
    (qs, qds, qdds), _ = broadcast_rows((q, "q"), (qd, "qd"), (qdd, "qdd"))
    n = qs.shape[0]
    tau = np.empty((n, 3))
    done = ct.c_size_t(0)
    status = _lib.FUNCS["rrr_inverse_dynamics_batch"](ct.byref(raw), n, ptr(qs), ptr(qds),
                                                      ptr(qdds), ptr(tau), path,
                                                      ct.byref(done))
    return tau if status == 0 else None
