"""rrr_robot: closed-form kinematic and dynamic models of an RRR arm, its FMUs and tools.

The model is computed by the C core librrr; this package binds it, builds and runs the FMUs,
and provides the writing task, identification, HIL bench and the ``rrr`` command line.
"""

from __future__ import annotations

from .errors import (
    BadInputError,
    CosimError,
    ModelError,
    NumericError,
    RrrError,
    SingularError,
    UnreachableError,
)
from .fmus import fmu_path
from .model import CtcOutput, Model, Singularity, bps_from_inertia

__version__ = "0.1.0"

__all__ = [
    "BadInputError",
    "CosimError",
    "CtcOutput",
    "Model",
    "ModelError",
    "NumericError",
    "RrrError",
    "SingularError",
    "Singularity",
    "UnreachableError",
    "__version__",
    "bps_from_inertia",
    "fmu_path",
]
