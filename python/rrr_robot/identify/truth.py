"""An identification against the truth (``rrr identify --truth FILE``): for a simulated
experiment the true robot file is known, so each estimate can stand beside its true value.

- Base parameters: the estimate, its 95 % interval (estimate +/- 1.96 standard deviations of the
  chosen estimator, :mod:`.base_params`), the true value (the truth's ``p``: its
  ``[base_parameters]``, or eq 12 of its link tables) and whether the interval holds it.
- Friction (with a friction log): per joint the estimated f, w and b beside the true ones, and
  the largest difference between the two eq 9 curves over the speeds the sweep measured (f and w
  trade against each other, so the curve is what the fit is responsible for). The fit gives no
  standard deviations, so there is no interval here.
- The parameters identification does not estimate (kinematics, g, k_t, u_max) come from the
  prior; those in which the prior and the truth differ are listed (they bias the estimate).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import _lib
from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.param_names import PARAMS, group_names
from .base_params import Estimate
from .friction import FrictionFit

__all__ = ["Z95", "TruthComparison", "compare_with_truth", "friction_curve"]

#: The two-sided 95 % quantile of the normal distribution: interval = estimate +/- Z95 std.
Z95 = 1.96
#: Groups identification estimates (the others are the prior's).
ESTIMATED = ("p", "f", "w", "b")


def friction_curve(f: FloatArray, w: FloatArray, b: float, v: FloatArray) -> FloatArray:
    """Eq 9 of one joint at the speeds ``v``: sum_k f_k tanh(w_k v) + b v, V."""
    v = np.asarray(v, dtype=float)
    out: FloatArray = np.tanh(np.outer(v, w)) @ np.asarray(f, dtype=float) + b * v
    return out


@dataclass(frozen=True)
class TruthComparison:
    """Each estimate beside its true value (see the module doc)."""

    source: str                  # the truth's robot file
    estimator: str               # ls or wls: whose p and standard deviations
    p: FloatArray                # estimate
    p_std: FloatArray
    p_true: FloatArray
    friction: tuple[dict[str, Any], ...] | None   # per joint, with a friction log
    prior_differs: tuple[str, ...]  # parameters taken from the prior that differ from the truth

    @property
    def low(self) -> FloatArray:
        out: FloatArray = self.p - Z95 * self.p_std
        return out

    @property
    def high(self) -> FloatArray:
        out: FloatArray = self.p + Z95 * self.p_std
        return out

    @property
    def inside(self) -> np.ndarray:
        """Whether each 95 % interval holds the true value."""
        return (self.low <= self.p_true) & (self.p_true <= self.high)

    def report(self) -> dict[str, Any]:
        """As JSON values (the ``truth`` section of ``rrr identify --report``)."""
        names = group_names("p")
        return {
            "source": self.source, "estimator": self.estimator,
            "p": [{"name": n, "estimate": float(e), "std": float(s), "interval_95": [lo, hi],
                   "truth": float(t), "inside_95": bool(i)}
                  for n, e, s, lo, hi, t, i in zip(names, self.p, self.p_std,
                                                   self.low.tolist(), self.high.tolist(),
                                                   self.p_true, self.inside, strict=True)],
            "p_inside_95": int(self.inside.sum()), "p_count": int(self.p.size),
            "friction": None if self.friction is None else list(self.friction),
            "prior_differs": list(self.prior_differs),
        }

    def toml_values(self) -> dict[str, Any]:
        """What the identified robot file's [identification] table keeps of it."""
        out: dict[str, Any] = {"truth": self.source, "p_true": self.p_true.tolist(),
                               "p_inside_95": int(self.inside.sum())}
        if self.friction is not None:
            out["friction_curve_error_max_V"] = [j["curve_error_max_V"] for j in self.friction]
        return out

    def lines(self) -> list[str]:
        """The comparison for the terminal: a line per base parameter, the count inside, a line
        per joint's friction, and the prior's parameters that differ from the truth."""
        out = [f"estimate ({self.estimator}) beside the truth ({self.source}):",
               f"  {'':<5}   {'estimate':>12} {'95 % interval':>27} {'truth':>12}"]
        for name, e, lo, hi, t, ok in zip(group_names("p"), self.p, self.low, self.high,
                                          self.p_true, self.inside, strict=True):
            out.append(f"  {name:<5} = {e: 12.6g} [{lo: 12.6g}, {hi: 12.6g}] {t + 0.0: 12.6g}"
                       f"  {'inside' if ok else 'OUTSIDE'}")
        out.append(f"{int(self.inside.sum())} of {self.p.size} true base parameters inside "
                   "their 95 % intervals")
        if self.friction:
            out.append("friction (eq 9) beside the truth; the fit gives no interval, the curve "
                       "is what it is responsible for:")
        for j in self.friction or ():
            out.append(
                f"friction joint {j['joint']}: f {_vec(j['f'])} (true {_vec(j['f_true'])}), "
                f"w {_vec(j['w'])} (true {_vec(j['w_true'])}), b {j['b']:.4g} (true "
                f"{j['b_true']:.4g}); curve within {j['curve_error_max_V']:.2e} V of the "
                f"truth's from {j['speed_min']:.3g} to {j['speed_max']:.3g} rad/s")
        if self.prior_differs:
            out.append(f"the prior differs from the truth in {', '.join(self.prior_differs)} "
                       "(not identified: the estimate is biased by it)")
        return out


def _vec(values: Sequence[float]) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in values) + "]"


def _friction(fits: Sequence[FrictionFit], true: Model) -> tuple[dict[str, Any], ...]:
    out = []
    for j, fit in enumerate(fits):
        v = np.abs(np.asarray(fit.points.v, dtype=float))
        grid = np.geomspace(v.min(), v.max(), 200) if v.min() > 0 else np.linspace(0, v.max(), 200)
        grid = np.concatenate([-grid[::-1], grid])
        est = friction_curve(fit.f, fit.w, fit.b, grid)
        tru = friction_curve(true.f[j], true.w[j], float(true.b[j]), grid)
        out.append({"joint": j + 1, "f": fit.f.tolist(), "f_true": true.f[j].tolist(),
                    "w": fit.w.tolist(), "w_true": true.w[j].tolist(), "b": float(fit.b),
                    "b_true": float(true.b[j]), "speed_min": float(v.min()),
                    "speed_max": float(v.max()),
                    "curve_error_max_V": float(np.max(np.abs(est - tru))),
                    "curve_true_max_V": float(np.max(np.abs(tru)))})
    return tuple(out)


def compare_with_truth(estimate: Estimate, friction: Sequence[FrictionFit] | None,
                       prior: Model, true: Model, source: str) -> TruthComparison:
    """The estimate (``estimate``: the base parameters of the chosen estimator; ``friction``:
    the fits, None without a friction log) beside the true model ``true`` of the robot file
    ``source``; ``prior`` is the model that supplied what is not identified."""
    differs = tuple(info.name for info in PARAMS if info.group not in ESTIMATED and
                    _lib.param_get(prior.raw, info.row) != _lib.param_get(true.raw, info.row))
    if friction is None:  # the prior's friction is used: it too differs from the truth or not
        differs += tuple(info.name for info in PARAMS if info.group in ("f", "w", "b") and
                         _lib.param_get(prior.raw, info.row) != _lib.param_get(true.raw,
                                                                                info.row))
    return TruthComparison(
        source=source, estimator=estimate.method, p=np.asarray(estimate.p, dtype=float),
        p_std=np.asarray(estimate.std, dtype=float), p_true=np.asarray(true.p, dtype=float),
        friction=None if friction is None else _friction(friction, true),
        prior_differs=differs)
