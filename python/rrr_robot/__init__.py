"""rrr_robot: closed-form kinematic and dynamic models of an RRR arm, its FMUs and tools.

The model is computed by the C core librrr; this package binds it, builds and runs the FMUs,
and provides the writing task, identification, HIL bench and the ``rrr`` command line.

Subpackages, each importing only from those below it: ``cli`` (the ``rrr`` command line) above
``hil`` (CAN bench), ``identify`` (identification) and ``sweep`` (Monte Carlo scenario sweeps
on Dask), above ``writing`` (the writing task), above
``sim`` (FMUs and co-simulation), above ``core`` (the binding of librrr and the model);
``errors`` (the exceptions) is below them all.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .core._version import package_version
from .errors import (
    BadInputError,
    CosimError,
    ModelError,
    NumericError,
    RobotFileError,
    RrrError,
    ScenarioError,
    SingularError,
    SweepSpecError,
    UnreachableError,
)

if TYPE_CHECKING:
    from .core.control import CtcGains
    from .core.integrator import PlantIntegrator
    from .core.linearization import LinearSystem, linearize
    from .core.mcap_log import write_mcap
    from .core.model import Model, Singularity, bps_from_inertia
    from .core.plant import Plant, PlantSnapshot, PlantStats
    from .core.robot import RobotFile, read_robot_file
    from .core.tables import read_table
    from .core.urdf import robot_urdf, write_urdf
    from .sim.cosim import CosimOptions, CosimResult
    from .sim.fmus import fmu_path
    from .sim.native import simulate
    from .writing.trajectory import Reference, WritingSpec, make_reference
    from .writing.view import write_view

#: The re-exported names that need numpy and librrr, imported on first use (``rr.Model``), so
#: that ``import rrr_robot`` (and ``rrr --help``, ``rrr fmus``) loads neither.
_LAZY = {
    "CtcGains": ".core.control",
    "Model": ".core.model",
    "Singularity": ".core.model",
    "bps_from_inertia": ".core.model",
    "PlantIntegrator": ".core.integrator",
    "LinearSystem": ".core.linearization",
    "linearize": ".core.linearization",
    "Plant": ".core.plant",
    "PlantSnapshot": ".core.plant",
    "PlantStats": ".core.plant",
    "RobotFile": ".core.robot",
    "read_robot_file": ".core.robot",
    "robot_urdf": ".core.urdf",
    "write_urdf": ".core.urdf",
    "CosimOptions": ".sim.cosim",
    "CosimResult": ".sim.cosim",
    "fmu_path": ".sim.fmus",
    "simulate": ".sim.native",
    "write_mcap": ".core.mcap_log",
    "read_table": ".core.tables",
    "write_view": ".writing.view",
    "Reference": ".writing.trajectory",
    "WritingSpec": ".writing.trajectory",
    "make_reference": ".writing.trajectory",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # the next access does not come here
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


#: The toolkit's version (``X.Y.Z``), from its one source ``rrr_version.h`` (also librrr's
#: ``RRR_VERSION_STRING``, the FMUs' ``version`` and the CMake package's).
__version__: str = package_version()

__all__ = [
    "BadInputError",
    "CosimError",
    "CosimOptions",
    "CosimResult",
    "CtcGains",
    "LinearSystem",
    "Model",
    "ModelError",
    "NumericError",
    "Plant",
    "PlantIntegrator",
    "PlantSnapshot",
    "PlantStats",
    "Reference",
    "RobotFile",
    "RobotFileError",
    "RrrError",
    "ScenarioError",
    "SingularError",
    "Singularity",
    "SweepSpecError",
    "UnreachableError",
    "WritingSpec",
    "__version__",
    "bps_from_inertia",
    "fmu_path",
    "linearize",
    "make_reference",
    "read_robot_file",
    "read_table",
    "robot_urdf",
    "simulate",
    "write_mcap",
    "write_urdf",
    "write_view",
]
