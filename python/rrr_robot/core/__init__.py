"""The core: the binding of librrr and the model built on it (the lowest layer).

_ext (the compiled binding, the one way to librrr: Model's calls with rows looped in C, and the
rest of librrr's calls; c_src/pyext/rrr_ext.c), _lib (librrr's structs as ctypes Structures that
_ext reads and writes, the parameter table), _status (statuses and their exceptions),
_arrays (vector and batch shapes), model (:class:`Model` and its closed-form algorithms, all in
C), control (:class:`CtcGains`, the gains of the computed-torque law), integrator
(:class:`PlantIntegrator`, the plant's integrator settings), plant (:class:`Plant`, the plant
stepped through librrr's rrr_plant_step), linearization (:func:`linearize`: the plant's and the
closed loop's state-space matrices from librrr's exact partial derivatives), param_names (the C
parameter table: the model's parameters under the FMUs' variable names), checked (checked
reading of TOML files), robot (the one robot file reader: :func:`read_robot_file` gives a
:class:`RobotFile`, the checked file and its :class:`Model`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .control import CtcGains
    from .integrator import PlantIntegrator
    from .linearization import LinearSystem, linearize
    from .model import DEFAULT_ROBOT_TOML, Model, Singularity, bps_from_inertia
    from .param_names import model_fmu_values
    from .plant import Plant, PlantSnapshot, PlantStats
    from .robot import (
        DEFAULT_SAMPLE_TIME,
        ControlGains,
        LinkInertia,
        RobotData,
        RobotFile,
        read_robot_file,
    )

#: Each re-exported name and its module, imported on first use: ``rrr_robot.core.outputs`` and
#: ``rrr_robot.core._package`` (``rrr fmus``) do not load numpy or librrr.
_LAZY = {
    "CtcGains": ".control",
    "DEFAULT_ROBOT_TOML": ".model",
    "Model": ".model",
    "Singularity": ".model",
    "bps_from_inertia": ".model",
    "PlantIntegrator": ".integrator",
    "LinearSystem": ".linearization",
    "linearize": ".linearization",
    "Plant": ".plant",
    "PlantSnapshot": ".plant",
    "PlantStats": ".plant",
    "model_fmu_values": ".param_names",
    "RobotFile": ".robot",
    "read_robot_file": ".robot",
    "DEFAULT_SAMPLE_TIME": ".robot",
    "ControlGains": ".robot",
    "LinkInertia": ".robot",
    "RobotData": ".robot",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__all__ = [
    "DEFAULT_ROBOT_TOML",
    "DEFAULT_SAMPLE_TIME",
    "ControlGains",
    "CtcGains",
    "LinearSystem",
    "LinkInertia",
    "Model",
    "Plant",
    "PlantIntegrator",
    "PlantSnapshot",
    "PlantStats",
    "RobotData",
    "RobotFile",
    "Singularity",
    "bps_from_inertia",
    "linearize",
    "model_fmu_values",
    "read_robot_file",
]
