"""What a plant costs to integrate: librrr's stiffness estimate ``rrr_plant_stiffness``
(c_src/rrr/include/rrr/rrr_plant.h, docs/limits.md), |d qdd / d qd| from the friction's
tanh slopes and the inertia, against the limit ``STIFFNESS_MAX`` every simulation of the plant
accepts (the FMU, the native loop, a robot file). Above it a run would take more than
``STIFFNESS_MAX / 3.3`` internal steps per simulated second, whatever the tolerances, so the
parameter set is refused at once with the numbers instead of running for hours."""

from __future__ import annotations

from collections.abc import Mapping

from ..errors import ModelError
from . import _lib
from ._lib import _ext

__all__ = ["STIFFNESS_MAX", "Stiffness", "stiffness"]

#: RRR_PLANT_STIFFNESS_MAX, 1/s
STIFFNESS_MAX = 1e6
_TOO_STIFF = 7  # RRR_TOO_STIFF


class Stiffness(ModelError):
    """A plant too stiff for its integrator; ``field`` names the friction parameter (``w[1,1]``,
    ``b[2]``) with the largest share, ``value`` is the estimate in 1/s."""

    def __init__(self, message: str, field: str, value: float) -> None:
        super().__init__(message, "rrr_plant_stiffness", "RRR_TOO_STIFF")
        self.field = field
        self.value = value


def stiffness(raw: _lib.RawModel, params: Mapping[str, float] | None = None) -> float:
    """The estimate in 1/s; :class:`Stiffness` (a ModelError) when it exceeds
    ``STIFFNESS_MAX``, naming the parameters (``params``: their values by name for the message,
    else read from ``raw``)."""
    status, value, field = _ext.plant_stiffness(raw)
    if status == _TOO_STIFF:
        name = field or "?"
        raise Stiffness(_message(raw, name, value, params), name, value)
    if status != 0:
        _lib.raise_for("rrr_plant_stiffness", status)
    return float(value)


def _message(raw: _lib.RawModel, name: str, value: float,
             params: Mapping[str, float] | None) -> str:
    def show(key: str, v: float) -> str:
        return f"{key} = {params[key] if params is not None and key in params else v:g}"

    if name.startswith("w["):
        i, k = (int(x) - 1 for x in name[2:-1].split(","))
        what = (f"{show('f' + name[1:], raw.f[i][k])} and "  # w[i,k]'s f[i,k]
                f"{show(name, raw.w[i][k])} make")
    else:
        what = f"{show(name, raw.b[int(name[2:-1]) - 1])} makes"
    return (f"{what} the plant too stiff for its integrator: its stiffness |d qdd/d qd| (the "
            f"friction slope k_t |f| w over the inertia) reaches {value:.3g} 1/s, more than the "
            f"{STIFFNESS_MAX:.0e} 1/s a simulation accepts (it would take more than "
            f"{STIFFNESS_MAX / 3.3:.0e} internal steps per simulated second)")
