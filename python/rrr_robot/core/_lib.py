"""Raw ctypes layer over librrr: structures and signatures declared once, one status check.

Everything model-related is computed in C; this module only moves arrays across.
"""

from __future__ import annotations

import ctypes as ct
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import RrrError
from ._package import PACKAGE_DIR
from ._status import STATUS_NAMES as STATUS_NAMES  # the status table lives in _status
from ._status import raise_for as raise_for

NP = 16
D3 = ct.c_double * 3
D33 = (ct.c_double * 3) * 3
DP = ct.c_double * NP
D3P = (ct.c_double * NP) * 3


class RawModel(ct.Structure):
    """Mirror of ``rrr_model`` (c_src/rrr/include/rrr/rrr_model.h)."""

    _fields_ = [
        ("d1", ct.c_double),
        ("a2", ct.c_double),
        ("a3", ct.c_double),
        ("d2", ct.c_double),
        ("d3", ct.c_double),
        ("g", ct.c_double),
        ("p", DP),
        ("kt", D3),
        ("f", D33),
        ("w", D33),
        ("b", D3),
        ("u_max", ct.c_double),
    ]


class RawLink(ct.Structure):
    """Mirror of ``rrr_link_inertia``."""

    _fields_ = [("mass", ct.c_double), ("com", D3), ("inertia_com", D33)]


class RawInertial(ct.Structure):
    """Mirror of ``rrr_inertial``."""

    _fields_ = [("link", RawLink * 3), ("rotor_inertia", D3)]


class RawIkSet(ct.Structure):
    """Mirror of ``rrr_ik_set``."""

    _fields_ = [("n", ct.c_int), ("q", (ct.c_double * 3) * 4), ("branch", ct.c_int * 4)]


class RawSingularity(ct.Structure):
    """Mirror of ``rrr_singularity``."""

    _fields_ = [
        ("flags", ct.c_uint),
        ("elbow_margin", ct.c_double),
        ("shoulder_margin", ct.c_double),
        ("det_jacobian", ct.c_double),
    ]


class RawCtcGains(ct.Structure):
    """Mirror of ``rrr_ctc_gains`` (c_src/rrr/include/rrr/rrr_control.h)."""

    _fields_ = [("kp", D3), ("kd", D3), ("feedforward", ct.c_int)]


class RawCtcOutput(ct.Structure):
    """Mirror of ``rrr_ctc_output``."""

    _fields_ = [("u", D3), ("u_n", D3), ("u_c", D3), ("saturated", ct.c_uint)]


class RawCtcDerivatives(ct.Structure):
    """Mirror of ``rrr_ctc_derivatives`` (c_src/rrr/include/rrr/rrr_derivatives.h): du[k][i][j]
    = d u_i / d (input k)_j, inputs q_ref, qd_ref, qdd_ref, q, qd."""

    _fields_ = [("out", RawCtcOutput), ("du", (D3 * 3) * 5), ("du_n", (D3 * 3) * 5),
                ("du_c", (D3 * 3) * 5)]


class RawPlantDerivatives(ct.Structure):
    """Mirror of ``rrr_plant_derivatives``: qdd and d qdd / d(q, qd, u)."""

    _fields_ = [("qdd", D3), ("dqdd_dq", D3 * 3), ("dqdd_dqd", D3 * 3), ("dqdd_du", D3 * 3),
                ("saturated", ct.c_uint)]


class RawPlantIntegrator(ct.Structure):
    """Mirror of ``rrr_plant_integrator`` (c_src/rrr/include/rrr/rrr_plant.h)."""

    _fields_ = [("adaptive", ct.c_int), ("rtol", ct.c_double), ("atol", ct.c_double),
                ("h_int", ct.c_double), ("max_steps", ct.c_long)]


class RawPlantState(ct.Structure):
    """Mirror of ``rrr_plant_state``: q, qd and the adaptive step-size controller's memory."""

    _fields_ = [("q", D3), ("qd", D3), ("h_guess", ct.c_double), ("err_prev", ct.c_double)]


class RawSimCarry(ct.Structure):
    """Mirror of ``rrr_sim_carry`` (rrr_sim.h): where a closed loop run in parts stands."""

    _fields_ = [("x", RawPlantState), ("qdd", D3), ("tip", D3), ("next", ct.c_size_t)]


class RawPlantStats(ct.Structure):
    """Mirror of ``rrr_plant_stats``: the work of one ``rrr_plant_step`` call."""

    _fields_ = [("steps", ct.c_long), ("rejected", ct.c_long), ("evals", ct.c_long)]


class RawParamInfo(ct.Structure):
    """Mirror of ``rrr_param_info`` (c_src/rrr/include/rrr/rrr_params.h): one row of the C
    parameter table."""

    _fields_ = [
        ("name", ct.c_char * 8),
        ("unit", ct.c_char * 8),
        ("offset", ct.c_size_t),
        ("bound", ct.c_int),          # enum rrr_param_bound
        ("description", ct.c_char * 80),
    ]


#: ``rrr_param_bound`` values: the lower bound of a parameter (every value must be finite).
PARAM_ANY, PARAM_NONNEG, PARAM_POS = 0, 1, 2


_P = ct.POINTER
_M = _P(RawModel)
_D = ct.c_void_p  # double arrays travel as addresses (ints): numpy rows without ctypes objects

# name -> argument types; every function returns rrr_status (int)
_SIGNATURES: dict[str, list[Any]] = {
    "rrr_model_default": [_M],
    "rrr_inertial_default": [_P(RawInertial)],
    "rrr_model_validate": [_M, _P(ct.c_char_p)],
    "rrr_bps_from_inertia": [_M, _P(RawInertial), _D],
    "rrr_fk": [_M, _D, _D, _D],
    "rrr_fk_frames": [_M, _D, _D],
    "rrr_jacobian": [_M, _D, _D],
    "rrr_tip_motion": [_M, _D, _D, _D, _D, _D],
    "rrr_joint_motion": [_M, _D, _D, _D, _D, _D],
    "rrr_ik_branch": [_M, _D, ct.c_int, ct.c_int, _D],
    "rrr_ik": [_M, _D, _P(RawIkSet)],
    "rrr_ik_nearest": [_M, _D, _D, _D, _P(ct.c_int)],
    "rrr_singularity_classify": [_M, _D, ct.c_double, _P(RawSingularity)],
    "rrr_workspace_margin": [_M, _D, _D, _P(ct.c_uint)],
    "rrr_regressor": [_M, _D, _D, _D, _D],
    "rrr_inverse_dynamics": [_M, _D, _D, _D, _D],
    "rrr_mass_matrix": [_M, _D, _D],
    "rrr_coriolis": [_M, _D, _D, _D],
    "rrr_gravity": [_M, _D, _D],
    "rrr_forward_dynamics": [_M, _D, _D, _D, _D],
    "rrr_energy": [_M, _D, _D, _D, _D],
    "rrr_friction": [_M, _D, _D],
    "rrr_voltage_from_torque": [_M, _D, _D, _D],
    "rrr_torque_from_voltage": [_M, _D, _D, _D],
    "rrr_ctc_gains_default": [_P(RawCtcGains)],
    "rrr_ctc": [_M, _P(RawCtcGains), _D, _D, _D, _D, _D, _P(RawCtcOutput)],
    "rrr_plant_integrator_default": [_P(RawPlantIntegrator)],
    "rrr_plant_integrator_check": [_P(RawPlantIntegrator), _P(ct.c_char_p)],
    "rrr_plant_state_init": [_D, _D, _P(RawPlantState)],
    "rrr_plant_stiffness": [_M, _P(ct.c_double), _P(ct.c_char_p)],
    "rrr_plant_accel": [_M, _P(RawPlantState), _D, _D],
    "rrr_plant_jacobian": [_M, _P(RawPlantState), _D, _P(RawPlantDerivatives)],
    "rrr_ctc_jacobian": [_M, _P(RawCtcGains), _D, _D, _D, _D, _D, _P(RawCtcDerivatives)],
    "rrr_plant_step": [_M, _P(RawPlantIntegrator), _D, ct.c_double, _P(RawPlantState), _D,
                       _P(RawPlantStats)],
    "rrr_inverse_dynamics_batch": [_M, ct.c_size_t, _D, _D, _D, _D, ct.c_int,
                                   _P(ct.c_size_t)],
    "rrr_regressor_batch": [_M, ct.c_size_t, _D, _D, _D, _D, ct.c_int, _P(ct.c_size_t)],
    "rrr_fk_batch": [_M, ct.c_size_t, _D, _D, _D, ct.c_int, _P(ct.c_size_t)],
    "rrr_forward_dynamics_batch": [_M, ct.c_size_t, _D, _D, _D, _D, ct.c_int,
                                   _P(ct.c_size_t)],
    "rrr_ik_batch": [_M, ct.c_size_t, _D, ct.c_int, ct.c_int, _D, _P(ct.c_int), ct.c_int,
                     _P(ct.c_size_t)],
    "rrr_plant_rollout": [_M, _P(RawPlantIntegrator), ct.c_size_t, _D, ct.c_double,
                          _P(RawPlantState), _D, _D, _D, _P(ct.c_size_t), _P(RawPlantStats)],
    "rrr_sim_closed_loop": [_M, _P(RawPlantIntegrator), _D, _D, _M, _P(RawCtcGains),
                            ct.c_size_t, ct.c_double, _D, _D, _D, _P(ct.c_size_t)],
    "rrr_sim_closed_loop_part": [_M, _P(RawPlantIntegrator), _D, _D, _M, _P(RawCtcGains),
                                 ct.c_size_t, ct.c_double, _D, _D, _D, ct.c_size_t,
                                 _P(RawSimCarry), _P(ct.c_size_t)],
    "rrr_param_set": [_M, ct.c_size_t, ct.c_double],
}

# the parameter table's functions that do not return a status: name -> (argtypes, restype)
_TABLE_SIGNATURES: dict[str, tuple[list[Any], Any]] = {
    "rrr_param_table": ([_P(ct.c_size_t)], _P(RawParamInfo)),
    "rrr_param_index": ([ct.c_char_p], ct.c_int),
    "rrr_param_get": ([_M, ct.c_size_t], ct.c_double),
    "rrr_param_in_range": ([ct.c_size_t, ct.c_double], ct.c_int),
    "rrr_sample_time_default": ([], ct.c_double),
    "rrr_version": ([], ct.c_char_p),
    "rrr_simd_available": ([ct.c_int], ct.c_int),
    "rrr_simd_best": ([], ct.c_int),
}

def library_path() -> Path:
    """Path of librrr: $RRR_LIBRARY if set, else the copy CMake installed in the package."""
    env = os.environ.get("RRR_LIBRARY")
    if env:
        return Path(env)
    return PACKAGE_DIR / "librrr.so"


def _load() -> ct.CDLL:
    path = library_path()
    if not path.exists():
        raise RrrError(
            f"librrr not found at {path}: install the package with 'pip install .' "
            "or point RRR_LIBRARY at a built librrr.so"
        )
    lib = ct.CDLL(str(path))
    for name, argtypes in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.argtypes = argtypes
        fn.restype = ct.c_int
    for name, (argtypes, restype) in _TABLE_SIGNATURES.items():
        fn = getattr(lib, name)
        fn.argtypes = argtypes
        fn.restype = restype
    return lib


LIB = _load()
FUNCS: dict[str, Callable[..., int]] = {name: getattr(LIB, name) for name in _SIGNATURES}


def sample_time_default() -> float:
    """RRR_SAMPLE_TIME_DEFAULT (rrr_control.h), s: the control period of the FMUs' default
    experiment, of the CAN bench and of a robot file without [control] sample_time."""
    return float(LIB.rrr_sample_time_default())


def library_version() -> str:
    """The version librrr reports (``rrr_version``: its RRR_VERSION_STRING), which equals
    ``rrr_robot.__version__`` for the library the package was built with."""
    return bytes(LIB.rrr_version()).decode("ascii")


def param_table() -> list[RawParamInfo]:
    """The rows of the C parameter table ``rrr_param_table`` (copies, in table order)."""
    n = ct.c_size_t()
    rows = LIB.rrr_param_table(ct.byref(n))
    return [RawParamInfo.from_buffer_copy(rows[i]) for i in range(n.value)]


def param_index(name: str) -> int:
    """Row of the parameter called ``name`` in the C table (``rrr_param_index``), -1 if none."""
    try:
        encoded = name.encode("ascii")
    except UnicodeEncodeError:
        return -1
    return int(LIB.rrr_param_index(encoded))


def param_get(raw: RawModel, row: int) -> float:
    """Value of row ``row`` of the table in ``raw`` (``rrr_param_get``)."""
    return float(LIB.rrr_param_get(ct.byref(raw), row))


def param_set(raw: RawModel, row: int, value: float) -> None:
    """Set row ``row`` of the table in ``raw`` (``rrr_param_set``; BadInputError if value is
    not finite or the row does not exist)."""
    call("rrr_param_set", ct.byref(raw), row, float(value),
         context=lambda: f"row {row} = {value!r}")


def param_in_range(row: int, value: float) -> bool:
    """Whether ``value`` satisfies row ``row``'s range (``rrr_param_in_range``)."""
    return bool(LIB.rrr_param_in_range(row, float(value)))


def call(name: str, *args: Any, context: str | Callable[[], str] = "") -> None:
    """Call a librrr function and raise the typed error matching a non-OK status.

    ``context`` (a string, or a callable building it only when the call fails) is appended to
    the message.
    """
    status = FUNCS[name](*args)
    if status != 0:
        raise_for(name, status, context)
