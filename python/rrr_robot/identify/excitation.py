"""Excitation design: periodic finite Fourier series joint trajectories (Swevers et al.),

    q_i(t) = q0_i + sum_l [a_il / (w l) sin(w l t) - b_il / (w l) cos(w l t)],  w = 2 pi / T,

whose coefficients minimise the condition number of the stacked regressor W = [R(t_1); ...;
R(t_M)] subject to bounds on |q - q0|, |qd| and |qdd| (linear in the coefficients), checked
afterwards against the voltage bound with a prior model (eq 10).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.outputs import atomic_write_text, strict_json
from ..errors import BadInputError
from ._threads import one_blas_thread

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FourierTrajectory:
    """Periodic excitation; a and b are (3, N) velocity amplitudes in rad/s."""

    period: float
    q0: FloatArray
    a: FloatArray
    b: FloatArray

    @property
    def harmonics(self) -> int:
        return int(self.a.shape[1])

    def basis(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Matrices Bq, Bd, Bdd (M, 2N) with q - q0 = Bq @ [a_i, b_i], etc."""
        w = 2 * np.pi / self.period * np.arange(1, self.harmonics + 1)
        s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
        return (np.hstack([s / w, -c / w]), np.hstack([c, s]), np.hstack([-s * w, c * w]))

    def evaluate(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """q, qd, qdd, each (M, 3)."""
        coef = np.hstack([self.a, self.b])          # (3, 2N)
        bq, bd, bdd = self.basis(np.asarray(t, dtype=float))
        return self.q0 + bq @ coef.T, bd @ coef.T, bdd @ coef.T

    def to_json(self, path: Path) -> None:
        data = {"period": self.period, "q0": self.q0.tolist(), "a": self.a.tolist(),
                "b": self.b.tolist()}
        atomic_write_text(path, strict_json(data) + "\n")

    @classmethod
    def from_json(cls, path: Path) -> FourierTrajectory:
        d = json.loads(Path(path).read_text())
        return cls(float(d["period"]), np.array(d["q0"]), np.array(d["a"]), np.array(d["b"]))


@dataclass(frozen=True)
class ExcitationLimits:
    """Bounds of the excitation (rad, rad/s, rad/s^2) and the fraction of u_max allowed."""

    q_amp: FloatArray = field(default_factory=lambda: np.array([1.5, 1.0, 1.2]))
    qd_max: FloatArray = field(default_factory=lambda: np.array([2.0, 2.0, 2.5]))
    qdd_max: FloatArray = field(default_factory=lambda: np.array([8.0, 8.0, 10.0]))
    u_fraction: float = 0.7


def stacked_regressor(model: Model, traj: FourierTrajectory, samples: int = 100) -> FloatArray:
    """W (3M, 16) of the trajectory on M points of one period (the C core's regressor)."""
    t = np.arange(samples) * traj.period / samples
    return model.regressor(*traj.evaluate(t)).reshape(-1, 16)


def _unpack(x: FloatArray, n: int) -> tuple[FloatArray, FloatArray]:
    return x[: 3 * n].reshape(3, n), x[3 * n:].reshape(3, n)


def _linear_constraints(traj: FourierTrajectory, lim: ExcitationLimits,
                        samples: int) -> list[dict[str, Any]]:
    """|q - q0|, |qd|, |qdd| <= bounds on a grid, as SLSQP 'ineq' constraints G x + h >= 0."""
    n = traj.harmonics
    t = np.arange(samples) * traj.period / samples
    rows, bounds = [], []
    for mat, bound in zip(traj.basis(t), (lim.q_amp, lim.qd_max, lim.qdd_max), strict=True):
        for i in range(3):
            g = np.zeros((samples, 6 * n))
            g[:, i * n:(i + 1) * n] = mat[:, :n]
            g[:, 3 * n + i * n:3 * n + (i + 1) * n] = mat[:, n:]
            rows += [-g, g]
            bounds += [np.full(samples, bound[i])] * 2
    gm, hv = np.vstack(rows), np.concatenate(bounds)
    return [{"type": "ineq", "fun": lambda x: gm @ x + hv, "jac": lambda _x: gm}]


@one_blas_thread
def design_excitation(prior: Model, q0: FloatArray, limits: ExcitationLimits = ExcitationLimits(),
                      period: float = 10.0, harmonics: int = 5, samples: int = 100,
                      maxiter: int = 60, seed: int = 0) -> tuple[FourierTrajectory, float]:
    """Optimise the coefficients for cond(W); returns the trajectory and cond(W)."""
    from scipy.optimize import minimize  # slow to import: when an excitation is designed

    n = harmonics
    rng = np.random.default_rng(seed)
    x0 = rng.uniform(-1, 1, 6 * n) / np.tile(np.repeat(np.arange(1, n + 1), 1), 6)
    shell = FourierTrajectory(period, np.asarray(q0, dtype=float), *_unpack(x0, n))
    t = np.arange(samples) * period / samples
    _, qd, qdd = shell.evaluate(t)
    scale = max(np.max(np.abs(qd) / limits.qd_max), np.max(np.abs(qdd) / limits.qdd_max),
                np.max(np.abs(shell.evaluate(t)[0] - shell.q0) / limits.q_amp))
    x0 = x0 / scale * 0.9

    def cost(x: FloatArray) -> float:
        traj = FourierTrajectory(period, shell.q0, *_unpack(x, n))
        return float(np.log(np.linalg.cond(stacked_regressor(prior, traj, samples))))

    res = minimize(cost, x0, method="SLSQP", constraints=_linear_constraints(shell, limits,
                   4 * samples), options={"maxiter": maxiter, "ftol": 1e-6})
    traj = FourierTrajectory(period, shell.q0, *_unpack(res.x, n))
    cond = float(np.exp(cost(res.x)))
    log.info("excitation: cond(W) %.1f after %d iterations (start %.1f): %s", cond, res.nit,
             np.exp(cost(x0)), res.message)
    check_voltage(prior, traj, limits.u_fraction)
    return traj, cond


def check_voltage(prior: Model, traj: FourierTrajectory, fraction: float = 0.7) -> float:
    """Largest nominal |u| of the prior model along the trajectory; BadInputError above
    fraction * u_max (the plant saturates at u_max, which would bias the estimate)."""
    t = np.linspace(0.0, traj.period, 1000, endpoint=False)
    u = prior.nominal_voltage(*traj.evaluate(t))
    peak = float(np.max(np.abs(u)))
    if peak > fraction * prior.u_max:
        raise BadInputError(f"the excitation needs {peak:.2f} V, above {fraction:g} u_max = "
                            f"{fraction * prior.u_max:.2f} V: lower the velocity/acceleration "
                            "limits")
    return peak
