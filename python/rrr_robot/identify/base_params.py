"""The 16 base parameters from an excitation log (eq 10): k_t (u - u_f(qd)) = R(q, qd, qdd) p.

q is filtered (zero phase), qd and qdd are its derivatives (signals.derivatives), u goes
through the same filter; the prior model supplies the kinematics, g, k_t and the friction
(identified before). Samples are decimated to about twice the cutoff, so the residuals are
nearly uncorrelated; rows (sample, joint) where that joint moves slower than ``v_min`` (where
the steep friction curve makes u_f unreliable) or where |u| reaches u_max (saturation) are
dropped. p is estimated by ordinary least squares and then by weighted least squares with one
noise level per joint (from the OLS residuals); the covariance is sigma^2 (W^T W)^-1, or
(W^T S^-1 W)^-1 for WLS, and the standard deviations its diagonal. On simulated data with
quantisation and noise the OLS 95 % intervals held the true value for 16/16 parameters in 10 of
10 noise seeds, the WLS ones for 13-16/16 (its per-joint weights trust joint 3, whose small
residual is partly systematic): the pipeline reports OLS by default.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.param_names import group_names
from ..errors import BadInputError
from ._threads import one_blas_thread
from .logs import Log
from .signals import derivatives

log = logging.getLogger(__name__)

NP = 16
MAX_COND = 1e5


@dataclass(frozen=True)
class Estimate:
    """p with its standard deviations; sigma is the residual std per joint (N m)."""

    p: FloatArray
    std: FloatArray
    sigma: FloatArray
    method: str


@dataclass(frozen=True)
class BaseParamResult:
    """The base parameters estimated from a log: ``ls`` (least squares) and ``wls`` (weighted
    by each joint's residual variance), each an :class:`Estimate`; ``cond`` the condition
    number of the stacked regressor, ``rows`` the regressor rows used, ``samples`` the log
    samples they came from."""

    ls: Estimate
    wls: Estimate
    cond: float             # condition number of the stacked regressor (rows used)
    rows: int
    samples: int


@dataclass(frozen=True)
class Regression:
    w: FloatArray           # (m, 16)
    y: FloatArray           # (m,) N m
    joint: np.ndarray       # (m,) 0..2
    samples: int


def build_regression(lg: Log, prior: Model, method: str = "butter", cutoff: float = 15.0,
                     v_min: float = 0.05, edge: float = 0.1) -> Regression:
    """Stacked regressor W and torques y = k_t (u - u_f) of the usable rows."""
    sig = derivatives(lg, method, cutoff)
    every = 1 if method == "log" else max(1, int(0.5 / (cutoff * lg.dt)))
    skip = round(edge / lg.dt) if method != "log" else 0
    idx = np.arange(skip, len(lg) - skip, every)
    if idx.size < NP:
        raise BadInputError(f"{lg.source}: too short: {idx.size} usable samples after "
                            f"filtering, need well over {NP}")
    q, qd, qdd, u = sig.q[idx], sig.qd[idx], sig.qdd[idx], sig.u[idx]
    reg = prior.regressor(q, qd, qdd)
    y = prior.torque_from_voltage(qd, u)  # eq 8 inverted by the model (u saturated at u_max)
    keep = (np.abs(qd) >= v_min) & (np.abs(lg.u[idx]) < 0.999 * prior.u_max)
    n_sat = int(np.sum(np.abs(lg.u[idx]) >= 0.999 * prior.u_max))
    if n_sat:
        log.warning("%s: %d samples reach u_max = %g V and are dropped", lg.source, n_sat,
                    prior.u_max)
    joint = np.broadcast_to(np.arange(3), keep.shape)
    return Regression(reg[keep], y[keep], joint[keep], int(idx.size))


def _check_rank(w: FloatArray, source: str) -> float:
    norms = np.linalg.norm(w, axis=0)
    names = group_names("p")        # "p[1]" ... "p[16]": the C parameter table's names
    dead = [names[k] for k in np.flatnonzero(norms < 1e-9 * max(norms.max(), 1e-300))]
    if dead:
        raise BadInputError(f"{source}: not exciting enough: the data carry no information on "
                            f"{', '.join(dead)} (rank deficient regressor)")
    scaled = w / norms
    s, vt = sla.svd(scaled, full_matrices=False)[1:]
    cond = float(s[0] / s[-1])
    if cond > MAX_COND:
        weak = np.argsort(-np.abs(vt[-1]))[:3]
        raise BadInputError(f"{source}: not exciting enough: the regressor is (nearly) rank "
                            f"deficient, condition number {cond:.3g} after column scaling; "
                            f"the weakest direction mixes {', '.join(names[k] for k in weak)}")
    return float(np.linalg.cond(w))


def _solve(w: FloatArray, y: FloatArray, scale: FloatArray, method: str,
           joint: np.ndarray) -> Estimate:
    ws, ys = w / scale[:, None], y / scale
    p = sla.lstsq(ws, ys)[0]
    res = y - w @ p
    sigma = np.array([np.sqrt(np.mean(res[joint == i] ** 2)) for i in range(3)])
    # unit-variance scaling: s^2 of the weighted residuals (1 for correct WLS weights)
    s2 = float(np.sum((res / scale) ** 2) / (w.shape[0] - NP))
    _, s, vt = sla.svd(ws, full_matrices=False)
    cov = (vt.T / s**2) @ vt * s2
    return Estimate(p, np.sqrt(np.diag(cov)), sigma, method)


@one_blas_thread
def estimate_base_params(lg: Log, prior: Model, method: str = "butter", cutoff: float = 15.0,
                         v_min: float = 0.05) -> BaseParamResult:
    """LS and WLS estimates of p with standard deviations (see module docstring)."""
    reg = build_regression(lg, prior, method, cutoff, v_min)
    if reg.y.size < 3 * NP:
        raise BadInputError(f"{lg.source}: too short or too slow: only {reg.y.size} usable rows "
                            f"(|qd| >= {v_min} rad/s, |u| < u_max), need at least {3 * NP}")
    cond = _check_rank(reg.w, lg.source)
    ls = _solve(reg.w, reg.y, np.ones_like(reg.y), "ls", reg.joint)
    sig = np.maximum(ls.sigma, 1e-12 * max(ls.sigma.max(), 1e-300))
    wls = _solve(reg.w, reg.y, sig[reg.joint], "wls", reg.joint)
    log.info("base parameters from %d rows (%d samples): cond(W) %.1f, residual std %s N m",
             reg.y.size, reg.samples, cond, np.array2string(wls.sigma, precision=4))
    return BaseParamResult(ls, wls, cond, int(reg.y.size), reg.samples)
