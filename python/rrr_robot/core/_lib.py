"""The C structs of librrr as ctypes Structures, and the calls of librrr that are not Model's.

The Structures are plain memory with named fields (no library is loaded through ctypes): the
compiled binding :mod:`rrr_robot.core._ext` (c_src/pyext/rrr_ext.c), the one way Python reaches
librrr, reads and writes them through their buffers, and checks every size against librrr's
(``_ext.SIZES``) when this module is imported. Everything model-related is computed in C.
"""

from __future__ import annotations

import ctypes as ct
import importlib.util
from pathlib import Path

from ..errors import RrrError
from ._package import PACKAGE_DIR
from ._status import STATUS_NAMES as STATUS_NAMES  # the status table lives in _status
from ._status import raise_for as raise_for  # and the one status check

try:
    from . import _ext as _ext  # the binding, re-exported for the modules of core
except ImportError:
    if importlib.util.find_spec(f"{__package__}._ext") is not None:
        raise  # the module is there but does not load: its own error says why
    # a source tree on sys.path, or an install that lost it
    raise ImportError(
        "rrr_robot.core._ext, the compiled binding of librrr, is missing from "
        f"{Path(__file__).parent}: install the package with 'pip install .' (it builds the "
        "module, which needs a C compiler and the Python headers: Debian, Ubuntu: apt-get "
        "install gcc python3-dev)") from None

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


#: ``rrr_param_bound`` values: the lower bound of a parameter (every value must be finite).
PARAM_ANY, PARAM_NONNEG, PARAM_POS = 0, 1, 2


#: each Structure and the C struct it mirrors: their sizes are checked against librrr's below
_MIRRORS: dict[str, type[ct.Structure]] = {
    "rrr_model": RawModel,
    "rrr_inertial": RawInertial,
    "rrr_ik_set": RawIkSet,
    "rrr_singularity": RawSingularity,
    "rrr_ctc_gains": RawCtcGains,
    "rrr_plant_integrator": RawPlantIntegrator,
    "rrr_plant_state": RawPlantState,
    "rrr_plant_stats": RawPlantStats,
    "rrr_sim_carry": RawSimCarry,
}
_WRONG = [f"{name} ({_ext.SIZES[name]} bytes, its mirror {ct.sizeof(mirror)})"
          for name, mirror in _MIRRORS.items() if _ext.SIZES[name] != ct.sizeof(mirror)]
if _WRONG or _ext.NP != NP:
    raise RrrError(f"librrr's structs differ from their mirrors in rrr_robot.core._lib: "
                   f"{', '.join(_WRONG) or f'RRR_NP {_ext.NP}'}; reinstall the package")


def library_path() -> Path:
    """Path of the copy of librrr.so the package ships for C programs (Python does not load it:
    the extension links librrr statically)."""
    return PACKAGE_DIR / "librrr.so"


def sample_time_default() -> float:
    """RRR_SAMPLE_TIME_DEFAULT (rrr_control.h), s: the control period of the FMUs' default
    experiment, of the CAN bench and of a robot file without [control] sample_time."""
    return float(_ext.SAMPLE_TIME_DEFAULT)


def library_version() -> str:
    """The version librrr reports (``rrr_version``: its RRR_VERSION_STRING), which equals
    ``rrr_robot.__version__`` for the library the package was built with."""
    return str(_ext.VERSION)


def param_table() -> tuple[tuple[str, str, int, str], ...]:
    """The rows of the C parameter table ``rrr_param_table``: (name, unit, bound, description),
    in table order."""
    return _ext.param_table()


def param_index(name: str) -> int:
    """Row of the parameter called ``name`` in the C table (``rrr_param_index``), -1 if none."""
    try:
        return int(_ext.param_index(name))
    except UnicodeEncodeError:  # a lone surrogate: no parameter's name
        return -1


def param_get(raw: RawModel, row: int) -> float:
    """Value of row ``row`` of the table in ``raw`` (``rrr_param_get``)."""
    return float(_ext.param_get(raw, row))


def param_set(raw: RawModel, row: int, value: float) -> None:
    """Set row ``row`` of the table in ``raw`` (``rrr_param_set``; BadInputError if value is
    not finite or the row does not exist)."""
    status = _ext.param_set(raw, row, float(value))
    if status != 0:
        raise_for("rrr_param_set", status, f"row {row} = {value!r}")


def param_in_range(row: int, value: float) -> bool:
    """Whether ``value`` satisfies row ``row``'s range (``rrr_param_in_range``)."""
    return bool(_ext.param_in_range(row, float(value)))
