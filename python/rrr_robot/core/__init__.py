"""The core: the ctypes binding of librrr and the model built on it (the lowest layer).

_lib (structures, signatures, status check), _arrays (vector and batch shapes), model
(:class:`Model` and its closed-form algorithms, all in C), robot_file (robot TOML files),
param_names (the model's parameters under the FMUs' variable names).
"""

from .model import DEFAULT_ROBOT_TOML, CtcOutput, Model, Singularity, bps_from_inertia
from .param_names import model_fmu_values

__all__ = [
    "DEFAULT_ROBOT_TOML",
    "CtcOutput",
    "Model",
    "Singularity",
    "bps_from_inertia",
    "model_fmu_values",
]
