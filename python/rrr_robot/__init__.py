"""rrr_robot: closed-form kinematic and dynamic models of an RRR arm, its FMUs and tools.

The model is computed by the C core librrr; this package binds it, builds and runs the FMUs,
and provides the writing task, identification, HIL bench and the ``rrr`` command line.

Subpackages, each importing only from those below it: ``cli`` (the ``rrr`` command line) above
``hil`` (CAN bench) and ``identify`` (identification), above ``writing`` (the writing task), above
``sim`` (FMUs and co-simulation), above ``core`` (the binding of librrr and the model);
``errors`` (the exceptions) is below them all.
"""

from __future__ import annotations

from .core.model import Model, Singularity, bps_from_inertia
from .core.robot import RobotFile, read_robot_file
from .errors import (
    BadInputError,
    CosimError,
    ModelError,
    NumericError,
    RobotFileError,
    RrrError,
    ScenarioError,
    SingularError,
    UnreachableError,
)
from .sim.fmus import fmu_path

__version__ = "0.1.0"

__all__ = [
    "BadInputError",
    "CosimError",
    "Model",
    "ModelError",
    "NumericError",
    "RobotFile",
    "RobotFileError",
    "RrrError",
    "ScenarioError",
    "SingularError",
    "Singularity",
    "UnreachableError",
    "__version__",
    "bps_from_inertia",
    "fmu_path",
    "read_robot_file",
]
