#!/usr/bin/env python3
"""The plant's cost: its FMU's doStep, its open loop from Python, and what its stiffness costs.

``--part step``: one plant fmi2DoStep (1 ms) at the default integrator against the fixed-step
RK4 of ten substeps (the former default), interleaved in one process. A C driver
(bench/bench_plant_step.c, built here with the system C compiler against FMPy's FMI headers)
loads the plant FMU binary, makes one instance per configuration, snapshots each after
initialization, and then runs blocks: every block runs every configuration once over the same
input sequence from its snapshot (the order reversed every other block), timing each fmi2DoStep
call, and checks that every block ends in the same state (determinism). The table gives the
min / median / max over blocks of the mean cost per step, and of the ratio default / other
within each block. Configurations: ``default`` (adaptive Dormand-Prince
5(4), rtol and atol at their defaults) and ``fixed`` (adaptive = false, h_int = 1e-4 s) of the
FMU under test, and with ``--baseline-ref REF`` (or ``--baseline-fmu FILE``) the plant FMU built
from another revision, at its defaults (``today``). Inputs: ``open loop`` (u = [0.5, 1, 0.3] V
from q0 = (0.1, 0.4, 1.0), 2 s) and ``writing`` (the voltages of the default writing task's ctc
scenario, 5.91 s, recorded from a co-simulation with the FMU under test and replayed open loop:
the configurations' end states drift apart, as open-loop replays do; the accuracy is checked in
tests/c/test_plant.c and tests/python/fmu/test_plant_integrator.py).

``--part rollout``: ``rr.Plant.rollout`` (one C call along an input table) against a Python loop
of ``rr.Plant.step`` and MuJoCo's ``rollout`` (RK4) at matched accuracy, interleaved. The robot:
the default model with only the viscous part b of its friction (the tanh terms of eq 9 set to
0), so that MuJoCo, which has no eq 9, integrates the same equations: the motor torque k_t u
applied as ``qfrc_applied`` and k_t b qd as the joints' damping of the MuJoCo model read from
our URDF, with the rotor inertias as its armature and our gravity, continuous joints and no
contacts. The input: smooth voltages, held over ``--hold-ms`` intervals (a zero-order hold, what
all three integrate), ``--runs`` runs of ``--seconds`` each from random starts near
q0 = (0.1, 0.4, 1.0) at rest. The error of each method is max |q - q_ref| over the hold grid,
q_ref from our adaptive integrator at rtol = atol = 1e-12; MuJoCo's RK4 steps are hold / k for
k = 1, 2, 4, ...: the timing uses the coarsest step whose error is at most ours at the default
tolerances ("matched"). Both agree with the reference before they are timed (the script stops
otherwise). The wall time per simulated second as min / median / max over the blocks.

``--part stiffness``: librrr's stiffness estimate (rrr_plant_stiffness, |d qdd / d qd| from the
friction's tanh slopes and the inertia) against the measured work of the adaptive integrator per
simulated second, for friction amplitudes f[i,1] that take the default robot from its own
1.6e3 1/s up to just below the limit every simulation accepts (RRR_PLANT_STIFFNESS_MAX, 1e6 1/s)
and one set above it, which is refused (docs/limits.md). Each row: the plant run for
``--seconds`` of 1 ms steps from rest under a smooth input, timed by the CPU time of the thread;
evaluations are librrr's count.

A measurement, not a test: it prints and never fails on a missed target.

Usage:
    python bench/bench_plant.py [--part step|rollout|stiffness] [--repeats N] [--seconds S]
        [--fmu-dir DIR] [--baseline-ref REF | --baseline-fmu FILE] [--no-writing]
        [--hold-ms MS] [--runs N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import rrr_robot as rr
from _timing import add_quick, apply_quick, interleaved, logger
from rrr_robot.core.stiffness import STIFFNESS_MAX, Stiffness, stiffness

ROOT = Path(__file__).resolve().parent.parent
DRIVER = ROOT / "bench" / "bench_plant_step.c"
STEP = 1e-3
OPEN_LOOP_Q0 = (0.1, 0.4, 1.0)
OPEN_LOOP_U = (0.5, 1.0, 0.3)
DEFAULT_HOLD = 5e-3
HOLD = DEFAULT_HOLD  # s: --hold-ms / 1e3 (set by rollout)
Q0 = (0.1, 0.4, 1.0)
#: f[i,1] of every joint (w[i,1] = 100 s/rad): the default 0.08, then stiffer, then too stiff
AMPLITUDES = (0.08, 1.0, 5.0, 47.0, 1e4)
PARTS = ("step", "rollout", "stiffness")
log = logger("bench_plant")


# ---- step: the FMU's fmi2DoStep ---------------------------------------------------------------
class Binary:
    """A plant FMU binary (Linux, FMI 2.0) with its GUID and value references."""

    def __init__(self, unzip_dir: Path) -> None:
        import xml.etree.ElementTree as ET

        root = ET.parse(unzip_dir / "modelDescription.xml").getroot()
        self.guid = root.attrib["guid"]
        self.vr = {v.attrib["name"]: int(v.attrib["valueReference"])
                   for v in root.iter("ScalarVariable")}
        self.so = unzip_dir / "binaries" / "linux64" / "rrr_plant.so"
        self.resources = (unzip_dir / "resources").as_uri()

    def config(self, label: str, q0: tuple[float, ...], values: dict[str, object]) -> str:
        sets = {f"q0[{i + 1}]": q for i, q in enumerate(q0)} | values
        spec = ",".join(f"{self.vr[k]}={str(v).lower() if isinstance(v, bool) else repr(v)}"
                        for k, v in sets.items())
        return f"{label}|{self.so}|{self.guid}|{self.resources}|{spec}"


def unzip(fmu: Path, into: Path) -> Path:
    with zipfile.ZipFile(fmu) as z:
        z.extractall(into)
    return into


def build_baseline(ref: str, work: Path) -> Path:
    """The FMI 2.0 plant FMU of revision REF, built from `git archive` (staged, unzipped)."""
    src = work / "src"
    src.mkdir()
    log(f"building the plant FMU of {ref} in {src} ...")
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    build = work / "build"
    subprocess.run(["cmake", "-S", str(src), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                    "-DRRR_BUILD_HIL=OFF", "-DRRR_BUILD_TESTS=OFF", "-DRRR_FMU_WINDOWS=OFF",
                    f"-DPython3_EXECUTABLE={sys.executable}"], check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(build), "-j2", "--target", "rrr_plant_fmi2_fmu"],
                   check=True, capture_output=True)
    return build / "fmu" / "fmi2" / "rrr_plant"


def build_driver(work: Path) -> Path:
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    exe = work / "bench_plant_step"
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-O2", "-std=c11", "-Wall", "-Wextra", f"-I{headers}", str(DRIVER),
                    "-o", str(exe), "-ldl"], check=True)
    return exe


def writing_inputs(plant_fmu: Path, controller_fmu: Path,
                   work: Path) -> tuple[tuple[float, ...], np.ndarray]:
    """q0 and the applied voltages of the default writing task's ctc scenario."""
    from rrr_robot.core.param_names import model_fmu_values
    from rrr_robot.sim.cosim import CosimOptions, run_cosim
    from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, (scn,), ref = prepare(WritingJob(out=work / "writing", scenarios=["ctc"]))
    res = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                    CosimOptions(step=float(ref.t[1] - ref.t[0]),
                                 plant_values=model_fmu_values(model),
                                 controller_values=controller_fmu_values(
                                     scn, model, robot.require_control()),
                                 plant_fmu=plant_fmu, controller_fmu=controller_fmu))
    # u at t_k is held over [t_k, t_k+1]: the last sample has no step after it
    return tuple(float(v) for v in ref.q[0]), np.asarray(res.u, dtype=float)[:-1]


def run(driver: Path, blocks: int, u: np.ndarray, configs: list[str], work: Path) -> list[dict]:
    inputs = work / "u.bin"
    np.concatenate([[float(len(u))], np.asarray(u, dtype=float).ravel()]).tofile(inputs)
    out = subprocess.run([str(driver), str(blocks), repr(STEP), str(inputs), *configs],
                         check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def report(name: str, rows: list[dict], n: int, labels: list[str]) -> None:
    per: dict[str, list[float]] = {lab: [] for lab in labels}
    q_end: dict[str, list[float]] = {}
    for r in rows:
        if "us_per_step" in r:
            per[r["label"]].append(r["us_per_step"])
        else:
            q_end[r["label"]] = r["q_end"]
    print(f"\n### {name}: {n} doSteps of 1 ms per block, {len(per[labels[0]])} blocks\n")
    print("| configuration | us per fmi2DoStep: min / median / max |")
    print("|---|---|")
    for lab in labels:
        a = np.array(per[lab])
        print(f"| {lab} | {a.min():.3f} / {np.median(a):.3f} / {a.max():.3f} |")
    base = np.array(per["default"])
    for other in labels[1:]:
        ratio = base / np.array(per[other])
        print(f"| default / {other} (per block) | {ratio.min():.3f} / {np.median(ratio):.3f} / "
              f"{ratio.max():.3f} |")
    diff = {lab: float(np.max(np.abs(np.array(q_end[lab]) - np.array(q_end["default"]))))
            for lab in labels[1:]}
    print("\nend state, max |q - q_default| (rad): "
          + ", ".join(f"{lab} {d:.3g}" for lab, d in diff.items()))


def step_part(args: argparse.Namespace) -> None:
    if args.fmu_dir is not None:
        plant_fmu, ctrl_fmu = args.fmu_dir / "rrr_plant.fmu", args.fmu_dir / "rrr_controller.fmu"
    else:
        plant_fmu, ctrl_fmu = Path(rr.fmu_path("plant")), Path(rr.fmu_path("controller"))
    work = Path(tempfile.mkdtemp(prefix="bench_plant_step-"))
    try:
        new = Binary(unzip(plant_fmu, work / "new"))
        baseline = None
        if args.baseline_fmu is not None:
            baseline = Binary(unzip(args.baseline_fmu, work / "baseline"))
        elif args.baseline_ref is not None:
            (work / "baseline").mkdir()
            baseline = Binary(build_baseline(args.baseline_ref, work / "baseline"))
        driver = build_driver(work)
        scenarios: list[tuple[str, tuple[float, ...], np.ndarray]] = [
            ("open loop, u = [0.5, 1, 0.3] V, 2 s", OPEN_LOOP_Q0,
             np.tile(OPEN_LOOP_U, (2000, 1)))]
        if not args.no_writing:
            try:
                q0, u = writing_inputs(plant_fmu, ctrl_fmu, work)
                scenarios.append(("writing task ctc voltages, replayed open loop", q0, u))
            except Exception as exc:  # a bench: say why and go on
                log(f"no writing-task inputs ({type(exc).__name__}: {exc}); open loop only")
        load = os.getloadavg()
        print(f"\n## The plant FMU's doStep: {platform.processor() or platform.machine()}, "
              f"{os.cpu_count()} CPUs, load average {load[0]:.2f} at start")
        print(f"FMU under test: {plant_fmu}"
              + (f"; today: {args.baseline_ref or args.baseline_fmu}" if baseline else ""))
        for name, q0, u in scenarios:
            labels = ["default", "fixed"]
            configs = [new.config("default", q0, {}),
                       new.config("fixed", q0, {"adaptive": False, "h_int": 1e-4})]
            if baseline is not None:
                labels.append("today")
                configs.append(baseline.config("today", q0, {}))
            rows = run(driver, args.repeats, u, configs, work)
            report(name, rows, len(u), labels)
        print(f"\nload average {os.getloadavg()[0]:.2f} at the end")
    finally:
        shutil.rmtree(work, ignore_errors=True)


# ---- rollout: open loop from Python -----------------------------------------------------------
def viscous(m: rr.Model) -> rr.Model:
    """The model with its viscous friction b only (the tanh terms f of eq 9 set to 0)."""
    return m.with_params(f=np.zeros_like(m.f))


def inputs(model: rr.Model, seconds: float, runs: int) -> tuple[np.ndarray, np.ndarray]:
    """``runs`` start positions (runs, 3) and input tables (runs, n, 3): voltages held over 5 ms,
    sines of random phases within 30 % of u_max (seeded)."""
    rng = np.random.default_rng(1)
    t = np.arange(round(seconds / HOLD)) * HOLD
    w = np.array([1.3, 2.1, 2.9]) * 2.0
    phase = rng.uniform(0.0, 2.0 * np.pi, (runs, 1, 3))
    u = 0.3 * float(np.min(model.u_max)) * np.sin(w * t[None, :, None] + phase)
    return np.asarray(Q0) + rng.uniform(-0.5, 0.5, (runs, 3)), u


def ours(model: rr.Model, q0: np.ndarray, u: np.ndarray, integ: rr.PlantIntegrator
         ) -> np.ndarray:
    """q (runs, n, 3) of one Plant.rollout per run."""
    return np.stack([rr.Plant(model, q0=q0[i], integrator=integ).rollout(u[i], HOLD).q
                     for i in range(u.shape[0])])


def ours_loop(model: rr.Model, q0: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The same with a Python call of Plant.step per row."""
    q = np.empty_like(u)
    for i in range(u.shape[0]):
        plant = rr.Plant(model, q0=q0[i])
        for k in range(u.shape[1]):
            plant.step(u[i, k], HOLD)
            q[i, k] = plant.q
    return q


class Mujoco:
    """The same robot in MuJoCo (from our URDF): RK4 at HOLD / substeps, tau = k_t u applied."""

    def __init__(self, r: rr.RobotFile, model: rr.Model, substeps: int, folder: Path) -> None:
        import mujoco

        self.mj = mujoco
        # continuous joints (no limits: ours has none) and no contacts: the bare equations
        urdf = rr.write_urdf(folder / "r.urdf", r, continuous=True)
        self.model = mujoco.MjModel.from_xml_path(str(urdf))
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        self.model.dof_armature[:] = r.rotor_inertia
        self.model.dof_damping[:] = model.kt * model.b  # k_t b qd: eq 9's viscous term
        self.model.opt.gravity[:] = (0.0, 0.0, -r.model.g)
        self.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        self.model.opt.timestep = HOLD / substeps
        self.substeps = substeps
        self.kt = model.kt
        self.data = mujoco.MjData(self.model)  # one MjData: one thread
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.qpos = slice(1, 1 + self.model.nq)  # FULLPHYSICS: time, qpos, qvel, ...

    def initial(self, q0: np.ndarray) -> np.ndarray:
        """(runs, nstate) initial states at q0, at rest."""
        out = np.empty((q0.shape[0], self.mj.mj_stateSize(self.model, self.spec)))
        for i, q in enumerate(q0):
            self.mj.mj_resetData(self.model, self.data)
            self.data.qpos[:] = q
            self.mj.mj_getState(self.model, self.data, out[i], self.spec)
        return out

    def run(self, state0: np.ndarray, u: np.ndarray) -> np.ndarray:
        """q (runs, n, 3) of one MuJoCo rollout call over every run."""
        from mujoco import rollout

        tau = np.repeat(u * self.kt, self.substeps, axis=1)  # held over the substeps
        state, _ = rollout.rollout(self.model, self.data, state0, tau,
                                   control_spec=self.mj.mjtState.mjSTATE_QFRC_APPLIED)
        return state[:, self.substeps - 1::self.substeps, self.qpos]


def rollout_part(args: argparse.Namespace) -> None:
    global HOLD
    HOLD = args.hold_ms * 1e-3
    try:
        import mujoco  # noqa: F401
    except ImportError:
        log("MuJoCo is not installed: pip install mujoco (the bench extra has it)")
        return
    r = rr.read_robot_file()  # the packaged robot: its links (the URDF) and motors
    model = viscous(r.model)
    q0, u = inputs(model, args.seconds, args.runs)
    ref = ours(model, q0, u, rr.PlantIntegrator(rtol=1e-12, atol=1e-12))
    mine = ours(model, q0, u, rr.PlantIntegrator())
    err_ours = float(np.abs(mine - ref).max())
    err_loop = float(np.abs(ours_loop(model, q0, u) - mine).max())
    if err_loop != 0.0:
        raise SystemExit(f"Plant.rollout and the Plant.step loop differ by {err_loop:.3g} rad")
    with tempfile.TemporaryDirectory() as tmp:
        rows, matched = [], None
        for k in (1, 2, 4, 8, 16, 32):
            mj = Mujoco(r, model, k, Path(tmp))
            err = float(np.abs(mj.run(mj.initial(q0), u) - ref).max())
            rows.append((k, err))
            if matched is None and err <= err_ours:
                matched = mj
        if matched is None:
            log(f"no MuJoCo RK4 step down to {HOLD / 32 * 1e6:.0f} us reaches our error "
                f"{err_ours:.3g} rad: timing the finest")
            matched = mj
        sim = u.shape[0] * u.shape[1] * HOLD

        def block(fn: object) -> object:
            def run() -> float:
                t0 = time.perf_counter()
                fn()  # type: ignore[operator]
                return (time.perf_counter() - t0) / sim * 1e3  # ms per simulated second
            return run

        state0 = matched.initial(q0)
        mj_run = matched.run
        series = interleaved([block(lambda: ours(model, q0, u, rr.PlantIntegrator())),
                              block(lambda: ours_loop(model, q0, u)),
                              block(lambda: mj_run(state0, u))],
                             args.repeats)  # type: ignore[list-item]
    print(f"\n## Open loop from Python: {args.runs} runs of {args.seconds:g} s ({sim:g} s "
          f"simulated), input held over {HOLD * 1e3:g} ms, the default robot with viscous "
          "friction only; error = max |q - q_ref| (q_ref: ours at rtol = atol = 1e-12)\n")
    print("| MuJoCo RK4 step (us) | error (rad) |")
    print("|---:|---:|")
    for k, err in rows:
        print(f"| {HOLD / k * 1e6:.0f} | {err:.3g} |")
    print(f"\nours (adaptive, default tolerances): error {err_ours:.3g} rad; the Plant.step loop "
          "equals Plant.rollout bit for bit\n")
    print(f"| method | error (rad) | ms per simulated second, min / median / max "
          f"({args.repeats} interleaved blocks) |")
    print("|---|---:|---:|")
    step_us = HOLD / matched.substeps * 1e6
    err_mj = dict(rows)[matched.substeps]
    print(f"| rr.Plant.rollout | {err_ours:.3g} | {series[0].format('.3g')} |")
    print(f"| rr.Plant.step loop in Python | {err_ours:.3g} | {series[1].format('.3g')} |")
    print(f"| MuJoCo rollout, RK4 {step_us:.0f} us (matched) | {err_mj:.3g} | "
          f"{series[2].format('.3g')} |")
    ratio = series[2].over(series[0])
    print(f"\nMuJoCo / ours per block: {ratio.format('.3g')}")


# ---- stiffness: what it costs ----------------------------------------------------------------
def stiffness_row(f11: float, seconds: float) -> str:
    default = rr.Model.default()
    f = [[f11, *row[1:]] for row in default.f.tolist()]
    model = default.with_params(f=f)
    try:
        lam = stiffness(model.raw)
    except Stiffness as exc:
        return f"{f11:>8g}  {exc.value:>10.3g}  refused: {exc.field} named, nothing runs"
    plant = rr.Plant(model)
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


def stiffness_part(args: argparse.Namespace) -> None:
    print(f"\n## What a plant's stiffness costs\n\nstiffness limit: {STIFFNESS_MAX:.0e} 1/s; "
          f"{args.seconds:g} simulated s per row")
    print(f"{'f[i,1]':>8}  {'lambda 1/s':>10}  {'evals per s':>14}  {'CPU s/s':>10}  "
          f"{'ns/eval':>8}")
    for f11 in AMPLITUDES:
        print(stiffness_row(f11, args.seconds))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--part", action="append", choices=PARTS,
                    help="what to measure (repeatable; default: all three)")
    ap.add_argument("--repeats", type=int,
                    help="interleaved blocks (default: 9 for step, 7 for rollout)")
    ap.add_argument("--seconds", type=float, default=1.0,
                    help="simulated time of each rollout run and of each stiffness row "
                    "(default 1)")
    ap.add_argument("--fmu-dir", type=Path,
                    help="step: folder with rrr_plant.fmu and rrr_controller.fmu (a CMake "
                    "build's fmus/); default: the installed package's")
    ap.add_argument("--baseline-ref", help="step: git revision whose plant FMU is 'today'")
    ap.add_argument("--baseline-fmu", type=Path, help="step: a plant .fmu file as 'today'")
    ap.add_argument("--no-writing", action="store_true", help="step: open loop only")
    ap.add_argument("--hold-ms", type=float, default=DEFAULT_HOLD * 1e3,
                    help="rollout: input hold, ms: the table's step (default 5; 1 is a 1 kHz "
                    "controller's)")
    ap.add_argument("--runs", type=int, default=20,
                    help="rollout: runs from other starts (default 20)")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 1, "seconds": 0.1, "runs": 2})
    for part in args.part or PARTS:
        if part == "step":
            step_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 9}))
        elif part == "rollout":
            rollout_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 7}))
        else:
            stiffness_part(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
