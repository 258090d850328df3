"""The parameter values an SSP archive binds, checked before any tool runs it, as strictly as a
robot file's and a scenario file's values (the same field checks and bounds), so that no tool
is handed a value an FMU refuses (libcosim aborts the process when an FMU refuses a value in its
worker thread, leaving its temporary folders behind).

Per component (the FMUs of ``rrr ssp``; the components' other parameters keep the FMUs' start
values, which are the default robot's):

- plant and controller: every model parameter (``d1`` ... ``u_max``, ``p[k]``, ``kt[i]``,
  ``f[i,k]``, ``w[i,k]``, ``b[i]``) as a robot file checks it (finite, its lower bound from the
  C parameter table, magnitude <= 1e6), then the model as a whole (``rrr_model_validate``: D(q)
  positive definite, ...);
- plant: ``q0[i]``, ``qd0[i]`` finite of magnitude <= 1e6; ``adaptive`` (Boolean), ``rtol``,
  ``atol``, ``h_int`` as the plant's integrator checks them;
- controller: ``kp[i]``, ``kd[i]`` as a scenario's [gains] (>= 0 and <= 1e6), ``feedforward``
  (Boolean), ``lead`` in [0, 1] s;
- reference: ``lookahead`` in [0, 1] s.

A Real bound to a Boolean variable, or the reverse, is refused too.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..core import fmu_vars as fv
from ..core.checked import Field, Flag, Invalid, Number, show
from ..core.integrator import PlantIntegrator
from ..core.model import Model
from ..core.param_names import param_index, set_values
from ..core.robot import GAIN, MAX_MAGNITUDE, param_check
from ..errors import BadInputError, ModelError

__all__ = ["MAX_LEAD", "check_bindings"]

#: The controller's ``lead`` and the reference FMU's ``lookahead``: at most 1 s (the FMUs' bound).
MAX_LEAD = 1.0
_LEAD = Number(lo=0.0, hi=MAX_LEAD)
_STATE = Number(lo=-MAX_MAGNITUDE, hi=MAX_MAGNITUDE)
#: The checks of the components' parameters that are not model parameters.
FIELDS: dict[str, dict[str, Field]] = {
    "plant": {**dict.fromkeys(fv.names("plant", "q0") + fv.names("plant", "qd0"), _STATE),
              "adaptive": Flag(), "rtol": Number(), "atol": Number(), "h_int": Number()},
    "controller": {**dict.fromkeys(fv.names("controller", "kp") + fv.names("controller", "kd"),
                                   GAIN),
                   "feedforward": Flag(), "lead": _LEAD},
    "reference": {"lookahead": _LEAD},
}
_WITH_MODEL = ("plant", "controller")
_INTEGRATOR = ("adaptive", "rtol", "atol", "h_int")


def _check_value(where: str, comp: str, name: str, value: float | bool, kind: str) -> None:
    if kind not in ("Real", "Boolean"):
        raise BadInputError(f"{where}: component {comp}: parameter {name} is a {kind} variable "
                            "(only Real and Boolean parameters can be bound)")
    if (kind == "Boolean") != isinstance(value, bool):
        given = "a Boolean" if isinstance(value, bool) else "a Real"
        raise BadInputError(f"{where}: component {comp}: parameter {name} is a {kind} "
                            f"variable, the archive binds {given} value")
    fields = FIELDS.get(comp, {})
    check: Field | None = fields.get(name)
    if check is None and comp in _WITH_MODEL and param_index(name) >= 0:
        check = param_check(name)
    if check is None:
        known = ", ".join(fields) if comp not in _WITH_MODEL else \
            f"the model parameters and {', '.join(fields)}"
        raise BadInputError(f"{where}: component {comp}: parameter {name} is not one an archive "
                            f"of rrr ssp binds ({known})")
    try:
        check.check(value)
    except Invalid as exc:
        raise BadInputError(f"{where}: component {comp}: parameter {name} {exc.requirement}, "
                            f"got {show(value)}") from None


def check_bindings(params: Mapping[str, Mapping[str, float | bool]],
                   kinds: Mapping[str, Mapping[str, str]], where: str) -> None:
    """Check every component's bound values (``params``: component -> name -> value) against
    the checks above; ``kinds``: component -> variable name -> its type ("Real", "Boolean");
    BadInputError naming the archive, the component, the parameter and the bound."""
    for comp, values in params.items():
        for name, value in values.items():
            _check_value(where, comp, name, value, kinds.get(comp, {}).get(name, "?"))
        if comp in _WITH_MODEL:
            model = {n: float(v) for n, v in values.items() if param_index(n) >= 0}
            raw = Model.default().raw
            try:
                Model(set_values(raw, model))
            except (BadInputError, ModelError) as exc:
                raise BadInputError(f"{where}: component {comp}: its model parameters are "
                                    f"refused: {exc}") from None
        if comp == "plant":
            settings = {n: values[n] for n in _INTEGRATOR if n in values}
            try:
                PlantIntegrator(**settings)  # type: ignore[arg-type]
            except BadInputError as exc:
                raise BadInputError(f"{where}: component plant: {exc}") from None
