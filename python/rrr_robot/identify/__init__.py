"""Identification of friction (eq 9) and the 16 base parameters (eq 10) from logs.

logs (CSV format), signals (zero-phase derivatives), friction, excitation, base_params,
experiments (simulated logs on the plant FMU), pipeline (end to end), validation (writing
task). The command line (``rrr identify``) is in :mod:`rrr_robot.cli.identify`.
"""

from .base_params import BaseParamResult, estimate_base_params
from .excitation import ExcitationLimits, FourierTrajectory, design_excitation
from .friction import curve_points, fit_ekf, fit_ls, fit_nls
from .logs import Log, read_log
from .pipeline import Identified, Settings, identify, write_robot

__all__ = [
    "BaseParamResult",
    "ExcitationLimits",
    "FourierTrajectory",
    "Identified",
    "Log",
    "Settings",
    "curve_points",
    "design_excitation",
    "estimate_base_params",
    "fit_ekf",
    "fit_ls",
    "fit_nls",
    "identify",
    "read_log",
    "write_robot",
]
