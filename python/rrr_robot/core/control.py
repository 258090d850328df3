"""The gains of the computed-torque law (eq 15, ``rrr_ctc`` of c_src/rrr/include/rrr/rrr_control.h),
checked once and packed as the C struct ``rrr_ctc_gains`` that :meth:`Model.ctc` passes to C.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import _lib
from ._lib import _ext

Vec3 = tuple[float, float, float]


def _gains(value: ArrayLike, name: str) -> Vec3:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise BadInputError(f"{name} must be 3 finite numbers >= 0, got {value!r}") from exc
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise BadInputError(f"{name} must be 3 finite numbers >= 0, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class CtcGains:
    """Gains and switch of the computed-torque law u = sat(u_n + Kp e + Kd e_dot) (eq 15).

    ``kp`` (V/rad) and ``kd`` (V s/rad): 3 finite numbers >= 0 each (BadInputError otherwise);
    ``feedforward``: add the model feedforward u_n of eq 10 along the reference.
    """

    kp: Vec3
    kd: Vec3
    feedforward: bool = True
    #: the C struct rrr_ctc_gains, as bytes (what Model.ctc hands to C)
    packed: bytes = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        kp, kd = _gains(self.kp, "kp"), _gains(self.kd, "kd")
        if not isinstance(self.feedforward, bool | np.bool_):
            raise BadInputError(f"feedforward must be true or false, got {self.feedforward!r}")
        raw = _lib.RawCtcGains()
        raw.kp[:] = kp
        raw.kd[:] = kd
        raw.feedforward = int(bool(self.feedforward))
        object.__setattr__(self, "kp", kp)
        object.__setattr__(self, "kd", kd)
        object.__setattr__(self, "feedforward", bool(self.feedforward))
        object.__setattr__(self, "packed", bytes(raw))

    @classmethod
    def default(cls) -> CtcGains:
        """The default robot's gains (``rrr_ctc_gains_default``, feedforward on)."""
        raw = _lib.RawCtcGains()
        _ext.ctc_gains_default(raw)
        return cls(tuple(raw.kp), tuple(raw.kd), bool(raw.feedforward))
