"""The per-run fixed cost of the FMPy engine: a run on fresh FMU instances (extract both FMUs,
load and instantiate them: what every run paid before the instances were pooled) against a run
on the reused, reset instances of the run before (sim.fmu_slave.pooled_slave).

For each run length (a 10 ms reference: nearly all fixed cost; a 1 s one: a typical sweep run)
the two are timed in alternation, fresh, reused, fresh, ... (wall clock of the whole run_cosim
call), and the table gives min / median / max of each and of their ratio per pair. The results
of the two are checked to be identical bit for bit before anything is timed.

Run:  python bench/bench_fmu_reuse.py [--pairs 20] [--fmi 2|3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _timing import add_quick, apply_quick
from rrr_robot.sim import fmu_slave
from rrr_robot.sim.cosim import CosimOptions, CosimResult, run_cosim

Ref = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def reference(duration: float) -> Ref:
    t = np.arange(0.0, duration + 5e-4, 1e-3)
    w = np.array([3.0, 5.0, 7.0])
    q = 0.3 + 0.2 * np.sin(np.outer(t, w))
    qd = 0.2 * np.cos(np.outer(t, w)) * w
    qdd = -0.2 * np.sin(np.outer(t, w)) * w**2
    return t, q, qd, qdd, np.zeros_like(q)


def one(ref: Ref, fmi: int, fresh: bool) -> tuple[float, CosimResult]:
    if fresh:
        fmu_slave.clear_pool()  # the next run extracts and instantiates, as before pooling
    start = time.perf_counter()
    res = run_cosim(*ref, CosimOptions(fmi_version=fmi))
    return time.perf_counter() - start, res


def stats(values: list[float], scale: float = 1.0) -> str:
    a = np.asarray(values) * scale
    return f"{a.min():8.2f} {np.median(a):8.2f} {a.max():8.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=20)
    parser.add_argument("--fmi", type=int, choices=(2, 3), default=2)
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(), {"pairs": 2})
    print(f"FMPy engine, FMI {args.fmi}.0: fresh instances vs reused ones, {args.pairs} "
          "interleaved pairs, wall clock (a shared machine: read the ratios)")
    print(f"{'run':>6} {'fresh ms (min med max)':>27} {'reused ms':>27} "
          f"{'fresh/reused':>27} {'fixed cost ms':>14}")
    for duration in (0.01, 1.0):
        ref = reference(duration)
        _, a = one(ref, args.fmi, True)
        _, b = one(ref, args.fmi, False)
        for f in ("q", "qd", "qdd", "tip", "u", "u_n", "u_c"):
            if not np.array_equal(getattr(a, f), getattr(b, f)):
                raise SystemExit(f"reused instances differ from fresh ones in {f}")
        fresh, reused = [], []
        for _ in range(args.pairs):
            fresh.append(one(ref, args.fmi, True)[0])
            reused.append(one(ref, args.fmi, False)[0])
        ratio = [f / r for f, r in zip(fresh, reused, strict=True)]
        print(f"{duration:5.2f}s {stats(fresh, 1e3):>27} {stats(reused, 1e3):>27} "
              f"{stats(ratio):>27} {np.median(fresh) * 1e3 - np.median(reused) * 1e3:14.1f}")


if __name__ == "__main__":
    main()
