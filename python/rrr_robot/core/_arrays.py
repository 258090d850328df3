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
