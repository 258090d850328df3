"""librrr's batch calls (``rrr_batch.h``): n states in one C call, with kernels vectorised over
the states (AVX2, AVX-512, with glibc's vector sin and cos) chosen from the CPU's features, or
the scalar path, bit for bit the one-state calls.
:meth:`rrr_robot.core.model.Model.inverse_dynamics` uses them for batches (its ``simd``
argument). The vector kernels' results differ from the
scalar path's by rounding only: within 1e-13 N m (tests/c/test_batch.c,
tests/python/unit/test_batch.py); they exist in librrr built with GCC for x86-64 Linux."""

from __future__ import annotations

from typing import NoReturn

from ..errors import BadInputError
from ._lib import _ext

__all__ = ["PATHS_HERE", "SIMD_PATHS", "refuse", "simd_available", "simd_best"]

#: The paths by name, with their ``rrr_simd`` values.
SIMD_PATHS = {"auto": 0, "scalar": 1, "avx2": 2, "avx512": 3}
_NAMES = {v: k for k, v in SIMD_PATHS.items()}


def simd_available() -> tuple[str, ...]:
    """The paths this librrr and this CPU can run ("auto" and "scalar" always)."""
    return tuple(PATHS_HERE)


def simd_best() -> str:
    """The path "auto" means here: "avx512", "avx2" or "scalar"."""
    return _NAMES[int(_ext.simd_best())]


#: The paths this librrr and CPU run, by name (what ``simd=`` takes), computed once.
PATHS_HERE = {name: v for name, v in SIMD_PATHS.items() if _ext.simd_available(v)}


def refuse(simd: object) -> NoReturn:
    """The BadInputError of a ``simd`` argument that is not a path name here."""
    if isinstance(simd, str) and simd in SIMD_PATHS:
        raise BadInputError(f"simd={simd!r} is not available here (this librrr and CPU run: "
                            f"{', '.join(PATHS_HERE)})")
    raise BadInputError(f"simd must be one of {', '.join(SIMD_PATHS)}, got {simd!r}")
