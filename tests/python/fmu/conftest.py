"""fmu/: the FMUs through FMPy, libcosim and their own variants: packages, states, errors,
derivatives, start values, the reference FMU, the plant's integrator, rr.Plant against the plant
FMU. Marker ``slow``."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__, "slow")
