"""Identification end to end: friction log + excitation log + prior robot file -> robot file.

The prior robot file supplies what is not identified (kinematics, g, k_t, u_max, [control],
[writing]); the written file has the identified ``[base_parameters] p`` and ``[friction]``
tables, readable by read_robot_file, the core and both FMUs (core.param_names.model_fmu_values),
plus an ``[identification]`` table with the standard deviations and figures of merit.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core.checked import write_toml
from ..core.model import Model
from ..core.outputs import atomic_path
from ..core.param_names import group_names
from ..core.robot import RobotFile, read_robot_file
from ..errors import BadInputError, ModelError
from ._threads import one_blas_thread
from .base_params import BaseParamResult, Estimate, estimate_base_params
from .friction import FrictionFit, curve_points, fit_ls, fit_nls
from .logs import Log
from .truth import TruthComparison, compare_with_truth

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Settings:
    """How to identify: the derivatives' filter (``butter``, ``savgol`` or ``log``: the logged
    ones), its cutoff for the excitation log and for the friction log (Hz), the friction fit
    (``nls``: f, w and b; ``ls``: w fixed from the prior), the base-parameter estimator
    (``ls`` or ``wls``) and the least joint speed of the friction samples (rad/s)."""

    derivatives: str = "butter"     # butter | savgol | log
    cutoff: float = 15.0            # Hz, excitation log
    friction_cutoff: float = 5.0    # Hz, friction log
    friction_method: str = "nls"    # nls (f, w, b) | ls (w fixed from the prior)
    weighting: str = "ls"           # ls | wls (WLS intervals are optimistic, see report)
    v_min: float = 0.05             # rad/s

    def __post_init__(self) -> None:
        for name in ("cutoff", "friction_cutoff", "v_min"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise BadInputError(f"{name} must be a finite number > 0, got {value}")


def check_voltages(lg: Log, u_max: float) -> None:
    """A logged voltage beyond the inverter's range cannot have been applied: name the row."""
    bad = np.argwhere(np.abs(lg.u) > u_max * (1.0 + 1e-9))
    if bad.size:
        row, col = (int(v) for v in bad[0])
        raise BadInputError(f"{lg.source}: row {row + 1}: {fv.names('plant', 'u')[col]} = "
                            f"{lg.u[row, col]:.6g} V "
                            f"is outside the voltage range +/- {u_max:g} V of the robot "
                            f"({bad.shape[0]} such value(s))")


@dataclass(frozen=True)
class Identified:
    """The result of :func:`identify`: the identified ``model`` (the prior with the estimated
    friction and base parameters), the friction fit of each joint (None without a friction
    log) and the base-parameter estimates; :meth:`report` gives it as JSON values."""

    model: Model
    friction: list[FrictionFit] | None
    base: BaseParamResult
    # each estimate beside the true value (rrr identify --truth: simulated experiments only)
    truth: TruthComparison | None = None

    @property
    def estimate(self) -> Estimate:
        """The base-parameter estimate the model holds (least squares or weighted)."""
        return self.base.wls if self.model_uses_wls else self.base.ls

    def compared_with(self, true: RobotFile, prior: Model) -> Identified:
        """This result with each estimate beside its value in the true robot file ``true``
        (:func:`~rrr_robot.identify.truth.compare_with_truth`); ``prior`` supplied what is not
        identified."""
        return replace(self, truth=compare_with_truth(self.estimate, self.friction, prior,
                                                      true.model, true.source))

    def report(self) -> dict[str, Any]:
        """The result as JSON values: the estimated p with its standard deviations, the
        estimator, the regressor's condition and rows, the friction fits and, against a truth,
        each estimate beside its true value (``truth``)."""
        est = self.estimate
        other = self.base.ls if self.model_uses_wls else self.base.wls
        out: dict[str, Any] = {
            "p": est.p.tolist(), "p_std": est.std.tolist(), "estimator": est.method,
            "cond": self.base.cond, "rows": self.base.rows,
            "residual_std_Nm": est.sigma.tolist(),
            f"p_{other.method}": other.p.tolist(), f"p_std_{other.method}": other.std.tolist(),
        }
        if self.friction:
            out["friction_method"] = self.friction[0].method
            out["friction_residual_rms_V"] = [f.residual_rms for f in self.friction]
            out["friction_residual_max_V"] = [f.residual_max for f in self.friction]
        if self.truth is not None:
            out["truth"] = self.truth.report()
        return out

    @property
    def model_uses_wls(self) -> bool:
        return bool(np.array_equal(self.model.p, self.base.wls.p))


@one_blas_thread
def identify_friction(lg: Log, prior: Model, settings: Settings = Settings(),
                      progress: Callable[[int, int], None] | None = None) -> list[FrictionFit]:
    """One fit per joint (eq 9) from a sweep log; ``progress(joints done, 3)``."""
    method = "log" if settings.derivatives == "log" else "butter"
    fits = []
    for j in fv.JOINTS:
        pts = curve_points(lg, j, prior, settings.friction_cutoff, method)
        fit = fit_nls(pts) if settings.friction_method == "nls" else fit_ls(pts, prior.w[j - 1])
        log.info("friction joint %d (%s): f %s, w %s, b %.5g; residual rms %.2e V", j,
                 fit.method, np.array2string(fit.f, precision=5),
                 np.array2string(fit.w, precision=4), fit.b, fit.residual_rms)
        fits.append(fit)
        if progress is not None:
            progress(j, 3)
    return fits


@one_blas_thread
def identify(excitation: Log, prior: Model, friction: Log | None = None,
             settings: Settings = Settings(),
             progress: Callable[[str, int, int], None] | None = None) -> Identified:
    """Friction (if a sweep log is given; otherwise the prior's) then the base parameters;
    ``progress(phase, done, total)`` as each joint's friction fit ends ("friction fits")."""
    for lg in (excitation, friction):
        if lg is not None:
            check_voltages(lg, prior.u_max)

    def fitted(done: int, total: int) -> None:
        if progress is not None:
            progress("friction fits", done, total)
    fits = (identify_friction(friction, prior, settings, progress=fitted)
            if friction is not None else None)
    model = prior
    if fits is not None:
        model = prior.with_params(f=np.array([f.f for f in fits]),
                                  w=np.array([f.w for f in fits]),
                                  b=np.array([f.b for f in fits]))
    base = estimate_base_params(excitation, model, settings.derivatives, settings.cutoff,
                                settings.v_min)
    est = base.wls if settings.weighting == "wls" else base.ls
    try:
        model = model.with_params(p=est.p)
    except ModelError as exc:
        raise ModelError(f"the identified parameters give an invalid model ({exc}); the "
                         "excitation is probably too weak") from exc
    return Identified(model, fits, base)


def write_robot(result: Identified, path: Path,
                prior: RobotFile | str | Path | None = None) -> None:
    """The identified robot file; tables of the prior robot file that are not identified
    (kinematics, motors, control, writing, ...) are carried over. ``prior``: the prior as read
    (RobotFile) or its path (read and checked here)."""
    tables: dict[str, Any] = {}
    if prior is not None:
        robot = prior if isinstance(prior, RobotFile) else read_robot_file(prior)
        tables = robot.data.tables()
        for drop in ("link1", "link2", "link3", "base_parameters", "friction", "identification"):
            tables.pop(drop, None)
        tables.get("motors", {}).pop("rotor_inertia", None)
    ident = result.model.to_dict()
    for name, table in ident.items():
        tables[name] = tables.get(name, {}) | table
    report = result.report()
    report.pop("truth", None)  # the robot file keeps the flat values of the comparison
    tables["identification"] = report | ({} if result.truth is None
                                         else result.truth.toml_values())
    header = ("Identified by rrr identify: [base_parameters] and [friction] estimated from logs;\n"
              "[identification] holds p_std (1 sigma) and figures of merit; the base parameters "
              f"are {group_names('p')[0]} ... {group_names('p')[-1]} (rrr_params.h).")
    with atomic_path(path) as tmp:  # the file appears complete or not at all
        write_toml(tables, tmp, header=header)
