"""Identification of friction (eq 9) and the 16 base parameters (eq 10) from logs.

logs (CSV format), signals (zero-phase derivatives), friction, excitation, base_params,
experiments (simulated logs on the plant FMU), pipeline (end to end), validation (writing
task), jobs (what ``rrr identify`` and ``rrr identify-experiment`` run: one call each). The
command line is in :mod:`rrr_robot.cli.identify`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .base_params import BaseParamResult, estimate_base_params
    from .excitation import ExcitationLimits, FourierTrajectory, design_excitation
    from .friction import curve_points, fit_ekf, fit_ls, fit_nls
    from .jobs import ExperimentJob, IdentifyJob, run_experiment, run_identify
    from .logs import Log, read_log
    from .pipeline import Identified, Settings, identify, write_robot

#: Each re-exported name and its module, imported on first use (they need scipy).
_LAZY = {
    "BaseParamResult": ".base_params",
    "estimate_base_params": ".base_params",
    "ExcitationLimits": ".excitation",
    "FourierTrajectory": ".excitation",
    "design_excitation": ".excitation",
    "curve_points": ".friction",
    "fit_ekf": ".friction",
    "fit_ls": ".friction",
    "fit_nls": ".friction",
    "ExperimentJob": ".jobs",
    "IdentifyJob": ".jobs",
    "run_experiment": ".jobs",
    "run_identify": ".jobs",
    "Log": ".logs",
    "read_log": ".logs",
    "Identified": ".pipeline",
    "Settings": ".pipeline",
    "identify": ".pipeline",
    "write_robot": ".pipeline",
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
    "BaseParamResult",
    "ExcitationLimits",
    "ExperimentJob",
    "FourierTrajectory",
    "Identified",
    "IdentifyJob",
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
    "run_experiment",
    "run_identify",
    "write_robot",
]
