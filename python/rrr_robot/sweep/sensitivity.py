"""Which varied input matters most: a ranking of the inputs of a sweep by how much of the
variance of an output (the maximum tip error) each explains alone.

Inputs: each varied key, and each element of a key drawn per element (``mismatch.p_rel[3]``,
``mismatch.f_rel[1,2]``: "which parameter matters most"); a key whose values are text, flags or
whole arrays (a values list of gains) is one categorical input.

For each input the first-order sensitivity index S1 = Var(E[Y | X]) / Var(Y) is estimated from
the runs themselves (the correlation ratio): the runs are grouped by the input's value (a
categorical input, or a numeric one with few distinct values) or into equal-count bins of it
(``bins`` = floor(sqrt(n)), 2 to 20), and S1 is the share of the variance of Y between the
groups. S1 is in [0, 1]; independent inputs with additive effects have indices summing to 1;
an input without effect gets about (groups - 1) / (n - 1) from sampling noise alone, which is
reported as ``noise_floor``. Numeric inputs also get Spearman's rank correlation with Y (its
sign says whether the error grows with the input). Only runs whose output is finite count.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .spec import Vary

__all__ = ["Input", "Sensitivity", "inputs", "rank"]

MAX_BINS = 20


@dataclass(frozen=True)
class Input:
    """One input of the ranking: its name, its values over the runs (float; codes 0, 1, ...
    for a categorical one) and the labels of a categorical one's codes."""

    name: str
    values: np.ndarray
    categories: tuple[str, ...] = ()

    @property
    def numeric(self) -> bool:
        return not self.categories


@dataclass(frozen=True)
class Sensitivity:
    """S1 of one input, Spearman's rho (numeric inputs), the runs and groups it used."""

    input: str
    s1: float
    spearman: float | None
    runs: int
    groups: int
    noise_floor: float


def _label(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_label(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def inputs(vary: Sequence[Vary], columns: dict[str, list[Any]]) -> list[Input]:
    """The inputs of the ranking from the result columns of the varied keys."""
    out: list[Input] = []
    for v in vary:
        col = columns[v.key]
        t = v.target
        if v.dist.per_element:
            arr = np.array([np.ravel(np.asarray(c, dtype=float)) for c in col], dtype=float)
            arr = arr.reshape(len(col), t.size)
            for j in range(t.size):
                index = str(j + 1) if len(t.shape) == 1 else \
                    f"{j // t.shape[1] + 1},{j % t.shape[1] + 1}"
                out.append(Input(f"{v.key}[{index}]", arr[:, j]))
        elif t.kind == "number" and not (col and isinstance(col[0], list | tuple)):
            out.append(Input(v.key, np.array(col, dtype=float)))
        else:
            labels = [_label(c) for c in col]
            order = list(dict.fromkeys(_label(x) for x in v.dist.values)) if v.dist.values \
                else sorted(set(labels))
            codes = np.array([order.index(lb) for lb in labels], dtype=float)
            out.append(Input(v.key, codes, tuple(order)))
    return out


def _groups(x: np.ndarray, categorical: bool) -> np.ndarray:
    """Group index of each run: by value (categorical, or few distinct values), else by
    equal-count bins of the ranks."""
    distinct, codes = np.unique(x, return_inverse=True)
    bins = min(MAX_BINS, max(2, math.isqrt(x.size)))
    if categorical or distinct.size <= bins:
        return np.asarray(codes, dtype=np.int64)
    ranks = np.argsort(np.argsort(x, kind="stable"), kind="stable")
    return np.asarray(ranks * bins // x.size, dtype=np.int64)


def _s1(x: np.ndarray, y: np.ndarray, categorical: bool) -> tuple[float, int]:
    groups = _groups(x, categorical)
    total = float(np.sum((y - y.mean()) ** 2))
    if total == 0.0:
        return 0.0, int(groups.max()) + 1
    between = 0.0
    for g in np.unique(groups):
        yg = y[groups == g]
        between += yg.size * float(yg.mean() - y.mean()) ** 2
    return min(1.0, between / total), int(np.unique(groups).size)


def rank(inps: Sequence[Input], y: np.ndarray) -> list[Sensitivity]:
    """The inputs by S1 of ``y``, largest first (inputs that do not vary over the runs with a
    finite ``y`` are left out)."""
    from scipy.stats import spearmanr

    finite = np.isfinite(y)
    yy = y[finite]
    out = []
    for inp in inps:
        x = inp.values[finite]
        if yy.size < 3 or np.unique(x).size < 2:
            continue
        s1, groups = _s1(x, yy, not inp.numeric)
        rho = None
        if inp.numeric and np.unique(yy).size > 1:
            rho = float(spearmanr(x, yy).statistic)
        floor = (groups - 1) / (yy.size - 1)
        out.append(Sensitivity(inp.name, s1, rho, int(yy.size), groups, floor))
    return sorted(out, key=lambda s: (-s.s1, s.input))
