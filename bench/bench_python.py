#!/usr/bin/env python3
"""Benchmark the Python API of rrr_robot (the compiled binding rrr_robot.core._ext) against
Pinocchio's and the Robotics Toolbox's Python APIs, on the same robot and the same inputs.

Rows: one state of ``Model.inverse_dynamics`` against ``pin.rnea``; ``Model.fk`` against
``ets.eval``; ``Model.ik`` (every branch) against ``ets.ik_LM`` (one solution);
``Model.forward_dynamics`` against ``accel``; a batch of 1e5 states of ``Model.inverse_dynamics``
against the Robotics Toolbox's batch ``rne``, written into a reused array (``out=``) and into a
new one, with the minor page faults per call of ours (the first write of fresh memory), and
against librrr's ``rrr_inverse_dynamics`` in a plain C loop (``loops_inverse_dynamics`` of
bench/core_loops.c, built with the system C compiler against the package's librrr.so: the floor
of the scalar batch); the batch's vector kernels (``simd="auto"``: AVX-512 or AVX2 where
the CPU has them) against its scalar path, and so for the regressor, FK, forward dynamics and
IK (``Model.ik(x, "front", "up")`` of the FK of the batch's angles); and one state of
``Model.inverse_dynamics`` against MuJoCo's ``mj_inverse`` and Drake's ``CalcInverseDynamics``
(both on the robot read from our URDF, with the rotor inertias as MuJoCo's armature and added as
J_m qdd to Drake's result, gravity ours).

Interleaved: each repeat times a block of ours and a block of the reference on the same inputs
back to back (the order alternating between repeats), so both see the same machine load; each
row reports min / median / max over the repeats of ns per call (per state for batches) and of
the per-repeat ratio reference / ours. The agreement of every pair is checked first. Blocks are
timed by the CPU time of the thread (``--clock wall``: the wall clock), so the time this process
waits for a core on a loaded machine is not counted.

``--part memory``: what the result's memory costs a batch call: ``Model.inverse_dynamics`` of
``--batch`` states into a new array against into a reused one (``out=``), each call after
another program's allocations and frees of large arrays (here twenty numpy arrays of the batch's
size), after which glibc has given the memory back to the operating system, so that a new result
array is fresh memory: its first write takes a page fault per 4 KiB page. Interleaved (new,
out=, out=, new, ...), each call timed alone by the thread's CPU time (the kernel's page-fault
handling included) with its minor page faults (getrusage): min / median / max of ns per state
and the faults per call, and the cost per fault from the medians. The rows above are ``--part
api`` (the default runs both).

This is a measurement, not a test: nothing fails when a target is missed.

Usage: python bench/bench_python.py [--part api|memory] [--repeats N] [--states N] [--batch N]
                                    [--seed N] [--clock cpu|wall] [--json FILE] [--quick]
"""

from __future__ import annotations

import argparse
import ctypes as ct
import datetime as dt
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from _timing import CLOCKS, Series, add_quick, apply_quick, interleaved, logger, mmm

ROOT = Path(__file__).resolve().parent.parent
ALPHA = (np.pi / 2, 0.0, 0.0)
IK_Q0 = np.array([0.1, 0.2, 1.0])  # the start of run_bench.py's LM references
POSITION_MASK = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
log = logger("bench_python")


@dataclass
class Pair:
    """One row: our call and the reference's on the same inputs, each timed as a block of
    ``calls`` calls (``per`` items per call: states of a batch)."""

    operation: str
    ours_name: str
    ours: Callable[[int], object]
    ref_name: str
    ref: Callable[[int], object]
    calls: int
    per: int = 1
    target: str = ""
    target_ratio: float | None = None
    target_ns: float | None = None
    ours_ns: list[float] = field(default_factory=list)
    ref_ns: list[float] = field(default_factory=list)
    agreement: str = ""
    clock: Callable[[], int] = time.thread_time_ns
    count_faults: bool = False  # report ours' minor page faults per call

    ours_faults: list[float] = field(default_factory=list)

    def block(self, fn: Callable[[int], object]) -> float:
        """ns per item of one block (for ours, also the minor page faults per call)."""
        f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        t0 = self.clock()
        for k in range(self.calls):
            fn(k)
        t1 = self.clock()
        if fn is self.ours:
            faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
            self.ours_faults.append(faults / self.calls)
        return (t1 - t0) / (self.calls * self.per)

    def run(self, repeats: int) -> None:
        for k in range(min(self.calls, 20)):  # warm-up
            self.ours(k)
            self.ref(k)
        ours, ref = interleaved([lambda: self.block(self.ours), lambda: self.block(self.ref)],
                                repeats, warmup=False)
        self.ours_ns, self.ref_ns = list(ours.values), list(ref.values)

    @property
    def ratios(self) -> list[float]:
        return [r / o for o, r in zip(self.ours_ns, self.ref_ns, strict=True)]

    def verdict(self) -> str:
        if not self.target:
            return ""
        ok = True
        if self.target_ratio is not None:
            ok &= Series.of(self.ratios).median >= self.target_ratio
        if self.target_ns is not None:
            ok &= Series.of(self.ours_ns).median <= self.target_ns
        return f"{self.target}: {'met' if ok else 'NOT met'}"


def fmt_ns(ns: float) -> str:
    return f"{ns:,.0f}" if ns >= 100 else f"{ns:.1f}"


def fmt_ratio(r: float) -> str:
    return f"{r:,.1f}x" if r < 100 else f"{r:,.0f}x"


def batch_floor(workdir: Path, package: Path) -> Any:
    """``loops_inverse_dynamics`` of bench/core_loops.c (run_bench.py's C loops), built against
    the package's librrr.so, as a function of one batch (None without a C compiler)."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        log("no C compiler: the librrr-in-C row is left out")
        return None
    lib = workdir / "libcoreloops.so"
    include = ROOT / "c_src" / "rrr" / "include"
    subprocess.run([cc, "-std=c11", "-O2", "-shared", "-fPIC", f"-I{include}",
                    str(ROOT / "bench" / "core_loops.c"), f"-L{package}", "-l:librrr.so",
                    f"-Wl,-rpath,{package}", "-o", str(lib)], check=True)
    floor = ct.CDLL(str(lib))
    fn = floor.loops_inverse_dynamics
    fn.argtypes = [ct.c_void_p] * 5 + [ct.c_long, ct.c_long]
    fn.restype = ct.c_long
    return lambda *args: fn(*args, 1)  # one pass over the batch


def build(args: argparse.Namespace, workdir: Path) -> tuple[list[Pair], dict[str, str]]:
    import pinocchio as pin
    import roboticstoolbox as rtb
    import rrr_robot as rr
    from rrr_robot.core import _ext
    from rrr_robot.core.batch import simd_best
    from rrr_robot.writing.references import inertial_from_robot, pinocchio_model

    robot_file = rr.read_robot_file()
    model = robot_file.model
    inertial = inertial_from_robot(robot_file)
    if inertial is None:
        sys.exit("bench_python: the default robot file has no link tables")
    dh = model.dh
    pm = pinocchio_model(dh, model.g, inertial)
    pdata = pm.createData()
    a = (0.0, dh["a2"], dh["a3"])
    d = (dh["d1"], dh["d2"], dh["d3"])
    links = [
        rtb.RevoluteDH(d=d[i], a=a[i], alpha=ALPHA[i], m=inertial.masses[i],
                       r=inertial.coms[i], I=inertial.inertias_com[i], Jm=inertial.rotor[i],
                       G=1.0, B=0.0, Tc=[0.0, 0.0])
        for i in range(3)
    ]
    robot = rtb.DHRobot(links, gravity=[0.0, 0.0, -model.g])
    ets = robot.ets()  # prebuilt once: robot.ik_LM would rebuild it on every call

    rng = np.random.default_rng(args.seed)
    n = args.states
    q = rng.uniform(-np.pi, np.pi, (n, 3))
    qd = rng.uniform(-3.0, 3.0, (n, 3))
    qdd = rng.uniform(-10.0, 10.0, (n, 3))
    q_ik = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi / 2, np.pi / 2, n),
                            rng.uniform(0.2, 2.5, n)])  # away from the elbow singularities
    x_ik, _ = model.fk(q_ik)
    teps = []
    for x in x_ik:
        tep = np.eye(4)
        tep[:3, 3] = x
        teps.append(tep)
    rows = [(q[k], qd[k], qdd[k]) for k in range(n)]  # the same row objects for both sides
    xs = list(x_ik)
    nb = args.batch
    bq, bqd, bqdd = (rng.uniform(lo, hi, (nb, 3)) for lo, hi in
                     ((-np.pi, np.pi), (-3.0, 3.0), (-10.0, 10.0)))
    floor = batch_floor(workdir, Path(rr.__file__).parent)

    def ik_lm(k: int) -> Any:
        return ets.ik_LM(teps[k % n], q0=IK_Q0, tol=args.ik_tol, mask=POSITION_MASK,
                         joint_limits=False)

    log("agreement checks")
    tau = model.inverse_dynamics(q, qd, qdd, simd="scalar")  # the one-state calls' numbers
    rnea = np.array([pin.rnea(pm, pdata, *rows[k]) for k in range(n)])
    fk_eval = np.array([ets.eval(q[k])[:3, 3] for k in range(n)])
    batch_ours = model.inverse_dynamics(bq, bqd, bqdd)
    batch_scalar = model.inverse_dynamics(bq, bqd, bqdd, simd="scalar")
    simd_diff = float(np.abs(batch_ours - batch_scalar).max())
    batch_rne = np.asarray(robot.rne(bq, bqd, bqdd), dtype=float)
    batch_out = np.empty_like(bq)
    batch_into = model.inverse_dynamics(bq, bqd, bqdd, out=batch_out).copy()
    if batch_into.tobytes() != batch_ours.tobytes():
        sys.exit("bench_python: inverse_dynamics into out= differs from the new array's result")
    lm_err, lm_solved = 0.0, 0
    for k in range(min(n, 200)):
        sol = ik_lm(k)
        if sol.success:
            lm_solved += 1
            back = model.fk(np.asarray(sol.q, dtype=float))[0]
            lm_err = max(lm_err, float(np.abs(back - xs[k]).max()))
    fk_back = max(float(np.abs(model.fk(model.ik(x))[0] - x).max()) for x in xs)
    fd_rows = [(q[k], qd[k], tau[k]) for k in range(n)]
    fd_accel = np.array([robot.accel(*fd_rows[k]) for k in range(min(n, 200))], dtype=float)
    fd_ours = model.forward_dynamics(q, qd, tau)

    per_call = args.calls
    pairs = [
        Pair("tau = R p, one state", "Model.inverse_dynamics",
             lambda k: model.inverse_dynamics(*rows[k % n]), "Pinocchio pin.rnea",
             lambda k: pin.rnea(pm, pdata, *rows[k % n]), per_call,
             target=">= 1x (goal 2x)", target_ratio=1.0,
             agreement=f"{np.abs(tau - rnea).max():.1e}"),
        Pair("FK, one state", "Model.fk", lambda k: model.fk(rows[k % n][0]),
             "RTB ets.eval", lambda k: ets.eval(rows[k % n][0]), per_call,
             target=">= 5x", target_ratio=5.0,
             agreement=f"{np.abs(fk_eval - model.fk(q)[0]).max():.1e}"),
        Pair("IK, one target (ours: all branches)", "Model.ik", lambda k: model.ik(xs[k % n]),
             "RTB ets.ik_LM (1 solution)", ik_lm, max(per_call // 20, 10),
             target=">= 5x", target_ratio=5.0,
             agreement=f"FK(IK(x)) - x: {fk_back:.1e} m; LM ({lm_solved}/{min(n, 200)} "
                       f"solved): {lm_err:.1e} m"),
        Pair("forward dynamics, one state", "Model.forward_dynamics",
             lambda k: model.forward_dynamics(*fd_rows[k % n]), "RTB accel",
             lambda k: robot.accel(*fd_rows[k % n]), max(per_call // 20, 10),
             agreement=f"{np.abs(fd_accel - fd_ours[: len(fd_accel)]).max():.1e} (RTB), "
                       f"{np.abs(fd_ours - qdd).max():.1e} (qdd back)"),
        Pair(f"tau = R p, batch of {nb:,} states (per state), into out= (the result array "
             "reused)", f"Model.inverse_dynamics ({simd_best()}, out=)",
             lambda k: model.inverse_dynamics(bq, bqd, bqdd, out=batch_out), "RTB rne (batch)",
             lambda k: robot.rne(bq, bqd, bqdd), 1, per=nb,
             target="<= 15 ns and >= 5x", target_ratio=5.0, target_ns=15.0,
             agreement=f"{np.abs(batch_into - batch_rne).max():.1e}", count_faults=True),
        Pair(f"tau = R p, batch of {nb:,} states (per state), a new result array",
             f"Model.inverse_dynamics ({simd_best()})",
             lambda k: model.inverse_dynamics(bq, bqd, bqdd), "RTB rne (batch)",
             lambda k: robot.rne(bq, bqd, bqdd), 1, per=nb, target=">= 5x", target_ratio=5.0,
             agreement=f"{np.abs(batch_ours - batch_rne).max():.1e}", count_faults=True),
        Pair(f"tau = R p, batch of {nb:,} states (per state): vector kernels against scalar",
             f"Model.inverse_dynamics ({simd_best()})",
             lambda k: model.inverse_dynamics(bq, bqd, bqdd), "Model.inverse_dynamics "
             "(simd='scalar')", lambda k: model.inverse_dynamics(bq, bqd, bqdd, simd="scalar"),
             1, per=nb, agreement=f"{simd_diff:.1e} (within 1e-13: "
                                  f"{'yes' if simd_diff <= 1e-13 else 'NO'})"),
    ]
    # the other batch kernels (regressor, FK, forward dynamics, IK): vector against scalar
    bx = model.fk(bq, simd="scalar")[0]  # reachable targets, IK on the front / up branch
    for label, method, inputs in (
            ("regressor R(q, qd, qdd)", model.regressor, (bq, bqd, bqdd)),
            ("FK (x and R)", model.fk, (bq,)),
            ("forward dynamics", model.forward_dynamics, (bq, bqd, batch_scalar)),
            ("IK (front / up)", model.ik, (bx, "front", "up"))):
        vec, sca = method(*inputs), method(*inputs, simd="scalar")
        pairs_out = zip(vec, sca, strict=True) if isinstance(vec, tuple) else [(vec, sca)]
        diff = max(float(np.abs(np.asarray(a) - np.asarray(b)).max()) for a, b in pairs_out)
        name = method.__name__
        pairs.append(Pair(
            f"{label}, batch of {nb:,} states (per state): vector kernels against scalar",
            f"Model.{name} ({simd_best()})",
            lambda k, f=method, a=inputs: f(*a), f"Model.{name} (simd='scalar')",
            lambda k, f=method, a=inputs: f(*a, simd="scalar"), 1, per=nb,
            agreement=f"{diff:.1e} (within 1e-13: {'yes' if diff <= 1e-13 else 'NO'})"))
    if floor is not None:
        out = np.empty((nb, 3))
        addr = [a.ctypes.data for a in (bq, bqd, bqdd, out)]
        m_addr = ct.addressof(model.raw)
        if floor(m_addr, *addr, nb) != -1:
            sys.exit("bench_python: loops_inverse_dynamics failed")

        def c_floor(k: int, arrays: tuple[Any, ...] = (bq, bqd, bqdd, out)) -> Any:
            # the arrays ride along: the C loop writes into `out`, which must outlive build()
            return floor(m_addr, *addr, nb)

        pairs.append(Pair(
            f"tau = R p, batch of {nb:,} states (per state): the scalar C floor",
            "Model.inverse_dynamics (simd='scalar')",
            lambda k: model.inverse_dynamics(bq, bqd, bqdd, simd="scalar"),
            "librrr in a C loop (bench/core_loops.c)", c_floor, 1,
            per=nb, agreement=f"bit-identical: {out.tobytes() == batch_scalar.tobytes()}"))
    pairs += engine_pairs(robot_file, rows, tau, per_call, workdir)
    info = {
        "binding": f"{Path(_ext.__file__).name} (GIL released from {_ext.NOGIL_ROWS} rows)",
        "versions": f"Python {platform.python_version()}, numpy {np.__version__}, pin "
                    f"{pin.__version__}, roboticstoolbox-python {rtb.__version__}, mujoco "
                    f"{mujoco_version()}, drake {drake_version()}",
    }
    return pairs, info


def mujoco_version() -> str:
    import mujoco

    return str(mujoco.__version__)


def drake_version() -> str:
    from importlib.metadata import version

    return version("drake")


def engine_pairs(robot_file: Any, rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                 tau: np.ndarray, calls: int, workdir: Path) -> list[Pair]:
    """One state of inverse dynamics against MuJoCo's mj_inverse and Drake's
    CalcInverseDynamics, on the robot of our URDF; their agreement with ours first."""
    import mujoco
    import rrr_robot as rr
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import MultibodyForces

    model = robot_file.model
    n = len(rows)
    urdf = rr.write_urdf(workdir / "robot.urdf", robot_file, continuous=True)
    rotor = np.asarray(robot_file.rotor_inertia, dtype=float)
    mj = mujoco.MjModel.from_xml_path(str(urdf))
    mj.dof_armature[:] = rotor
    mj.opt.gravity[:] = (0.0, 0.0, -model.g)
    md = mujoco.MjData(mj)

    def mj_inverse(k: int) -> np.ndarray:
        q, qd, qdd = rows[k % n]
        md.qpos[:], md.qvel[:], md.qacc[:] = q, qd, qdd
        mujoco.mj_inverse(mj, md)
        return md.qfrc_inverse.copy()

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link"))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -model.g])
    plant.Finalize()
    ctx = plant.CreateDefaultContext()
    forces = MultibodyForces(plant)

    def drake_inverse(k: int) -> np.ndarray:
        q, qd, qdd = rows[k % n]
        plant.SetPositions(ctx, q)
        plant.SetVelocities(ctx, qd)
        forces.SetZero()
        plant.CalcForceElementsContribution(ctx, forces)  # gravity
        return plant.CalcInverseDynamics(ctx, qdd, forces) + rotor * qdd

    mj_tau = np.array([mj_inverse(k) for k in range(n)])
    drake_tau = np.array([drake_inverse(k) for k in range(n)])
    for name, ref in (("MuJoCo", mj_tau), ("Drake", drake_tau)):
        err = float(np.abs(ref - tau).max())
        if not err <= 1e-9 * max(1.0, float(np.abs(tau).max())):
            sys.exit(f"bench_python: {name}'s inverse dynamics differ from ours by {err:.3g} N m")
    return [
        Pair("tau = R p, one state", "Model.inverse_dynamics",
             lambda k: model.inverse_dynamics(*rows[k % n]), "MuJoCo mj_inverse", mj_inverse,
             calls, agreement=f"{np.abs(tau - mj_tau).max():.1e}"),
        Pair("tau = R p, one state", "Model.inverse_dynamics",
             lambda k: model.inverse_dynamics(*rows[k % n]), "Drake CalcInverseDynamics",
             drake_inverse, max(calls // 10, 10),
             agreement=f"{np.abs(tau - drake_tau).max():.1e}"),
    ]


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def minor_faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def memory_part(args: argparse.Namespace) -> None:
    """A batch's result memory: a new array against out=, after the churn of large arrays."""
    import rrr_robot as rr
    from rrr_robot.core.batch import simd_best

    m = rr.Model.default()
    n = args.batch
    rng = np.random.default_rng(args.seed)
    q, qd, qdd = (rng.uniform(lo, hi, (n, 3)) for lo, hi in
                  ((-np.pi, np.pi), (-5.0, 5.0), (-20.0, 20.0)))
    out = np.empty((n, 3))
    if m.inverse_dynamics(q, qd, qdd, out=out).tobytes() != m.inverse_dynamics(
            q, qd, qdd).tobytes():
        sys.exit("bench_python: the result into out= differs from the new array's")

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
    print(f"\n## A batch's result memory: Model.inverse_dynamics of {n:,} states "
          f"({simd_best()}), {args.repeats} interleaved repeats, each call after the churn of "
          f"20 arrays of the batch's size; load average {load}; min / median / max\n")
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


def api_part(args: argparse.Namespace) -> None:
    """The Python API against the references' Python APIs: the table of rows."""
    load_start = " ".join(f"{v:.2f}" for v in os.getloadavg())
    with tempfile.TemporaryDirectory(prefix="rrr-bench-") as tmp:
        pairs, info = build(args, Path(tmp))
        for p in pairs:
            log(f"{p.operation}: {args.repeats} interleaved repeats")
            p.clock = CLOCKS[args.clock]
            p.run(args.repeats)
            if p.count_faults:
                p.agreement += (f"; minor page faults per call of ours: "
                                f"{mmm(p.ours_faults[-args.repeats:], lambda v: f'{v:,.0f}')}")
    load_end = " ".join(f"{v:.2f}" for v in os.getloadavg())

    print(f"## Python API benchmark, {dt.datetime.now().isoformat(timespec='seconds')}, "
          f"{cpu_model()}, {os.cpu_count()} CPUs, load average {load_start} (start) / "
          f"{load_end} (end)")
    print(f"{info['versions']}; binding: {info['binding']}")
    clock = "the thread's CPU time" if args.clock == "cpu" else "the wall clock"
    print(f"{args.repeats} interleaved repeats, blocks timed by {clock}; each cell: "
          "min / median / max\n")
    print("| operation | ours | ours (ns) | reference | reference (ns) | ratio ref/ours "
          "| agreement (max abs diff) | target |")
    print("|---|---|---:|---|---:|---:|---|---|")
    for p in pairs:
        print(f"| {p.operation} | `{p.ours_name}` | {mmm(p.ours_ns, fmt_ns)} | {p.ref_name} | "
              f"{mmm(p.ref_ns, fmt_ns)} | {mmm(p.ratios, fmt_ratio)} | {p.agreement} | "
              f"{p.verdict()} |")
    if args.json:
        args.json.write_text(json.dumps({
            "info": info, "load": [load_start, load_end], "clock": args.clock,
            "rows": [{"operation": p.operation, "ours_ns": p.ours_ns, "ref_ns": p.ref_ns,
                      "reference": p.ref_name, "agreement": p.agreement} for p in pairs],
        }, indent=1), encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", action="append", choices=("api", "memory"),
                        help="what to measure (repeatable; default: both)")
    parser.add_argument("--repeats", type=int,
                        help="interleaved repeats per row (default: 7 for api, 15 for memory)")
    parser.add_argument("--states", type=int, default=1000, help="single-state inputs")
    parser.add_argument("--calls", type=int, default=2000,
                        help="calls per block of a single-state row (IK LM, accel: 1/20 of it)")
    parser.add_argument("--batch", type=int, default=100_000, help="states of the batch rows")
    parser.add_argument("--ik-tol", type=float, default=1e-12, help="ets.ik_LM tol")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu",
                        help="time blocks by the CPU time of the thread (default) or the wall "
                             "clock")
    parser.add_argument("--json", type=Path, help="also write the api rows' raw timings here")
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(argv),
                       {"repeats": 2, "states": 40, "calls": 80, "batch": 2000})
    for part in args.part or ("api", "memory"):
        if part == "api":
            api_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 7}))
        else:
            memory_part(argparse.Namespace(**{**vars(args), "repeats": args.repeats or 15}))
    return 0

if __name__ == "__main__":
    sys.exit(main())
