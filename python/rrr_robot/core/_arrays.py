"""Shape handling shared by the Pythonic layer: one vector (3,) or a batch (n, 3)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import BadInputError

FloatArray = NDArray[np.float64]


def as_rows(value: ArrayLike, name: str, width: int = 3) -> tuple[FloatArray, bool]:
    """Return (array of shape (n, width): float64, C-contiguous, aligned; was_batch); raise
    BadInputError on a wrong shape."""
    try:
        raw = np.asarray(value)
        if not np.iscomplexobj(raw):
            arr = np.ascontiguousarray(raw, dtype=np.float64)
            if not arr.flags.aligned:  # C reads doubles at aligned addresses only
                arr = arr.copy()
    except (TypeError, ValueError) as exc:
        raise BadInputError(f"{name} must be an array of numbers: {exc}") from exc
    if np.iscomplexobj(raw):
        raise BadInputError(f"{name} must be real, got complex values")
    if arr.ndim == 1 and arr.shape[0] == width:
        return arr.reshape(1, width), False
    if arr.ndim == 2 and arr.shape[1] == width:
        return arr, True
    raise BadInputError(f"{name} must have shape ({width},) or (n, {width}), got {arr.shape}")


def broadcast_rows(*pairs: tuple[ArrayLike, str]) -> tuple[list[FloatArray], bool]:
    """Convert several (value, name) pairs to (n, 3) arrays of a common n."""
    rows = [as_rows(v, name) for v, name in pairs]
    if not any(b for _, b in rows):  # fast path: single vectors, nothing to broadcast
        return [a for a, _ in rows], False
    n = max(a.shape[0] for a, _ in rows)
    out = []
    for (a, _), (_, name) in zip(rows, pairs, strict=True):
        if a.shape[0] not in (1, n):
            raise BadInputError(f"{name} has {a.shape[0]} rows, expected {n}")
        out.append(np.ascontiguousarray(np.broadcast_to(a, (n, a.shape[1]))))
    return out, True


def ptr(a: FloatArray) -> int:
    """Address of the data of a C-contiguous float64 array (passed as a C double pointer)."""
    return int(a.ctypes.data)


def rows_of(a: FloatArray) -> tuple[int, int]:
    """(address of row 0, bytes between rows) of a C-contiguous (n, ...) float64 array, so a loop
    over rows passes ``base + i * stride`` without building ctypes objects per row."""
    return int(a.ctypes.data), int(a.strides[0])
