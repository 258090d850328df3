"""What a plant's stiffness costs: librrr's estimate (rrr_plant_stiffness, |d qdd / d qd| from
the friction's tanh slopes and the inertia) against the measured work of the adaptive integrator
per simulated second, for friction amplitudes f[i,1] that take the default robot from its own
1.6e3 1/s up to just below the limit every simulation accepts (RRR_PLANT_STIFFNESS_MAX, 1e6 1/s)
and one set above it, which is refused (docs/limits.md).

Each row: the plant (rrr_plant_step through rrr_robot.core.plant.Plant) run for --seconds of
1 ms steps from rest under a smooth input, timed by the CPU time of the thread; evaluations are
librrr's count. The cost grows like the estimate (about one evaluation per simulated second per
1/s of stiffness): the limit bounds what any accepted parameter set costs.

Run:  python bench/bench_stiffness.py [--seconds 1]
"""

from __future__ import annotations

import argparse
import math
import time

from _timing import add_quick, apply_quick
from rrr_robot.core.model import Model
from rrr_robot.core.plant import Plant
from rrr_robot.core.stiffness import STIFFNESS_MAX, Stiffness, stiffness

#: f[i,1] of every joint (w[i,1] = 100 s/rad): the default 0.08, then stiffer, then too stiff
AMPLITUDES = (0.08, 1.0, 5.0, 47.0, 1e4)


def run(f11: float, seconds: float) -> str:
    default = Model.default()
    f = [[f11, *row[1:]] for row in default.f.tolist()]
    model = default.with_params(f=f)
    try:
        lam = stiffness(model.raw)
    except Stiffness as exc:
        return f"{f11:>8g}  {exc.value:>10.3g}  refused: {exc.field} named, nothing runs"
    plant = Plant(model)
    evals = 0
    n = max(1, round(seconds / 1e-3))
    start = time.thread_time()
    for k in range(n):
        t = k * 1e-3
        plant.step([2.0 * math.sin(6.28 * t), 1.5 * math.cos(3.0 * t), math.sin(10.0 * t)], 1e-3)
        evals += plant.stats.evals
    cpu = time.thread_time() - start
    sim = n * 1e-3
    return (f"{f11:>8g}  {lam:>10.3g}  {evals / sim:>14.3g}  {cpu / sim:>10.3f}  "
            f"{1e9 * cpu / evals:>8.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per row")
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(), {"seconds": 0.02})
    print(f"stiffness limit: {STIFFNESS_MAX:.0e} 1/s; {args.seconds:g} simulated s per row")
    print(f"{'f[i,1]':>8}  {'lambda 1/s':>10}  {'evals per s':>14}  {'CPU s/s':>10}  "
          f"{'ns/eval':>8}")
    for f11 in AMPLITUDES:
        print(run(f11, args.seconds))


if __name__ == "__main__":
    main()
