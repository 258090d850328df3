"""The closed loop in C: ``rr.simulate`` runs librrr's ``rrr_sim_closed_loop`` over a sampled
reference, with the calls and the order of the co-simulation master (:func:`run_cosim`) on the
controller and plant FMUs, and returns the same :class:`CosimResult`: bit for bit the same
numbers, without FMI and Python in the loop.

The FMUs' start values become the C structs as the FMUs' ``set_defaults`` and setters would make
them: librrr's defaults, then the given values by FMU variable name (model parameters through the
C parameter table; the plant's ``q0``, ``qd0``, ``adaptive``, ``rtol``, ``atol``, ``h_int``; the
controller's ``kp``, ``kd``, ``feedforward``). An unknown name is refused, as an FMU would.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

import numpy as np

from ..core import _lib
from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core._lib import _ext
from ..core.control import CtcGains
from ..core.integrator import PlantIntegrator
from ..core.param_names import param_index, set_values
from ..core.stiffness import stiffness
from ..errors import BadInputError
from .cosim import CosimOptions, CosimResult, _check_reference, initial_state_values

__all__ = ["simulate"]

_INTEGRATOR = ("adaptive", "rtol", "atol", "h_int")


def _split(values: Mapping[str, float | bool], extra: set[str], who: str,
           ) -> tuple[dict[str, float], dict[str, float | bool]]:
    """(model parameters, the FMU's other variables); BadInputError for a name it has not."""
    model: dict[str, float] = {}
    other: dict[str, float | bool] = {}
    for name, value in values.items():
        if param_index(name) >= 0:
            model[name] = float(value)
        elif name in extra:
            other[name] = value
        else:
            raise BadInputError(f"the {who} has no variable {name!r} (its model parameters and "
                                f"{', '.join(sorted(extra))})")
    return model, other


def _model(changes: Mapping[str, float]) -> _lib.RawModel:
    raw = _lib.RawModel()
    _ext.model_default(raw)
    return set_values(raw, changes)


def _vector(other: Mapping[str, float | bool], name: str, default: float = 0.0) -> FloatArray:
    return np.array([float(other.get(n, default)) for n in fv.names("plant", name)])


def _plant(values: Mapping[str, float | bool],
           ) -> tuple[_lib.RawModel, _lib.RawPlantIntegrator, FloatArray, FloatArray]:
    extra = {n for v in ("q0", "qd0") for n in fv.names("plant", v)} | set(_INTEGRATOR)
    model, other = _split(values, extra, "plant")
    settings: dict[str, float | bool] = {
        name: other[name] for name in ("rtol", "atol", "h_int") if name in other}
    if "adaptive" in other:
        settings["adaptive"] = bool(other["adaptive"])
    integ = PlantIntegrator(**settings)  # type: ignore[arg-type]
    return (_model(model), _lib.RawPlantIntegrator.from_buffer_copy(integ.packed),
            _vector(other, "q0"), _vector(other, "qd0"))


def _controller(values: Mapping[str, float | bool]) -> tuple[_lib.RawModel, _lib.RawCtcGains]:
    extra = {n for g in ("kp", "kd") for n in fv.names("controller", g)} | {"feedforward"}
    model, other = _split(values, extra, "controller")
    default = CtcGains.default()
    kp = [float(other.get(n, d)) for n, d in zip(fv.names("controller", "kp"), default.kp,
                                                 strict=True)]
    kd = [float(other.get(n, d)) for n, d in zip(fv.names("controller", "kd"), default.kd,
                                                 strict=True)]
    gains = CtcGains(kp=(kp[0], kp[1], kp[2]), kd=(kd[0], kd[1], kd[2]),
                     feedforward=bool(other.get("feedforward", default.feedforward)))
    return _model(model), _lib.RawCtcGains.from_buffer_copy(gains.packed)


#: wall time one C call of the loop may take before Python runs again (Ctrl-C, SIGTERM, the
#: progress callback), s; the parts are sized from the time the previous one took
PART_SECONDS = 0.05
_FIRST_PART = 256  # samples of the first call (its setup validates both models: about 2 ms)
_MAX_PART = 1 << 20


def _run_in_parts(n: int, options: CosimOptions,
                  part: Callable[[int, _lib.RawSimCarry], tuple[int, int]], t: FloatArray) -> None:
    """``rrr_sim_closed_loop_part`` until the n samples are written, each call about
    PART_SECONDS long: a signal handler (KeyboardInterrupt, the CLI's SIGTERM) runs between two
    calls, so a run ends within about that time; no allocation in C, the state between the calls
    is the caller's :class:`_lib.RawSimCarry`."""
    carry = _lib.RawSimCarry()
    count = _FIRST_PART
    while carry.next < n:
        begin = time.perf_counter()
        status, k = part(count, carry)
        if status != 0:
            # k: 0 also when the setup (models, settings, initial state) failed
            where = (f"sample {k} (t = {t[min(k, n - 1)]:.6f} s)"
                     + (" or its setup" if k == 0 else ""))
            _lib.raise_for("rrr_sim_closed_loop", status, f"at {where}")
        elapsed = time.perf_counter() - begin
        if options.progress is not None:
            options.progress(int(carry.next) - 1, n)
        scale = PART_SECONDS / elapsed if elapsed > 0.0 else 4.0
        count = max(1, min(_MAX_PART, int(count * min(4.0, scale))))


def simulate(t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray, qdd_ref: FloatArray,
             x_ref: FloatArray, options: CosimOptions | None = None) -> CosimResult:
    """The closed loop of :func:`~rrr_robot.sim.cosim.run_cosim` in C, bit-identical to the
    FMUs' co-simulation.

    ``options`` as for :func:`~rrr_robot.sim.cosim.run_cosim`; FMU files and the
    measurement/actuation hooks (a CAN bench's quantisation) belong to the FMU engine and are
    refused here.
    """
    options = options if options is not None else CosimOptions()
    _check_reference(t, q_ref, qd_ref, qdd_ref, options.step)
    if options.measure is not None or options.actuate is not None:
        raise BadInputError("the native engine has no measurement or actuation hooks (they model "
                            "a CAN bench): run the FMUs (run_cosim) for those")
    if options.plant_fmu is not None or options.controller_fmu is not None:
        raise BadInputError("the native engine runs librrr, not FMU files: leave plant_fmu and "
                            "controller_fmu unset, or run the FMUs (run_cosim)")
    n = t.shape[0]
    plant_values = initial_state_values(q_ref[0], qd_ref[0])
    plant_values |= dict(options.plant_values)
    plant, integ, q0, qd0 = _plant(plant_values)
    ctrl, gains = _controller(options.controller_values)
    ref = np.ascontiguousarray(np.hstack([q_ref, qd_ref, qdd_ref]), dtype=np.float64)
    plant_rec = np.empty((n, 12))
    ctrl_rec = np.empty((n, 9))
    stiffness(plant)  # a plant too stiff to integrate: refused with the numbers, at once
    start, start_cpu = time.perf_counter(), time.thread_time()
    def part(count: int, carry: _lib.RawSimCarry) -> tuple[int, int]:
        return _ext.sim_closed_loop_part(plant, integ, q0, qd0, ctrl, gains, float(options.step),
                                         ref, plant_rec, ctrl_rec, count, carry)

    _run_in_parts(n, options, part, t)
    wall, cpu = time.perf_counter() - start, time.thread_time() - start_cpu
    return CosimResult(
        t=t, q_ref=q_ref, qd_ref=qd_ref, x_ref=x_ref,
        q=plant_rec[:, 0:3], qd=plant_rec[:, 3:6], qdd=plant_rec[:, 6:9], tip=plant_rec[:, 9:12],
        u=ctrl_rec[:, 0:3], u_n=ctrl_rec[:, 3:6], u_c=ctrl_rec[:, 6:9], wall_time=wall,
        cpu_time=cpu,
    )
