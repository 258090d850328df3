"""Friction of eq 9 per joint from constant-velocity sweeps (log with a ``joint`` column).

Experiment (see experiments.friction_reference): joint i moves at constant velocity +v and
then -v over the same arc while the others are held still, for several speeds v. Everything
but friction in u_i is k_t,i^-1 R_i(q, qd, qdd) p (eq 10) with p unknown but the same for all
passes, and is even in the velocity of joint i (gravity, inertia, Coriolis terms are
quadratic in velocity); friction is odd. So all passes of joint i are regressed together on
[one signed indicator column per speed level, R_i(q, qd, qdd) from the C core, 1]: the
coefficient of level l is the friction F(v_l); p/k_t,i (whatever part the sweep excites) and
an offset are nuisance terms, and so is the local slope of friction times each sample's
deviation from the mean speed of its pass (the speed ripples a little). This compensates
gravity exactly even though the locked joints give a little, and needs only the kinematics of
the prior model. The speed of a pass is the mean of the filtered velocity over it, i.e. its
distance over its duration (robust to encoder quantisation).

The curve points (v_l, F_l) are fitted by eq 9, u_f = sum_k f_k tanh(w_k v) + b v:
- ``fit_ls``: w fixed, f and b by linear least squares;
- ``fit_nls``: f, w and b by separable nonlinear least squares (variable projection: for a
  given w the optimal f, b are linear; Levenberg-Marquardt on log w from 35 starts on a
  log grid, best cost kept, w sorted descending). This is used instead of the EKF of the
  paper: with the data already in a file, batch NLS re-linearises at every iteration and
  reaches the least-squares optimum, whereas an EKF with constant-parameter states is one
  pass of recursive Gauss-Newton that linearises once per sample, depends on the chosen
  initial covariance and stops short of the optimum when w starts far off. ``fit_ekf`` is
  given for comparison.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..core._arrays import FloatArray
from ..core.model import Model
from ..errors import BadInputError
from ._threads import one_blas_thread
from .logs import Log
from .signals import derivatives

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CurvePoints:
    """Friction voltage F (V) at mean speed v (rad/s), one point per speed level."""

    v: FloatArray
    F: FloatArray


@dataclass(frozen=True)
class FrictionFit:
    """Eq 9 coefficients of one joint and the fit residuals at the curve points (V)."""

    f: FloatArray            # (3,)
    w: FloatArray            # (3,)
    b: float
    residual_rms: float
    residual_max: float
    method: str
    points: CurvePoints

    def predict(self, v: FloatArray) -> FloatArray:
        u: FloatArray = _basis(np.asarray(v, dtype=float), self.w) @ np.append(self.f, self.b)
        return u


def _basis(v: FloatArray, w: FloatArray) -> FloatArray:
    return np.column_stack([np.tanh(np.outer(v, w)), v])


def _blocks(mask: np.ndarray) -> list[slice]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [slice(a, b) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _pairs(t: FloatArray, q: FloatArray, blocks: list[slice]) -> list[tuple[slice, slice, float]]:
    """Consecutive passes of opposite direction and similar speed, with their mean speed."""
    slopes = [np.polyfit(t[b] - t[b][0], q[b], 1)[0] for b in blocks]
    out = []
    k = 0
    while k + 1 < len(blocks):
        v1, v2 = slopes[k], slopes[k + 1]
        if v1 * v2 < 0 and 0.8 < abs(v1 / v2) < 1.25:
            out.append((blocks[k], blocks[k + 1], 0.5 * (abs(v1) + abs(v2))))
            k += 2
        else:
            k += 1
    return out


@one_blas_thread
def curve_points(lg: Log, joint: int, prior: Model, cutoff: float = 5.0,
                 method: str = "butter", every: int = 5) -> CurvePoints:
    """Friction curve points of one joint from a sweep log (see module docstring); ``prior``
    supplies the kinematics for the regressor, ``every`` decimates the samples."""
    if lg.joint is None:
        raise BadInputError(f"{lg.source}: a friction log needs the column joint")
    sig = derivatives(lg, method, cutoff)
    i = joint - 1
    blocks = [b for b in _blocks(lg.joint == joint) if b.stop - b.start >= 20]
    pairs = _pairs(lg.t, sig.q[:, i], blocks)
    if len(pairs) < 4:
        raise BadInputError(f"{lg.source}: joint {joint} has {len(pairs)} forward/backward "
                            "pass pairs at constant speed; need at least 4 speed levels")
    rows, level_cols = [], []
    for level, (fw, bw, _) in enumerate(pairs):
        s = np.sign(sig.qd[fw, i].mean())
        for blk, sign in ((fw, s), (bw, -s)):
            idx = np.arange(blk.start, blk.stop, every)
            rows.append(idx)
            col = np.zeros((idx.size, 2 * len(pairs)))
            col[:, level] = sign
            col[:, len(pairs) + level] = sig.qd[idx, i] - sig.qd[blk, i].mean()
            level_cols.append(col)
    r = np.concatenate(rows)
    reg = prior.regressor(sig.q[r], sig.qd[r], sig.qdd[r])[:, i, :]
    reg = reg[:, np.sqrt(np.mean(reg**2, axis=0)) > 1e-3]   # columns this sweep excites
    x = np.hstack([np.vstack(level_cols), reg, np.ones((r.size, 1))])
    coef = sla.lstsq(x, sig.u[r, i])[0]
    speed = np.array([abs(sig.qd[fw, i].mean()) + abs(sig.qd[bw, i].mean())
                      for fw, bw, _ in pairs]) / 2
    order = np.argsort(speed)
    return CurvePoints(speed[order], coef[: len(pairs)][order])


@one_blas_thread
def fit_ls(points: CurvePoints, w: FloatArray) -> FrictionFit:
    """f and b by linear least squares with w fixed."""
    w = np.asarray(w, dtype=float)
    coef = sla.lstsq(_basis(points.v, w), points.F)[0]
    return _result(coef, w, points, "ls (w fixed)")


def _result(coef: FloatArray, w: FloatArray, points: CurvePoints, method: str) -> FrictionFit:
    res = points.F - _basis(points.v, w) @ coef
    return FrictionFit(coef[:3], w, float(coef[3]), float(np.sqrt(np.mean(res**2))),
                       float(np.max(np.abs(res))), method, points)


#: |ln w| at most this: an LM step may try a huge slope (exp would overflow to inf, with a
#: RuntimeWarning, past ln w = 709); from e^40 (2e17 s/rad) on, tanh(w v) is the sign of v for
#: any measured speed, so bounding it changes no fit.
_LOG_W_BOUND = 40.0


def _slopes(log_w: FloatArray) -> FloatArray:
    return np.exp(np.clip(log_w, -_LOG_W_BOUND, _LOG_W_BOUND))


def _projected(log_w: FloatArray, points: CurvePoints) -> FloatArray:
    a = _basis(points.v, _slopes(log_w))
    residual: FloatArray = points.F - a @ sla.lstsq(a, points.F)[0]
    return residual


@one_blas_thread
def fit_nls(points: CurvePoints, w_starts: FloatArray | None = None) -> FrictionFit:
    """f, w and b by variable-projection nonlinear least squares from several starts."""
    from scipy.optimize import least_squares  # slow to import: when a curve is fitted

    if points.v.size < 8:
        raise BadInputError(f"{points.v.size} friction curve points cannot determine the 7 "
                            "coefficients f, w, b robustly; sweep at least 8 speeds")
    if w_starts is None:
        grid = np.geomspace(0.3, 300.0, 7)
        w_starts = np.array([c for c in itertools.combinations(grid[::-1], 3)])
    best = None
    for w0 in w_starts:
        sol = least_squares(_projected, np.log(w0), args=(points,), method="lm", xtol=1e-14,
                            ftol=1e-14, gtol=1e-14, max_nfev=2000)
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    w = _slopes(best.x)
    order = np.argsort(w)[::-1]
    w = w[order]
    coef = sla.lstsq(_basis(points.v, w), points.F)[0]
    log.debug("friction NLS: cost %.3g, w = %s", best.cost, w)
    return _result(coef, w, points, "nls (variable projection)")


@one_blas_thread
def fit_ekf(points: CurvePoints, w0: FloatArray, passes: int = 20,
            p0: float = 1.0, r: float = 1e-6) -> FrictionFit:
    """f, w, b as constant states of an Extended Kalman Filter, fed the curve points in turn
    (``passes`` sweeps over the data, the paper's approach; for comparison with fit_nls)."""
    x = np.concatenate([fit_ls(points, w0).f, np.log(np.asarray(w0, dtype=float)),
                        [fit_ls(points, w0).b]])
    cov = p0 * np.eye(7)
    for _ in range(passes):
        for v, y in zip(points.v, points.F, strict=True):
            f, w, b = x[:3], np.exp(x[3:6]), x[6]
            th = np.tanh(w * v)
            h = np.concatenate([th, f * (1 - th**2) * v * w, [v]])   # d u_f / d [f, log w, b]
            s = h @ cov @ h + r
            gain = cov @ h / s
            x = x + gain * (y - (f @ th + b * v))
            cov = cov - np.outer(gain, h @ cov)
    return _result(np.append(x[:3], x[6]), np.exp(x[3:6]), points, "ekf")
