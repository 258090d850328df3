"""The settings of the plant's integrator (``rrr_plant_integrator`` of
c_src/rrr/include/rrr/rrr_plant.h), checked once by librrr and packed as the C struct that
:class:`rrr_robot.core.plant.Plant` hands to ``rrr_plant_step``: the FMU parameters
``adaptive``, ``rtol``, ``atol`` and ``h_int`` under the same names and defaults."""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np

from ..errors import BadInputError
from . import _lib
from ._lib import _ext


def _default() -> _lib.RawPlantIntegrator:
    raw = _lib.RawPlantIntegrator()
    _ext.plant_integrator_default(raw)
    return raw


_DEFAULT = _default()


@dataclass(frozen=True)
class PlantIntegrator:
    """How the plant integrates one step (docs: README "The plant's integrator").

    ``adaptive`` (default True): Dormand-Prince 5(4) with error control at ``rtol`` and ``atol``
    (rad, rad/s; each in [1e-14, 1e-2]); False: classic RK4 in substeps of at most ``h_int``
    seconds. ``max_steps`` bounds the internal steps of one call. Out-of-range values are
    refused with BadInputError naming the field (librrr's ``rrr_plant_integrator_check``).
    """

    adaptive: bool = bool(_DEFAULT.adaptive)
    rtol: float = float(_DEFAULT.rtol)
    atol: float = float(_DEFAULT.atol)
    h_int: float = float(_DEFAULT.h_int)
    max_steps: int = int(_DEFAULT.max_steps)
    #: the C struct rrr_plant_integrator, as bytes (what the plant step hands to C)
    packed: bytes = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.adaptive, bool | np.bool_):
            raise BadInputError(f"adaptive must be true or false, got {self.adaptive!r}")
        raw = _lib.RawPlantIntegrator()
        object.__setattr__(self, "adaptive", bool(self.adaptive))
        raw.adaptive = int(self.adaptive)
        for name in ("rtol", "atol", "h_int"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise BadInputError(f"{name} must be a number, got {value!r}")
            setattr(raw, name, float(value))
            object.__setattr__(self, name, float(value))
        steps: object = self.max_steps
        if isinstance(steps, bool) or not isinstance(steps, numbers.Integral):
            raise BadInputError(f"max_steps must be an integer, got {steps!r}")
        if not 1 <= int(steps) <= 2**62:
            raise BadInputError(f"max_steps must be >= 1, got {steps}")
        object.__setattr__(self, "max_steps", int(steps))
        raw.max_steps = self.max_steps
        status, name = _ext.plant_integrator_check(raw)
        if status != 0:
            name = name or "?"
            raise BadInputError(f"plant integrator: {name} out of range, got "
                                f"{getattr(self, name, '?')!r} (rtol and atol in [1e-14, 1e-2], "
                                "h_int > 0 and finite, max_steps >= 1)")
        object.__setattr__(self, "packed", bytes(raw))

    @classmethod
    def fixed_step(cls, h_int: float = float(_DEFAULT.h_int)) -> PlantIntegrator:
        """Classic RK4 in substeps of at most ``h_int`` s (the FMU's ``adaptive = false``)."""
        return cls(adaptive=False, h_int=h_int)
