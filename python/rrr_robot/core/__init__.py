"""The core: the ctypes binding of librrr and the model built on it (the lowest layer).

_lib (structures, signatures, status check), _arrays (vector and batch shapes), model
(:class:`Model` and its closed-form algorithms, all in C), param_names (the C parameter table:
the model's parameters under the FMUs' variable names), checked (checked reading of TOML files),
robot_file (the one robot file reader: :class:`RobotData`), robot (:class:`RobotFile`: the
checked file and its :class:`Model`).
"""

from .model import DEFAULT_ROBOT_TOML, Model, Singularity, bps_from_inertia
from .param_names import model_fmu_values
from .robot import RobotFile, read_robot_file
from .robot_file import DEFAULT_SAMPLE_TIME, ControlGains, LinkInertia, RobotData

__all__ = [
    "DEFAULT_ROBOT_TOML",
    "DEFAULT_SAMPLE_TIME",
    "ControlGains",
    "LinkInertia",
    "Model",
    "RobotData",
    "RobotFile",
    "Singularity",
    "bps_from_inertia",
    "model_fmu_values",
    "read_robot_file",
]
