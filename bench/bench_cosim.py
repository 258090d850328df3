"""The co-simulation of the default writing task: its speed, the FMPy engine's fixed cost per run,
and the task as an SSP archive in libcosim and FMPy.

``--part speed``: the real-time factor of the FMPy co-simulation against the bare FMPy loop
ceiling measured in the same run, and where the time goes. The ceiling is the same FMI call
sequence per communication step (controller set/get, plant set, two doSteps, plant get) on the
same FMUs, made on FMPy's FMU2Slave methods directly with no master work around them (no error
guard, no reference copy, no recording, no progress). The breakdown times each FMI call kind
alone in a loop. The last table compares the FMI 3.0 FMUs with the FMI 2.0 ones under the same
master, measured in alternating blocks (FMI 2, FMI 3, FMI 2, ...) on the same reference. Loops
are timed by the CPU time of the calling thread (every FMI call and the C loop run on it), so
time spent waiting for a core on a loaded machine does not count; ``--clock wall`` uses the wall
clock. The FMPy master's and rr.simulate's times are those of their stepping loops
(CosimResult.cpu_time / wall_time), without loading the FMUs.

``--part reuse``: the per-run fixed cost of the FMPy engine: a run on fresh FMU instances
(extract both FMUs, load and instantiate them: what every run paid before the instances were
pooled) against a run on the reused, reset instances of the run before
(sim.fmu_slave.pooled_slave). For each run length (a 10 ms reference: nearly all fixed cost; a
1 s one: a typical sweep run) the two are timed in alternation, fresh, reused, fresh, ... (wall
clock of the whole run_cosim call); the results of the two are checked to be identical bit for
bit before anything is timed.

``--part ssp``: the writing task as an SSP archive in libcosim and FMPy against rrr writing: the
maximum and RMS tip error of each built-in scenario with the one-step compensation (reference
look-ahead and controller lead), with the reference look-ahead only, and with none; then one run
in libcosim's real-time mode and the real-time factor it achieved. Each run's figures (those of
``rrr writing``, about 5 CPU-s a run) are drawn only with ``--out``, where they are kept.

Every table gives min / median / max over the repeats, a ratio taken within each repeat. A
measurement, not a test: it asserts nothing.

Run:  python bench/bench_cosim.py [--part speed|reuse|ssp] [--repeats N] [--clock cpu|wall]
          [--fmi 2|3] [--out DIR] [--no-real-time | --real-time-only] [--scenario S] [--quick]
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import tempfile
import time
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import rrr_robot as rr
from _timing import CLOCKS_S, add_quick, apply_quick, mmm, timed
from rrr_robot.sim import fmu_slave
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
from rrr_robot.ssp.export import SspJob, export_ssp
from rrr_robot.ssp.run import SspRun, run_ssp
from rrr_robot.writing.job import WritingJob, run_writing
from rrr_robot.writing.scenarios import BUILTIN
from rrr_robot.writing.trajectory import make_reference

CLOCKS = CLOCKS_S
clock: Callable[[], float] = time.thread_time
PARTS = ("speed", "reuse", "ssp")
Ref = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


# ---- speed --------------------------------------------------------------------------------------
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


def speed_part(args: argparse.Namespace) -> None:
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
    print(f"\n## Co-simulation speed: {platform.processor() or platform.machine()}, "
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


# ---- reuse -------------------------------------------------------------------------------------
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


def reuse_part(args: argparse.Namespace) -> None:
    print(f"\n## The FMPy engine's fixed cost per run: FMI {args.fmi}.0, fresh instances against "
          f"reused ones, {args.repeats} interleaved pairs, wall clock, load average "
          f"{os.getloadavg()[0]:.2f}\n")
    print("| run | fresh instances, ms | reused instances, ms | fresh / reused (per pair) "
          "| fixed cost, ms (medians) |")
    print("|---|---|---|---|---:|")
    for duration in (0.01, 1.0):
        ref = reference(duration)
        _, a = one(ref, args.fmi, True)
        _, b = one(ref, args.fmi, False)
        for f in ("q", "qd", "qdd", "tip", "u", "u_n", "u_c"):
            if not np.array_equal(getattr(a, f), getattr(b, f)):
                raise SystemExit(f"reused instances differ from fresh ones in {f}")
        fresh, reused = [], []
        for _ in range(args.repeats):
            fresh.append(one(ref, args.fmi, True)[0])
            reused.append(one(ref, args.fmi, False)[0])
        ratio = [f / r for f, r in zip(fresh, reused, strict=True)]
        ms = [1e3 * v for v in fresh], [1e3 * v for v in reused]
        print(f"| {duration:g} s reference ({round(duration / 1e-3) + 1} samples) | "
              f"{mmm(ms[0], '.3g')} | {mmm(ms[1], '.3g')} | {mmm(ratio, '.3g')} | "
              f"{np.median(ms[0]) - np.median(ms[1]):.1f} |")


# ---- ssp ---------------------------------------------------------------------------------------
def without_lead(src: Path, dst: Path) -> Path:
    """The archive with the controller's lead set to 0 (the reference keeps its look-ahead)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "SystemStructure.ssd":
                text, n = re.subn(r'(<ssv:Parameter name="lead">\s*<ssv:Real value=")[^"]*',
                                  r"\g<1>0.0", data.decode())
                assert n == 1
                data = text.encode()
            zout.writestr(item, data)
    return dst


def ssp_part(args: argparse.Namespace) -> None:
    print("\n## The writing task as an SSP system\n")
    with tempfile.TemporaryDirectory(prefix="bench-ssp-") as tmp:
        root = args.out or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        if args.real_time_only:
            export_ssp(SspJob(out=root / "ctc.ssp", scenario="ctc"))
        scenarios = args.scenario or list(BUILTIN)
        ours = {"scenarios": {}} if args.real_time_only else run_writing(
            WritingJob(out=root / "writing", engine="native", figures=False,
                       scenarios=scenarios))
        print("| scenario | rrr writing: max / RMS (mm) | compensation | libcosim: max / RMS (mm)"
              " | FMPy: max / RMS (mm) |")
        print("|---|---|---|---|---|")
        for scn in () if args.real_time_only else scenarios:
            w = ours["scenarios"][scn]
            both = root / f"{scn}.ssp"
            export_ssp(SspJob(out=both, scenario=scn))
            none = root / f"{scn}-none.ssp"
            export_ssp(SspJob(out=none, scenario=scn, lookahead_steps=0))
            ref_only = without_lead(both, root / f"{scn}-reference-only.ssp")
            for label, ssp in (("look-ahead + lead (default)", both),
                               ("look-ahead only", ref_only), ("none", none)):
                cells = []
                for tool in ("libcosim", "fmpy"):
                    s = run_ssp(SspRun(ssp=ssp, tool=tool, out=root / f"{ssp.stem}-{tool}",
                                       figures=args.out is not None))
                    m = s["scenarios"][scn]
                    cells.append(f"{1e3 * m['tip_error_max']:.3f} / "
                                 f"{1e3 * m['tip_error_rms']:.3f} "
                                 f"({s['ssp']['real_time_factor']:.0f}x real time)")
                print(f"| `{scn}` | {1e3 * w['tip_error_max']:.3f} / "
                      f"{1e3 * w['tip_error_rms']:.3f} | {label} | {cells[0]} | {cells[1]} |")
        if not args.no_real_time:
            s, wall = timed(lambda: run_ssp(SspRun(ssp=root / "ctc.ssp", tool="libcosim",
                                                    out=root / "rt", real_time=True)))
            info = s["ssp"]
            print(f"\nreal time (libcosim, ctc): {info['simulated_time']:.3f} s simulated in "
                  f"{info['wall_time']:.3f} s: real-time factor {info['real_time_factor']:.4f} "
                  f"(libcosim's own figure at the end: {info['libcosim_real_time_factor']:.4f}); "
                  f"the whole call took {wall:.2f} s with loading and writing")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", action="append", choices=PARTS,
                    help="what to measure (repeatable; default: all three)")
    ap.add_argument("--repeats", type=int,
                    help="alternating blocks (speed: default 5, at least 3) or interleaved pairs "
                    "(reuse: default 20)")
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="cpu",
                    help="speed: cpu (default), the calling thread's CPU time; wall: the wall "
                    "clock")
    ap.add_argument("--calls", type=int, default=5000,
                    help="speed: calls per row of 'where the time goes' (default 5000)")
    ap.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                    help="reuse: the FMUs' FMI version (default 2)")
    ap.add_argument("--out", type=Path, help="ssp: folder for the archives, results and "
                    "figures (default: a temporary one, no figures)")
    ap.add_argument("--no-real-time", action="store_true", help="ssp: skip the real-time run")
    ap.add_argument("--real-time-only", action="store_true", help="ssp: only the real-time run")
    ap.add_argument("--scenario", action="append", choices=list(BUILTIN), metavar="S",
                    help="ssp: the scenarios of the table (repeatable; default: all built-in)")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 2, "calls": 200, "scenario": ["ctc"],
                                             "no_real_time": True})
    for part in args.part or PARTS:
        if part == "speed":
            speed_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 5}))
        elif part == "reuse":
            reuse_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 20}))
        else:
            ssp_part(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
