#!/usr/bin/env python3
"""What the result's memory costs a batch call: ``Model.inverse_dynamics`` of 1e5 states into a
new array against into a reused one (``out=``), each call after another program's allocations
and frees of large arrays (here twenty numpy arrays of the batch's size), after which glibc has
given the memory back to the operating system, so that a new result array is fresh memory: its
first write takes a page fault per 4 KiB page.

Interleaved (new, out=, out=, new, ...), each call timed alone by the thread's CPU time (the
kernel's page-fault handling included) with its minor page faults (getrusage). Prints
min / median / max of ns per state and the faults per call, and the cost per fault from the
medians.

Run:  python bench/bench_batch_memory.py [--states 100000] [--repeats 15] [--quick]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from collections.abc import Callable

import numpy as np
from _timing import Series, add_quick, apply_quick, interleaved, mmm


def minor_faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=100_000)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--seed", type=int, default=1)
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(argv), {"states": 2000, "repeats": 2})

    import rrr_robot as rr
    from rrr_robot.core.batch import simd_best

    m = rr.Model.default()
    n = args.states
    rng = np.random.default_rng(args.seed)
    q, qd, qdd = (rng.uniform(lo, hi, (n, 3)) for lo, hi in
                  ((-np.pi, np.pi), (-5.0, 5.0), (-20.0, 20.0)))
    out = np.empty((n, 3))
    if m.inverse_dynamics(q, qd, qdd, out=out).tobytes() != m.inverse_dynamics(
            q, qd, qdd).tobytes():
        sys.exit("bench_batch_memory: the result into out= differs from the new array's")

    def churn() -> float:
        arrays = [np.ones((n, 3)) for _ in range(20)]
        return float(sum(a[0, 0] for a in arrays))

    faults: dict[str, list[float]] = {"new": [], "out": []}

    def block(name: str, call: Callable[[], object]) -> Callable[[], float]:
        def run() -> float:
            churn()
            f0, t0 = minor_faults(), time.thread_time_ns()
            call()
            t1, f1 = time.thread_time_ns(), minor_faults()
            faults[name].append(f1 - f0)
            return (t1 - t0) / n
        return run

    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    new, into = interleaved([block("new", lambda: m.inverse_dynamics(q, qd, qdd)),
                             block("out", lambda: m.inverse_dynamics(q, qd, qdd, out=out))],
                            args.repeats)
    print(f"Model.inverse_dynamics of {n:,} states ({simd_best()}), {args.repeats} interleaved "
          f"repeats, each call after the churn of 20 arrays of the batch's size; load average "
          f"{load}; min / median / max\n")
    print("| result | ns per state | minor page faults per call |")
    print("|---|---:|---:|")
    rows = (("a new array", new, faults["new"][1:]), ("into out= (reused)", into,
                                                       faults["out"][1:]))
    for label, series, counts in rows:
        print(f"| {label} | {series.format('.1f')} | {mmm(counts, '.0f')} |")
    extra = (new.median - into.median) * n
    per = Series.of(faults["new"][1:]).median
    if per > 0:
        print(f"\nmedian difference {extra / 1e3:,.0f} us a call, {per:,.0f} faults: about "
              f"{extra / per / 1e3:.2f} us a fault")
    return 0


if __name__ == "__main__":
    sys.exit(main())
