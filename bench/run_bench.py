#!/usr/bin/env python3
"""Benchmark the closed-form core librrr against Pinocchio (C++) and the Robotics Toolbox.

One command, one run: builds the C++ driver bench/bench_core.cpp and the C loops
bench/core_loops.c with CMake (librrr from c_src/rrr with the repository's own CMakeLists,
Pinocchio from the ``pin`` wheel), runs the driver (librrr against Pinocchio, interleaved), times
the Robotics Toolbox for Python (``ets.ik_LM`` on a prebuilt ETS, ``rne``, ``accel``) against
librrr in C loops on the same inputs, interleaved, counts the operations of our generated
dynamics (c_src/rrr/gen/derive_dynamics.py) and of our IK (a hand count of
c_src/rrr/src/rrr_kinematics.c, checked against the source text), and prints markdown tables.

Interleaved: each repeat times one block of ours and one block of the reference back to back on
the same inputs (the order reversed every other repeat), so a change of machine load hits both;
every cell is min / median / max over the repeats and each ratio is taken within a repeat.
Blocks are timed by the CPU time of the timing thread (``--clock wall``: the wall clock), so the
time this process waits for a core on a loaded machine is not counted. The Python API of
rrr_robot against the references' Python APIs is bench/bench_python.py.

This is a measurement, not a test: nothing fails when a target is missed.

Usage:
    python bench/run_bench.py [--build-dir DIR] [--calls N] [--repeats N] [--states N]
                              [--py-states N] [--py-repeats N] [--c-loop-calls N]
                              [--ik-tol E] [--clock cpu|wall] [--skip-build] [--json FILE]
"""

from __future__ import annotations

import argparse
import ctypes as ct
import datetime as dt
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from _timing import CLOCKS, Series, add_quick, apply_quick, interleaved, logger, timed

FloatArray = npt.NDArray[np.float64]

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"
GEN_SCRIPT = ROOT / "c_src" / "rrr" / "gen" / "derive_dynamics.py"
GEN_DIR = ROOT / "c_src" / "rrr" / "src"
KIN_SOURCE = ROOT / "c_src" / "rrr" / "src" / "rrr_kinematics.c"

PAPER_IK_FLOPS = 102
PAPER_DYN_FLOPS = 393
TARGET_TAU_VS_RNEA = 8.0  # tau = R p at most 1/8 of the Pinocchio rnea time
TARGET_IK_VS_LM = 150.0  # IK at least 150x faster than ets.ik_LM
ALPHA = (np.pi / 2, 0.0, 0.0)
IK_Q0 = np.array([0.1, 0.2, 1.0])  # the same start as the C++ LM reference
POSITION_MASK = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])


log = logger("run_bench")


# ---------------------------------------------------------------------------------------------
# Build and run the C++ driver
# ---------------------------------------------------------------------------------------------
def cmeel_prefix() -> Path:
    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    if not (prefix / "lib" / "cmake" / "pinocchio").is_dir():
        sys.exit(
            f"run_bench: no Pinocchio CMake config under {prefix}; "
            "pip install .[bench] (pin, cmeel-eigen, cmeel-urdfdom-headers)"
        )
    return prefix


def build(build_dir: Path, cmake: str, werror: bool = False) -> None:
    configure = [
        cmake, "-S", str(BENCH), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
        f"-DCMAKE_PREFIX_PATH={cmeel_prefix()}", f"-DRRR_WERROR={'ON' if werror else 'OFF'}",
    ]
    log("configure: " + " ".join(configure))
    subprocess.run(configure, check=True, stdout=subprocess.DEVNULL)
    log("build (about 20 CPU-s: Pinocchio's algorithms come compiled in libpinocchio_default)")
    _, seconds = timed(lambda: subprocess.run([cmake, "--build", str(build_dir), "-j", "2"],
                                              check=True, stdout=subprocess.DEVNULL))
    log(f"built in {seconds:.0f} s")


def run_core(exe: Path, args: argparse.Namespace) -> list[dict[str, Any]]:
    cmd = [
        str(exe), "--states", str(args.states), "--calls", str(args.calls),
        "--repeats", str(args.repeats), "--ik-tol", repr(args.ik_tol), "--clock", args.clock,
    ]
    log("run: " + " ".join(cmd))
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


# ---------------------------------------------------------------------------------------------
# librrr in C loops (one ctypes call per block) against the Robotics Toolbox, interleaved
# ---------------------------------------------------------------------------------------------
def per_call_block(fn: Callable[[int], object], n: int, clock: Callable[[], int]
                   ) -> Callable[[], float]:
    """A block of Python calls fn(0), ..., fn(n - 1): ns per call."""

    def run() -> float:
        t0 = clock()
        for k in range(n):
            fn(k)
        return (clock() - t0) / n

    return run


def c_loop_block(fn: Callable[[], int], calls: int, what: str, clock: Callable[[], int]
                 ) -> Callable[[], float]:
    """A block of one ctypes call of a C loop of ``calls`` librrr calls: ns per librrr call."""

    def run() -> float:
        t0 = clock()
        failed = fn()
        elapsed = clock() - t0
        if failed != -1:
            sys.exit(f"run_bench: {what} failed on row {failed}")
        return elapsed / calls

    return run


@dataclass
class RtbResults:
    series: dict[str, Series] = field(default_factory=dict)
    checks: dict[str, float] = field(default_factory=dict)
    info: dict[str, str] = field(default_factory=dict)


def load_loops(path: Path) -> tuple[ct.CDLL, Any, Any]:
    """bench_loops (core_loops.c) of the build, with the default model and its inertias read
    from it; the structures are the package's ctypes mirrors, checked by size."""
    from rrr_robot.core import _lib

    loops = ct.CDLL(str(path))
    sizes = [ct.c_size_t() for _ in range(3)]
    loops.loops_sizes(*(ct.byref(v) for v in sizes))
    mirrors = (_lib.RawModel, _lib.RawInertial, _lib.RawIkSet)
    if [v.value for v in sizes] != [ct.sizeof(t) for t in mirrors]:
        sys.exit("run_bench: rrr_model / rrr_inertial / rrr_ik_set of the build differ from the "
                 "package's ctypes mirrors: reinstall the package from this checkout")
    model, inertial = _lib.RawModel(), _lib.RawInertial()
    if loops.loops_defaults(ct.byref(model), ct.byref(inertial)) != 0:
        sys.exit("run_bench: rrr_model_default / rrr_inertial_default failed")
    for name, pointers in (("loops_ik", 3), ("loops_ik_branch", 3),
                           ("loops_inverse_dynamics", 5), ("loops_forward_dynamics", 5)):
        fn = getattr(loops, name)
        fn.argtypes = [ct.c_void_p] * pointers + [ct.c_long, ct.c_long]
        fn.restype = ct.c_long
    return loops, model, inertial


def rtb_side(args: argparse.Namespace, loops_path: Path) -> RtbResults:
    import roboticstoolbox as rtb
    import rrr_robot as rr
    from rrr_robot.core import _lib

    loops, raw, inertial = load_loops(loops_path)
    res = RtbResults()
    model = rr.Model.default()  # the package's binding: the FK checks of the IK results
    links = [
        rtb.RevoluteDH(
            d=(raw.d1, raw.d2, raw.d3)[i], a=(0.0, raw.a2, raw.a3)[i], alpha=ALPHA[i],
            m=inertial.link[i].mass, r=np.array(inertial.link[i].com[:]),
            I=np.array([inertial.link[i].inertia_com[r][:] for r in range(3)]),
            Jm=inertial.rotor_inertia[i], G=1.0, B=0.0, Tc=[0.0, 0.0],
        )
        for i in range(3)
    ]
    robot = rtb.DHRobot(links, gravity=[0.0, 0.0, -raw.g])
    ets = robot.ets()  # prebuilt once: robot.ik_LM would rebuild it on every call

    rng = np.random.default_rng(args.seed)
    n = args.py_states
    q = rng.uniform(-np.pi, np.pi, (n, 3))
    qd = rng.uniform(-3.0, 3.0, (n, 3))
    qdd = rng.uniform(-10.0, 10.0, (n, 3))
    # IK targets: the same distribution as bench_core.cpp (q3 away from 0 and pi)
    q_ik = np.column_stack([
        rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi / 2, np.pi / 2, n),
        rng.uniform(0.2, 2.5, n),
    ])
    x_ik = np.ascontiguousarray(model.fk(q_ik)[0])
    teps = []
    for x in x_ik:
        tep = np.eye(4)
        tep[:3, 3] = x
        teps.append(tep)
    n_acc = min(n, 256)  # accel is slow: its rows use the first n_acc states

    # the C side: whole passes over the same inputs, one ctypes call per block
    passes = max(1, -(-args.c_loop_calls // n))
    passes_acc = max(1, -(-args.c_loop_calls // n_acc))
    ref = ct.addressof(raw)
    tau = np.empty((n, 3))
    acc = np.empty((n_acc, 3))
    q_branch = np.empty((n, 3))
    sols = (_lib.RawIkSet * n)()
    p_sols = ct.addressof(sols)

    def addr(a: FloatArray) -> int:
        return int(a.ctypes.data)

    def c_tau(reps: int) -> int:
        return int(loops.loops_inverse_dynamics(ref, addr(q), addr(qd), addr(qdd), addr(tau),
                                                n, reps))

    def c_fd(reps: int) -> int:
        return int(loops.loops_forward_dynamics(ref, addr(q), addr(qd), addr(tau), addr(acc),
                                                n_acc, reps))

    def c_ik(reps: int) -> int:
        return int(loops.loops_ik(ref, addr(x_ik), p_sols, n, reps))

    def c_branch(reps: int) -> int:
        return int(loops.loops_ik_branch(ref, addr(x_ik), addr(q_branch), n, reps))

    def ik_lm(k: int) -> Any:
        return ets.ik_LM(teps[k], q0=IK_Q0, tol=args.ik_tol, mask=POSITION_MASK,
                         joint_limits=False)

    # agreement of the references with librrr on these inputs
    for what, fn in (("rrr_inverse_dynamics", c_tau), ("rrr_forward_dynamics", c_fd),
                     ("rrr_ik", c_ik), ("rrr_ik_branch", c_branch)):
        if fn(1) != -1:
            sys.exit(f"run_bench: {what} failed in the C loop")
    rne = np.array([robot.rne(q[k], qd[k], qdd[k]) for k in range(n)], dtype=float)
    res.checks["tau_rne"] = float(np.abs(rne - tau).max())
    accel = np.array([robot.accel(q[k], qd[k], tau[k]) for k in range(n_acc)], dtype=float)
    res.checks["fd_accel"] = float(np.abs(accel - qdd[:n_acc]).max())
    res.checks["fd_ours"] = float(np.abs(acc - qdd[:n_acc]).max())
    lm = [ik_lm(k) for k in range(n)]
    ok = [s for s in lm if s.success]
    res.checks["ik_lm_position"] = max(
        (float(np.abs(model.fk(np.asarray(s.q, dtype=float))[0] - x_ik[k]).max())
         for k, s in enumerate(lm) if s.success),
        default=float("nan"),
    )
    res.info["ik_lm"] = (
        f"{len(ok)}/{n} solved, mean {np.mean([s.iterations for s in ok]):.1f} iterations, "
        f"{np.mean([s.searches for s in ok]):.2f} searches"
    )
    ik_back = 0.0
    for k in range(n):
        branches = np.array(sols[k].q[: sols[k].n], dtype=float)
        ik_back = max(ik_back, float(np.abs(model.fk(branches)[0] - x_ik[k]).max()))
    res.checks["ik_ours"] = ik_back
    res.checks["ik_branch"] = float(np.abs(model.fk(q_branch)[0] - x_ik).max())
    res.info["versions"] = f"roboticstoolbox-python {rtb.__version__}, numpy {np.__version__}"
    res.info["loops"] = (f"C loops: {passes * n} calls per block ({passes} passes over {n} "
                         f"inputs; accel: {passes_acc * n_acc} over {n_acc})")

    rep = args.py_repeats
    clk = CLOCKS[args.clock]
    log(f"RTB against librrr in C loops ({n} inputs, {rep} interleaved repeats)")
    ik_ours, branch_ours, ik_ref = interleaved([
        c_loop_block(lambda: c_ik(passes), passes * n, "rrr_ik", clk),
        c_loop_block(lambda: c_branch(passes), passes * n, "rrr_ik_branch", clk),
        per_call_block(ik_lm, n, clk),
    ], rep)
    tau_ours, tau_ref = interleaved([
        c_loop_block(lambda: c_tau(passes), passes * n, "rrr_inverse_dynamics", clk),
        per_call_block(lambda k: robot.rne(q[k], qd[k], qdd[k]), n, clk),
    ], rep)
    fd_ours, fd_ref = interleaved([
        c_loop_block(lambda: c_fd(passes_acc), passes_acc * n_acc, "rrr_forward_dynamics", clk),
        per_call_block(lambda k: robot.accel(q[k], qd[k], tau[k]), n_acc, clk),
    ], rep)
    res.series.update({
        "ik.ours": ik_ours, "ik_branch.ours": branch_ours, "ik.rtb": ik_ref,
        "tau.ours": tau_ours, "tau.rtb": tau_ref, "fd.ours": fd_ours, "fd.rtb": fd_ref,
    })
    return res


# ---------------------------------------------------------------------------------------------
# Operation counts
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Ops:
    """Hand count of one source statement: + - (add), * (mul), / (div), unary minus (neg),
    sqrt, atan2 calls; ``other`` lists non-flop calls (fabs, fmax) of the statement."""

    snippet: str
    add: int = 0
    mul: int = 0
    div: int = 0
    neg: int = 0
    sqrt: int = 0
    atan2: int = 0
    other: str = ""

    @property
    def flops(self) -> int:
        return self.add + self.mul + self.div + self.neg + self.sqrt


# ik_geometry(): once per target (shared by the branches).
IK_GEOMETRY = (
    Ops("e = m->d2 + m->d3", add=1),
    Ops("L = a2 + a3 + fabs(e)", add=2, other="fabs"),
    Ops("rho2 = x[0] * x[0] + x[1] * x[1] - e * e", add=2, mul=3),
    Ops("pwv = x[2] - m->d1", add=1),
    Ops("c3 = (rho2 + pwv * pwv - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)", add=3, mul=5, div=1),
    Ops("fabs(c3) > 1.0", other="fabs"),
    Ops("g->rabs = sqrt(rho2)", sqrt=1),
    Ops("g->s3abs = sqrt(fmax(0.0, 1.0 - c3 * c3))", add=1, mul=1, sqrt=1, other="fmax"),
    Ops("g->psi = atan2(x[1], x[0])", atan2=1),
    Ops("g->gamma_f = atan2(e, g->rabs)", atan2=1),
    Ops("g->gamma_b = copysign(RRR_PI, e) - g->gamma_f", add=1, other="copysign"),
    Ops("g->phi_f = atan2(pwv, g->rabs)", atan2=1),
    Ops("g->phi_b = copysign(RRR_PI, pwv) - g->phi_f", add=1, other="copysign"),
    Ops("g->beta_down = atan2(a3 * g->s3abs, a2 + a3 * c3)", add=1, mul=1, atan2=1),
    Ops("g->q3_down = atan2(g->s3abs, c3)", atan2=1),
)
# ik_solve_branch(): once per branch. The sign flips of the elbow-up branch (beta, q3) are
# counted per branch where they happen, in ik_count(); wrap_pi() counts as one add (worst case)
# for q1 and q2.
IK_BRANCH = (
    Ops("q[0] = wrap_pi(g->psi + (front ? g->gamma_f : g->gamma_b))", add=2),
    Ops("q[1] = wrap_pi((front ? g->phi_f : g->phi_b) - (down ? g->beta_down : -g->beta_down))",
        add=2),
    Ops("q[2] = wrap_pi(down ? g->q3_down : -g->q3_down)"),
)


@dataclass(frozen=True)
class IkCount:
    flops: int
    sqrt: int
    atan2: int
    detail: str
    stale: list[str]


def ik_count(branches: Sequence[tuple[bool, bool]]) -> IkCount:
    """Flops of the IK code path for the given (back shoulder, elbow up) branches."""
    src = re.sub(r"\s+", " ", KIN_SOURCE.read_text(encoding="utf-8"))
    stale = [op.snippet for op in (*IK_GEOMETRY, *IK_BRANCH) if op.snippet not in src]
    add = sum(op.add for op in IK_GEOMETRY) + len(branches) * sum(op.add for op in IK_BRANCH)
    mul = sum(op.mul for op in IK_GEOMETRY) + len(branches) * sum(op.mul for op in IK_BRANCH)
    div = sum(op.div for op in IK_GEOMETRY) + len(branches) * sum(op.div for op in IK_BRANCH)
    neg = sum(2 * int(up) for _back, up in branches)
    sqrt = sum(op.sqrt for op in IK_GEOMETRY)
    atan2 = sum(op.atan2 for op in IK_GEOMETRY) + len(branches) * sum(op.atan2 for op in IK_BRANCH)
    flops = add + mul + div + neg + sqrt
    detail = f"{add} add/sub, {mul} mul, {div} div, {neg} neg, {sqrt} sqrt; + {atan2} atan2"
    return IkCount(flops, sqrt, atan2, detail, stale)


@dataclass(frozen=True)
class GenCount:
    ops: dict[str, int]
    detail: dict[str, str]
    matches_source: bool


def dynamics_count() -> GenCount:
    """Run the generator into a temporary directory and parse its 'operations after CSE'."""
    with tempfile.TemporaryDirectory() as tmp:
        log("derive_dynamics.py (SymPy, a few seconds)")
        out = subprocess.run(
            [sys.executable, str(GEN_SCRIPT), "--output-dir", tmp, "--firmware-dir", tmp],
            check=True, capture_output=True, text=True,
        ).stdout
        same = all(
            (Path(tmp) / name).read_bytes() == (GEN_DIR / name).read_bytes()
            for name in ("rrr_dynamics_gen.c", "rrr_dynamics_gen.h")
        )
    ops: dict[str, int] = {}
    detail: dict[str, str] = {}
    for m in re.finditer(r"^\s+(rrr_gen_\w+)\s+(\d+)\s+(.*)$", out, flags=re.MULTILINE):
        ops[m.group(1)] = int(m.group(2))
        detail[m.group(1)] = m.group(3).strip()
    if not ops:
        sys.exit("run_bench: could not parse the operation counts of derive_dynamics.py")
    return GenCount(ops, detail, same)


# rrr_trig_of(): sin, cos of q2 and q3, then s23 = s2 c3 + c2 s3, c23 = c2 c3 - s2 s3
TRIG_PROLOGUE_OPS = 6
TRIG_PROLOGUE_CALLS = 4


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------
def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def load_average() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def fmt_ns(ns: float) -> str:
    return f"{ns:,.0f}" if ns >= 100 else f"{ns:.1f}"


def fmt_ratio(r: float) -> str:
    return f"{r:,.1f}x" if r < 100 else f"{r:,.0f}x"


def fmt_diff(value: float | None) -> str:
    return "" if value is None else f"{value:.1e}"


def core_series(core: list[dict[str, Any]]) -> dict[str, Series]:
    """The driver's groups: every operation's ns per repeat, keyed '<group>:<op id>'."""
    out: dict[str, Series] = {}
    for g in core:
        if g["kind"] == "group":
            for op in g["ops"]:
                out[f"{g['id']}:{op['id']}"] = Series(tuple(float(v) for v in op["values"]))
    return out


@dataclass(frozen=True)
class Row:
    """One ratio: ours and the reference timed in the same interleaved repeats."""

    operation: str
    ours: str
    ours_ns: Series
    ref: str
    ref_ns: Series
    diff: str
    target: float | None = None

    @property
    def ratio(self) -> Series:
        return self.ref_ns.over(self.ours_ns)

    def verdict(self) -> str:
        if self.target is None:
            return ""
        r = self.ratio
        if r.min >= self.target:
            verdict = "met (every repeat)"
        elif r.median >= self.target:
            verdict = f"met (median; min {fmt_ratio(r.min)})"
        else:
            verdict = "NOT met"
        return f">= {self.target:g}x: {verdict}"


def render_rows(rows: Sequence[Row]) -> list[str]:
    out = [
        "| operation | ours | ours (ns) | reference | reference (ns) | ratio ref/ours "
        "| agreement (max abs diff) | target |",
        "|---|---|---:|---|---:|---:|---|---|",
    ]
    for r in rows:
        out.append(
            f"| {r.operation} | {r.ours} | {r.ours_ns.format(fmt_ns)} | {r.ref} "
            f"| {r.ref_ns.format(fmt_ns)} | {r.ratio.format(fmt_ratio)} | {r.diff} "
            f"| {r.verdict()} |"
        )
    return out


def report(
    args: argparse.Namespace, core: list[dict[str, Any]], py: RtbResults, gen: GenCount,
    load: tuple[str, str],
) -> tuple[str, dict[str, dict[str, float]]]:
    meta = next(r for r in core if r["kind"] == "meta")
    t = core_series(core)
    groups = {r["id"]: r for r in core if r["kind"] == "group"}
    chk = {r["id"]: float(r["max_abs_diff"]) for r in core if r["kind"] == "check"}
    info = {r["id"]: r for r in core if r["kind"] == "info"}
    lm = info["ik.pin_lm"]
    lm_txt = (f"{lm['success']}/{lm['targets']} solved, "
              f"mean {lm['mean_iterations']:.1f} iterations")
    p = py.series

    def c(*ids: str) -> str:
        return fmt_diff(max(chk[i] for i in ids))

    ik_diff = f"FK(IK(x)) - x: {c('ik_fk')}"
    rows_c = [
        Row("FK (position + orientation)", "`rrr_fk`", t["fk:fk.ours"],
            "Pinocchio `forwardKinematics` + tip placement", t["fk:fk.pin"],
            c("fk_position", "fk_rotation")),
        Row("IK, all branches (4 solutions)", "`rrr_ik`", t["ik:ik.ours"],
            "the LM of `ets.ik_LM` on Pinocchio kinematics (C++, this bench; 1 solution)",
            t["ik:ik.pin_lm"], f"{ik_diff}; LM: {fmt_diff(lm['max_position_error'])}"),
        Row("IK, one branch (1 solution each)", "`rrr_ik_branch`", t["ik:ik_branch.ours"],
            "the same LM (C++)", t["ik:ik.pin_lm"], "a branch of `rrr_ik`"),
        Row("tau = R p (inverse dynamics)", "`rrr_inverse_dynamics`", t["tau:tau.ours"],
            "Pinocchio `rnea`", t["tau:tau.pin"], c("tau"), TARGET_TAU_VS_RNEA),
        Row("regressor R (3 x 16)", "`rrr_regressor`", t["regressor:regressor.ours"],
            "Pinocchio `computeJointTorqueRegressor` (3 x 30)", t["regressor:regressor.pin"],
            f"R p vs rnea: {c('regressor')}"),
        Row("D(q)", "`rrr_mass_matrix`", t["mass:mass.ours"],
            "Pinocchio `crba` (upper triangle)", t["mass:mass.pin"], c("mass")),
        Row("c(q, qd)", "`rrr_coriolis`", t["nle:coriolis.ours"],
            "Pinocchio `nonLinearEffects` (c + h)", t["nle:nle.pin"],
            f"vs nle - g: {c('coriolis')}"),
        Row("h(q)", "`rrr_gravity`", t["gravity:gravity.ours"],
            "Pinocchio `computeGeneralizedGravity`", t["gravity:gravity.pin"], c("gravity")),
        Row("c + h", "`rrr_inverse_dynamics`, qdd = 0", t["nle:nle.ours"],
            "Pinocchio `nonLinearEffects`", t["nle:nle.pin"], c("nle")),
        Row("forward dynamics", "`rrr_forward_dynamics`", t["fd:fd.ours"],
            "Pinocchio `aba`", t["fd:fd.pin"], c("fd")),
    ]
    ik_lm_diff = (f"FK(IK(x)) - x: {fmt_diff(py.checks['ik_ours'])}; "
                  f"LM: {fmt_diff(py.checks['ik_lm_position'])}")
    rows_rtb = [
        Row("IK, all branches (4 solutions)", "`rrr_ik`", p["ik.ours"],
            "RTB `ets.ik_LM` (1 solution; Python -> C++)", p["ik.rtb"], ik_lm_diff,
            TARGET_IK_VS_LM),
        Row("IK, one branch (1 solution each)", "`rrr_ik_branch`", p["ik_branch.ours"],
            "RTB `ets.ik_LM` (Python -> C++)", p["ik.rtb"],
            f"FK(q) - x: {fmt_diff(py.checks['ik_branch'])}", TARGET_IK_VS_LM),
        Row("tau = R p (inverse dynamics)", "`rrr_inverse_dynamics`", p["tau.ours"],
            "RTB `rne` (Python -> C)", p["tau.rtb"], fmt_diff(py.checks["tau_rne"])),
        Row("forward dynamics", "`rrr_forward_dynamics`", p["fd.ours"],
            "RTB `accel` (Python)", p["fd.rtb"],
            f"{fmt_diff(py.checks['fd_accel'])} (ours: {fmt_diff(py.checks['fd_ours'])})"),
    ]

    diag = groups["diagnostics"]["ops"]
    d = {op["id"]: Series(tuple(op["values"])) for op in diag}
    ik_all = ik_count([(back, up) for back in (False, True) for up in (True, False)])
    ik_one = ik_count([(False, True)])
    tau_ops = gen.ops["rrr_gen_inverse_dynamics"] + TRIG_PROLOGUE_OPS
    lines: list[str] = []
    add = lines.append
    add("# librrr benchmark")
    add("")
    add(f"- date: {dt.datetime.now().astimezone().isoformat(timespec='seconds')}")
    add(f"- machine: {cpu_model()}, nproc {os.cpu_count()} "
        f"(usable {len(os.sched_getaffinity(0))}), {platform.system()} {platform.release()}; "
        f"load average {load[0]} (start) / {load[1]} (end)")
    add(f"- C (librrr): {meta['c']}; C++ (driver + Pinocchio headers): {meta['cxx']}; "
        "no -march=native (the prebuilt libpinocchio crashes with it)")
    add(f"- Pinocchio {meta['pinocchio']} (prebuilt libpinocchio_default from the pin wheel), "
        f"Eigen {meta['eigen']}, {py.info['versions']}, Python {platform.python_version()}")
    calls = groups["tau"]["ops"][0]["calls"]
    lm_calls = groups["ik"]["ops"][2]["calls"]
    clock = ("the CPU time of the thread (time spent waiting for a core is left out)"
             if meta.get("clock", "cpu") == "cpu" else "the wall clock")
    add(f"- interleaved: {meta['repeats']} repeats (RTB rows: {args.py_repeats}); each repeat "
        "times one block of ours and one of the reference back to back (order reversed every "
        "other repeat) on the same inputs; every cell is min / median / max over the repeats, "
        f"the ratio is taken per repeat; blocks timed by {clock}")
    add(f"- C/C++ rows: {meta['states']} random states (q in [-pi, pi], qd in [-3, 3], "
        f"qdd in [-10, 10]), the same for ours and Pinocchio; blocks of {calls} calls "
        f"(the C++ LM: {lm_calls}), ns/call (throughput loop; empty loop "
        f"{d['loop.empty'].format(fmt_ns)} ns, not subtracted)")
    add(f"- libm floor in the same driver: sin + cos of q2 and q3 as in rrr_trig_of "
        f"(two sincos calls) {d['floor.trig'].format(fmt_ns)} ns, one atan2 "
        f"{d['floor.atan2'].format(fmt_ns)} ns (`rrr_ik` calls atan2 {ik_all.atan2} times, "
        f"`rrr_ik_branch` {ik_one.atan2} times)")
    if "kernel.tau" in d:
        add(f"- diagnostic: the tau kernel alone (rrr_trig_of + generated code, no argument "
            f"checks, called from the driver) {d['kernel.tau'].format(fmt_ns)} ns against "
            f"{d['tau.ours'].format(fmt_ns)} ns of `rrr_inverse_dynamics` in the same repeats")
    add(f"- RTB rows: {args.py_states} inputs (accel: {min(args.py_states, 256)}); "
        "the reference block is one Python call per "
        f"input, ours one ctypes call of a C loop over the same inputs ({py.info['loops']}, "
        "bench/core_loops.c, the same librrr), so ours is the C call alone")
    add(f"- IK: position only (mask [1,1,1,0,0,0]), targets from q1 in [-pi, pi], "
        f"q2 in [-pi/2, pi/2], q3 in [0.2, 2.5]; LM solvers: q0 = (0.1, 0.2, 1.0), "
        f"tol = {args.ik_tol:g} on E = |e|^2/2, ilimit 30, slimit 100, joint_limits off. "
        f"RTB: {py.info['ik_lm']}; C++ LM: {lm_txt}. "
        f"Ours returns all {info['ik.ours']['mean_solutions']:.0f} branches per target.")
    add("- ratio = reference time / our time (> 1: ours is faster). "
        "Noisy shared VM: compare ratios, not absolute times. The Python API (`rrr_robot`) "
        "against the references' Python APIs: bench/bench_python.py.")
    add("")
    add("## Compiled: librrr (C) vs Pinocchio (C++)")
    add("")
    lines.extend(render_rows(rows_c))
    add("")
    add("## librrr (C) vs the Robotics Toolbox (Python)")
    add("")
    lines.extend(render_rows(rows_rtb))
    add("")
    add("## Operation counts vs the paper")
    add("")
    add("| computation | ours | paper | how counted |")
    add("|---|---|---:|---|")
    add(f"| IK, all 4 branches (`rrr_ik`) | {ik_all.flops} flops + {ik_all.atan2} atan2 "
        f"({ik_all.detail}) | {PAPER_IK_FLOPS} | hand count of rrr_kinematics.c (below) |")
    add(f"| IK, one branch (`rrr_ik_branch`) | {ik_one.flops} flops + {ik_one.atan2} atan2 "
        f"({ik_one.detail}) | {PAPER_IK_FLOPS} | hand count of rrr_kinematics.c |")
    add(f"| tau = R p (`rrr_inverse_dynamics`) | {tau_ops} ops + {TRIG_PROLOGUE_CALLS} sin/cos "
        f"({gen.ops['rrr_gen_inverse_dynamics']} generated + {TRIG_PROLOGUE_OPS} for s23, c23) "
        f"| {PAPER_DYN_FLOPS} | SymPy count_ops after CSE |")
    for name, label in (
        ("rrr_gen_regressor", "regressor R"),
        ("rrr_gen_bias", "c + h, the plant's forward dynamics"),
        ("rrr_gen_mass_matrix", "D(q)"),
        ("rrr_gen_coriolis", "c(q, qd)"),
        ("rrr_gen_gravity", "h(q)"),
    ):
        if name in gen.ops:
            add(f"| {label} (`{name}`) | {gen.ops[name] + TRIG_PROLOGUE_OPS} ops + "
                f"{TRIG_PROLOGUE_CALLS} sin/cos ({gen.ops[name]} generated: "
                f"{gen.detail[name]}) | | SymPy count_ops after CSE |")
    add("")
    add("- Generated dynamics: `derive_dynamics.py --output-dir <tmp>`, its \"operations after "
        "CSE\" (SymPy `count_ops`: each binary +, -, *, / and unary minus is 1, x**2 is 1 "
        "multiplication). Regenerated code identical to the compiled c_src/rrr/src/"
        f"rrr_dynamics_gen.[ch]: {'yes' if gen.matches_source else 'NO (counts may be stale)'}. "
        f"Every public call adds rrr_trig_of: {TRIG_PROLOGUE_CALLS} libm calls (sin, cos of q2, "
        f"q3) and {TRIG_PROLOGUE_OPS} flops (s23, c23).")
    add("- IK: statement by statement from c_src/rrr/src/rrr_kinematics.c as written "
        "(ik_geometry once, ik_solve_branch per branch; add/sub, mul, div, unary minus and sqrt "
        "are 1 flop each, atan2 is listed apart, fabs/fmax/comparisons and input validation "
        "are not counted; e = d2 + d3 is counted where it is written, although the compiler "
        "may hoist it). Statements not found in the source: "
        + (", ".join(f"`{s}`" for s in ik_all.stale) if ik_all.stale else "none")
        + ".")
    add("")
    key_rows = {
        "tau_vs_rnea": rows_c[3],
        "ik_vs_cpp_lm": rows_c[1],
        "fd_vs_aba": rows_c[9],
        "mass_vs_crba": rows_c[5],
        "ik_vs_ik_lm": rows_rtb[0],
        "ik_branch_vs_ik_lm": rows_rtb[1],
        "tau_vs_rne": rows_rtb[2],
        "fd_vs_accel": rows_rtb[3],
    }
    key = {name: {"min": r.ratio.min, "median": r.ratio.median, "max": r.ratio.max}
           for name, r in key_rows.items()}
    add(f"Key ratios (min / median / max): tau = R p vs rnea "
        f"{key_rows['tau_vs_rnea'].ratio.format(fmt_ratio)} "
        f"({key_rows['tau_vs_rnea'].verdict()}); "
        f"IK (C, all branches) vs ets.ik_LM {key_rows['ik_vs_ik_lm'].ratio.format(fmt_ratio)} "
        f"({key_rows['ik_vs_ik_lm'].verdict()}), one branch "
        f"{key_rows['ik_branch_vs_ik_lm'].ratio.format(fmt_ratio)}.")
    return "\n".join(lines), key


#: --quick: every part on a few inputs (the build and the generator run in full)
QUICK = {"states": 64, "calls": 640, "repeats": 3, "py_states": 16, "py_repeats": 3,
         "c_loop_calls": 64}


# ---------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build-dir", type=Path, default=BENCH / "build",
                        help="CMake build directory of the C++ driver (default: %(default)s)")
    parser.add_argument("--cmake", default=shutil.which("cmake") or "cmake")
    parser.add_argument("--skip-build", action="store_true", help="reuse an existing build")
    parser.add_argument("--build-only", action="store_true",
                        help="configure and build, then stop (the test command builds in the "
                        "background and runs --quick --skip-build later)")
    parser.add_argument("--states", type=int, default=1024, help="C++ states (power of 2)")
    parser.add_argument("--calls", type=int, default=20_480,
                        help="C++ calls per block, rounded up to whole passes over the states "
                             "(the C++ LM: 1/20 of it); default %(default)s")
    parser.add_argument("--repeats", type=int, default=31,
                        help="C++ interleaved repeats (blocks of each operation)")
    parser.add_argument("--py-states", type=int, default=512, help="RTB inputs (accel: 256)")
    parser.add_argument("--py-repeats", type=int, default=21, help="RTB interleaved repeats")
    parser.add_argument("--c-loop-calls", type=int, default=20_480,
                        help="librrr calls per C-loop block against RTB, rounded up to whole "
                             "passes over the inputs; default %(default)s")
    parser.add_argument("--ik-tol", type=float, default=1e-12,
                        help="LM tolerance on E = |e|^2/2 (RTB's tol), default %(default)g")
    parser.add_argument("--seed", type=int, default=1, help="seed of the RTB-side inputs")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu",
                        help="time blocks by the CPU time of the thread (default: the time spent "
                             "waiting for a core on a loaded machine is left out) or the wall "
                             "clock")
    parser.add_argument("--json", type=Path, help="also write the raw results to this file")
    parser.add_argument("--werror", action="store_true",
                        help="build with warnings as errors (RRR_WERROR; the test command)")
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(argv), QUICK)
    for name in ("states", "calls", "repeats", "py_states", "py_repeats", "c_loop_calls"):
        if getattr(args, name) <= 0:
            parser.error(f"--{name.replace('_', '-')} must be positive")

    load_start = load_average()
    build_dir = args.build_dir.resolve()
    if not args.skip_build:
        build(build_dir, args.cmake, args.werror)
    if args.build_only:
        return 0
    exe = build_dir / "bench_core"
    loops = build_dir / "libbench_loops.so"
    if not exe.is_file() or not loops.is_file():
        sys.exit(f"run_bench: {exe} or {loops} missing: run without --skip-build")

    core = run_core(exe, args)
    rtb_results = rtb_side(args, loops)
    gen = dynamics_count()
    load_end = load_average()
    text, key = report(args, core, rtb_results, gen, (load_start, load_end))
    print(text)
    if args.json:
        args.json.write_text(
            json.dumps({"load": [load_start, load_end], "core": core,
                        "rtb": {k: list(s.values) for k, s in rtb_results.series.items()},
                        "rtb_checks": rtb_results.checks, "rtb_info": rtb_results.info,
                        "ops": gen.ops, "key_ratios": key}, indent=1),
            encoding="utf-8",
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
