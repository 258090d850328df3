"""The runs of a sweep: each run's values, computed up front on the client from the spec alone.

Every run ``k`` has its own seed, drawn from (the spec's seed, k) by numpy's SeedSequence
(``spawn_key=(k,)``): it depends on nothing else (not on the worker, the order runs finish in or
the number of samples). Methods:

- ``random``: run k's values are drawn, in the order of [vary], from
  ``numpy.random.default_rng(seed_k)``: uniform, normal, log-uniform (exp of a uniform draw of
  the log), values (each with equal probability); with ``per_element`` one draw per element, in
  the field's order (row-major);
- ``lhs``: a Latin hypercube (scipy.stats.qmc.LatinHypercube, scrambled, seeded by the spec's
  seed) with one dimension per independent draw: each dimension's [0, 1) is cut into
  ``samples`` strata with one run in each, mapped through the inverse distribution function
  (normal: scipy.stats.norm.ppf; values: stratum of the list);
- ``grid``: every combination of the values lists, the last key changing fastest.

Values are as a scenario file gives them (floats, arrays as tuples, strings, booleans) and go
through the same checks there (rrr_robot.sweep.runs).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .spec import SweepSpec, Vary

__all__ = ["RunInput", "design", "run_seed"]


@dataclass(frozen=True)
class RunInput:
    """One run: its index, its seed and the value of every varied key (spec order)."""

    run: int
    seed: int
    values: tuple[tuple[str, Any], ...]


def run_seed(seed: int, run: int) -> int:
    """The seed of run ``run`` of a sweep seeded ``seed`` (63 bits: it fits an int64 column)."""
    state = np.random.SeedSequence(seed, spawn_key=(run,)).generate_state(1, np.uint64)
    return int(state[0] >> np.uint64(1))


def _shaped(v: Vary, flat: Sequence[Any]) -> Any:
    """Draws of one key as its value: one, or the field's shape of them (tuples)."""
    if not v.dist.per_element:
        return flat[0]
    shape = v.target.shape
    if len(shape) == 1:
        return tuple(flat)
    return tuple(tuple(flat[i * shape[1]:(i + 1) * shape[1]]) for i in range(shape[0]))


def _from_unit(v: Vary, u: np.ndarray) -> list[Any]:
    """Draws of one key from numbers in [0, 1) (inverse distribution function)."""
    d = v.dist
    a, b = d.params
    if d.kind == "values":
        idx = np.minimum((u * len(d.values)).astype(np.int64), len(d.values) - 1)
        return [d.values[int(i)] for i in idx]
    if d.kind == "uniform":
        x = a + u * (b - a)
    elif d.kind == "loguniform":
        x = np.exp(math.log(a) + u * (math.log(b) - math.log(a)))
    else:
        from scipy.stats import norm

        x = norm.ppf(u, loc=a, scale=b)
    return [float(e) for e in x]


def _random(v: Vary, rng: np.random.Generator) -> list[Any]:
    d, n = v.dist, v.dims
    a, b = d.params
    if d.kind == "values":
        return [d.values[int(i)] for i in rng.integers(len(d.values), size=n)]
    if d.kind == "uniform":
        x = rng.uniform(a, b, size=n)
    elif d.kind == "loguniform":
        x = np.exp(rng.uniform(math.log(a), math.log(b), size=n))
    else:
        x = rng.normal(a, b, size=n)
    return [float(e) for e in x]


def design(spec: SweepSpec) -> list[RunInput]:
    """Every run of the spec, in run order."""
    n = spec.samples
    seeds = [run_seed(spec.seed, k) for k in range(n)]
    keys = [v.key for v in spec.vary]
    if spec.method == "grid":
        combos = itertools.product(*(v.dist.values for v in spec.vary))
        return [RunInput(k, seeds[k], tuple(zip(keys, combo, strict=True)))
                for k, combo in enumerate(combos)]
    if spec.method == "random":
        runs = []
        for k in range(n):
            rng = np.random.default_rng(seeds[k])
            runs.append(RunInput(k, seeds[k], tuple(
                (v.key, _shaped(v, _random(v, rng))) for v in spec.vary)))
        return runs
    dims = sum(v.dims for v in spec.vary)
    if dims == 0:
        return [RunInput(k, seeds[k], ()) for k in range(n)]
    from scipy.stats import qmc

    unit = qmc.LatinHypercube(d=dims, rng=np.random.default_rng(spec.seed)).random(n)
    columns: list[list[Any]] = []
    first = 0
    for v in spec.vary:
        draws = [_from_unit(v, unit[:, first + j]) for j in range(v.dims)]
        columns.append([_shaped(v, [draws[j][k] for j in range(v.dims)]) for k in range(n)])
        first += v.dims
    return [RunInput(k, seeds[k], tuple((key, col[k]) for key, col in zip(keys, columns,
                                                                          strict=True)))
            for k in range(n)]
