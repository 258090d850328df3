"""Real-time factor of the FMPy co-simulation of the default writing task, against the bare
FMPy loop ceiling measured in the same run, and where the time goes.

The ceiling is the same FMI call sequence per communication step (controller set/get, plant
set, two doSteps, plant get) on the same FMUs, made on FMPy's FMU2Slave methods directly with no
master work around them (no error guard, no reference copy, no recording, no progress). The
breakdown times each FMI call kind alone in a loop. The last table compares the FMI 3.0 FMUs
with the FMI 2.0 ones under the same master, measured in alternating blocks (FMI 2, FMI 3,
FMI 2, ...) on the same reference: min / median / max.

Loops are timed by the CPU time of the calling thread (every FMI call and the C loop run on it),
so time spent waiting for a core on a loaded machine does not count; ``--clock wall`` uses the
wall clock. The FMPy master's and rr.simulate's times are those of their stepping loops
(CosimResult.cpu_time / wall_time), without loading the FMUs.

Run:  python bench/bench_cosim.py [--repeats 5] [--clock cpu|wall]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable

import numpy as np
import rrr_robot as rr
from _timing import CLOCKS_S, add_quick, apply_quick
from rrr_robot.sim.cosim import (
    CTRL_IN,
    CTRL_OUT,
    PLANT_IN,
    PLANT_OUT,
    CosimOptions,
    CosimResult,
    run_cosim,
)
from rrr_robot.sim.fmu_slave import FmuSlave
from rrr_robot.writing.trajectory import make_reference

CLOCKS = CLOCKS_S
clock: Callable[[], float] = time.thread_time


def loop_time(res: CosimResult) -> float:
    """The stepping loop's time of a run on the chosen clock."""
    return res.cpu_time if clock is time.thread_time else res.wall_time


def bare_loop(n: int, step: float, q0: np.ndarray) -> float:
    """Seconds for n steps of the FMI calls alone, made on FMPy's FMU2Slave directly (no
    guard, no copy, no recording): the ceiling of any master written over FMPy."""
    with FmuSlave(rr.fmu_path("controller"), "c") as ctrl, \
            FmuSlave(rr.fmu_path("plant"), "p") as plant:
        ctrl.initialize()
        plant.initialize(0.0, {f"q0[{i + 1}]": float(q0[i]) for i in range(3)})
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        p_in, p_out = plant.real_block(PLANT_IN), plant.real_block(PLANT_OUT)
        c_in.values[:3] = q0
        c_in.values[9:12] = q0
        cf, pf = ctrl._fmu, plant._fmu  # FMPy's FMU2Slave objects
        cc, pc = cf.component, pf.component
        nc_in, nc_out, np_in, np_out = len(CTRL_IN), len(CTRL_OUT), len(PLANT_IN), len(PLANT_OUT)
        t = 0.0
        start = clock()
        for _ in range(n):
            cf.fmi2SetReal(cc, c_in.vrs, nc_in, c_in.buffer)
            cf.fmi2GetReal(cc, c_out.vrs, nc_out, c_out.buffer)
            pf.fmi2SetReal(pc, p_in.vrs, np_in, p_in.buffer)
            pf.fmi2DoStep(pc, t, step, 1)
            cf.fmi2DoStep(cc, t, step, 1)
            t += step
            pf.fmi2GetReal(pc, p_out.vrs, np_out, p_out.buffer)
        return clock() - start


def per_call(n: int, step: float) -> dict[str, float]:
    """Microseconds per call of each FMI call kind, each timed alone."""
    out: dict[str, float] = {}
    with FmuSlave(rr.fmu_path("controller"), "c") as ctrl, \
            FmuSlave(rr.fmu_path("plant"), "p") as plant:
        ctrl.initialize()
        plant.initialize(0.0, {"q0[2]": 0.4, "q0[3]": 1.0})
        c_in, c_out = ctrl.real_block(CTRL_IN), ctrl.real_block(CTRL_OUT)
        p_in, p_out = plant.real_block(PLANT_IN), plant.real_block(PLANT_OUT)
        c_in.values[:] = 0.1
        calls: dict[str, Callable[[], object]] = {
            "controller setReal (15 inputs)": lambda: ctrl.set_block(c_in),
            "controller getReal (9 outputs, runs rrr_ctc)": lambda: (ctrl.set_block(c_in),
                                                                     ctrl.get_block(c_out)),
            "plant setReal (3 inputs)": lambda: plant.set_block(p_in),
            "plant doStep (1 ms, default integrator)": lambda: plant.do_step(step),
            "controller doStep": lambda: ctrl.do_step(step),
            "plant getReal (12 outputs)": lambda: plant.get_block(p_out),
        }
        for name, fn in calls.items():
            start = time.perf_counter()
            for _ in range(n):
                fn()
            out[name] = 1e6 * (time.perf_counter() - start) / n
        key = "controller getReal (9 outputs, runs rrr_ctc)"
        out[key] -= out["controller setReal (15 inputs)"]  # the set only marks inputs dirty
    return out


def fmi_versions(ref: object, step: float, blocks: int) -> tuple[list[float], list[float]]:
    """Wall times of run_cosim with the FMI 2.0 and the FMI 3.0 FMUs, in alternating blocks."""
    walls: dict[int, list[float]] = {2: [], 3: []}
    for _ in range(blocks):
        for version in (2, 3):
            opts = CosimOptions(step=step, fmi_version=version)
            res = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)  # type: ignore[attr-defined]
            walls[version].append(loop_time(res))
    return walls[2], walls[3]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="alternating blocks (>= 3)")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu",
                        help="cpu (default): the calling thread's CPU time; wall: the wall clock")
    parser.add_argument("--calls", type=int, default=5000,
                        help="calls per row of 'where the time goes' (default 5000)")
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(), {"repeats": 3, "calls": 200})
    global clock
    clock = CLOCKS[args.clock]
    model = rr.Model.default()
    ref = make_reference(model)
    step = float(ref.t[1] - ref.t[0])
    n = ref.t.size
    sim_time = float(ref.t[-1] - ref.t[0])
    blocks = max(3, args.repeats)
    walls: dict[str, list[float]] = {"master": [], "ceiling": [], "native": []}
    opts = CosimOptions(step=step)
    for _ in range(blocks):  # alternating blocks: master, bare loop, native, master, ...
        walls["master"].append(loop_time(run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)))
        walls["ceiling"].append(bare_loop(n - 1, step, ref.q[0]))
        walls["native"].append(loop_time(rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)))
    print(f"# Co-simulation speed: {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, Python {platform.python_version()}, {blocks} alternating "
          f"blocks, min / median / max, {args.clock} clock, load average "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"default writing task: {sim_time:.2f} s simulated, {n} steps of {1e3 * step:g} ms\n")
    print("| loop | real-time factor | us/step (median) |")
    print("|---|---|---|")
    for key, name in (("master", "run_cosim: FMUs through FMPy (master, recording)"),
                      ("ceiling", "bare FMPy loop (the same FMI calls, nothing else)"),
                      ("native", "rr.simulate: the same loop in C (rrr_sim_closed_loop)")):
        rtf = sim_time / np.array(walls[key])
        print(f"| {name} | {rtf.min():.1f}x / {np.median(rtf):.1f}x / {rtf.max():.1f}x | "
              f"{1e6 * float(np.median(walls[key])) / n:.2f} |")
    share = np.array(walls["ceiling"]) / np.array(walls["master"])
    speedup = np.array(walls["master"]) / np.array(walls["native"])
    print(f"\nmaster / ceiling (per block): {100 * share.min():.0f} / "
          f"{100 * np.median(share):.0f} / {100 * share.max():.0f} %; rr.simulate / master: "
          f"{speedup.min():.1f}x / {np.median(speedup):.1f}x / {speedup.max():.1f}x\n")
    print("| where the time goes (each call alone) | us/call |")
    print("|---|---|")
    for name, us in per_call(args.calls, step).items():
        print(f"| {name} | {us:.2f} |")
    w2, w3 = fmi_versions(ref, step, max(3, args.repeats))
    ratio = np.array(w3) / np.array(w2)
    print(f"\n| FMUs (alternating blocks, {len(w2)} each) | real-time factor min / median / max |")
    print("|---|---|")
    for name, w in (("FMI 2.0", w2), ("FMI 3.0", w3)):
        rtf = sim_time / np.array(w)
        print(f"| {name} | {rtf.min():.1f}x / {np.median(rtf):.1f}x / {rtf.max():.1f}x |")
    print(f"| wall time FMI 3.0 / FMI 2.0 | {ratio.min():.2f} / {np.median(ratio):.2f} / "
          f"{ratio.max():.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
