#!/usr/bin/env python3
"""Benchmark the closed-form core librrr against Pinocchio (C++) and the Robotics Toolbox.

One command, one run: builds the C++ driver bench/bench_core.cpp with CMake (librrr from
c_src/rrr with the repository's own CMakeLists, Pinocchio from the ``pin`` wheel), runs it, times
the Robotics Toolbox for Python (``rne``, ``ets.ik_LM`` on a prebuilt ETS, ``ets.eval``,
``accel``), our Python API (the installed package's compiled binding) and bare ctypes calls of
the build's librrr.so in the same process, counts the operations of our generated dynamics
(c_src/rrr/gen/derive_dynamics.py) and of our IK (a hand count of c_src/rrr/src/rrr_kinematics.c,
checked against the source text), and prints markdown tables.

This is a measurement, not a test: nothing fails when a target is missed.

Usage:
    python bench/run_bench.py [--build-dir DIR] [--calls N] [--repeats N] [--states N]
                              [--py-repeats N] [--ik-tol E] [--skip-build] [--json FILE]
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
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

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


def log(msg: str) -> None:
    print(f"[run_bench] {msg}", file=sys.stderr, flush=True)


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


def build(build_dir: Path, cmake: str) -> None:
    configure = [
        cmake, "-S", str(BENCH), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
        f"-DCMAKE_PREFIX_PATH={cmeel_prefix()}",
    ]
    log("configure: " + " ".join(configure))
    subprocess.run(configure, check=True, stdout=subprocess.DEVNULL)
    log("build (one Pinocchio translation unit: about 1.5-3 min on 2 cores)")
    t0 = time.perf_counter()
    subprocess.run([cmake, "--build", str(build_dir), "-j", "2"], check=True,
                   stdout=subprocess.DEVNULL)
    log(f"built in {time.perf_counter() - t0:.0f} s")


def run_core(exe: Path, args: argparse.Namespace) -> list[dict[str, Any]]:
    cmd = [
        str(exe), "--states", str(args.states), "--calls", str(args.calls),
        "--repeats", str(args.repeats), "--ik-tol", repr(args.ik_tol),
    ]
    log("run: " + " ".join(cmd))
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


# ---------------------------------------------------------------------------------------------
# Python-side timings: RTB, our Python API (the compiled binding) and bare ctypes calls
# ---------------------------------------------------------------------------------------------
def best_ns(fn: Callable[[int], object], n: int, repeats: int) -> float:
    """Best over repeats of (time of fn(0..n-1)) / n, in ns per call."""
    for k in range(min(n, 50)):  # warm-up
        fn(k)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for k in range(n):
            fn(k)
        best = min(best, (time.perf_counter_ns() - t0) / n)
    return best


@dataclass
class PyResults:
    times: dict[str, float] = field(default_factory=dict)
    checks: dict[str, float] = field(default_factory=dict)
    info: dict[str, str] = field(default_factory=dict)


def default_inertial(lib: ct.CDLL, raw_type: type[ct.Structure]) -> Any:
    raw = raw_type()
    status = lib.rrr_inertial_default(ct.byref(raw))
    if status != 0:
        sys.exit(f"run_bench: rrr_inertial_default returned {status}")
    return raw


def python_side(args: argparse.Namespace) -> PyResults:
    import roboticstoolbox as rtb
    import rrr_robot as rr
    from rrr_robot.core import _lib
    from rrr_robot.core._arrays import ptr

    res = PyResults()
    model = rr.Model.default()
    raw = default_inertial(_lib.LIB, _lib.RawInertial)
    dh = model.dh
    a = (0.0, dh["a2"], dh["a3"])
    d = (dh["d1"], dh["d2"], dh["d3"])
    links = [
        rtb.RevoluteDH(
            d=d[i], a=a[i], alpha=ALPHA[i], m=raw.link[i].mass,
            r=np.array(raw.link[i].com[:]),
            I=np.array([raw.link[i].inertia_com[r][:] for r in range(3)]),
            Jm=raw.rotor_inertia[i], G=1.0, B=0.0, Tc=[0.0, 0.0],
        )
        for i in range(3)
    ]
    robot = rtb.DHRobot(links, gravity=[0.0, 0.0, -model.g])
    ets = robot.ets()  # prebuilt once: robot.ik_LM would rebuild it on every call

    rng = np.random.default_rng(args.seed)
    n = args.py_states
    q = rng.uniform(-np.pi, np.pi, (n, 3))
    qd = rng.uniform(-3.0, 3.0, (n, 3))
    qdd = rng.uniform(-10.0, 10.0, (n, 3))
    tau = model.inverse_dynamics(q, qd, qdd)
    # IK targets: the same distribution as bench_core.cpp (q3 away from 0 and pi)
    q_ik = np.column_stack([
        rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi / 2, np.pi / 2, n),
        rng.uniform(0.2, 2.5, n),
    ])
    x_ik, _ = model.fk(q_ik)
    teps = []
    for x in x_ik:
        tep = np.eye(4)
        tep[:3, 3] = x
        teps.append(tep)
    rep = args.py_repeats

    # agreement of the references with our model on these states
    rne = np.array([robot.rne(q[k], qd[k], qdd[k]) for k in range(n)], dtype=float)
    res.checks["tau_rne"] = float(np.abs(rne - tau).max())
    n_acc = min(n, 256)
    acc = np.array([robot.accel(q[k], qd[k], tau[k]) for k in range(n_acc)], dtype=float)
    res.checks["fd_accel"] = float(np.abs(acc - qdd[:n_acc]).max())
    fk_rtb = np.array([ets.eval(q[k])[:3, 3] for k in range(n)])
    res.checks["fk_eval"] = float(np.abs(fk_rtb - model.fk(q)[0]).max())
    sols = [
        ets.ik_LM(teps[k], q0=IK_Q0, tol=args.ik_tol, mask=POSITION_MASK, joint_limits=False)
        for k in range(n)
    ]
    ok = [s for s in sols if s.success]
    err = max(
        (float(np.abs(model.fk(np.asarray(s.q, dtype=float))[0] - x_ik[k]).max())
         for k, s in enumerate(sols) if s.success),
        default=float("nan"),
    )
    res.checks["ik_lm_position"] = err
    res.info["ik_lm"] = (
        f"{len(ok)}/{n} solved, mean {np.mean([s.iterations for s in ok]):.1f} iterations, "
        f"{np.mean([s.searches for s in ok]):.2f} searches"
    )
    ik_err = max(float(np.abs(model.fk(model.ik(x))[0] - x).max()) for x in x_ik)
    res.checks["ik_ours_py"] = ik_err

    log(f"Python timings ({n} states, best of {rep})")
    res.times["rtb.rne"] = best_ns(lambda k: robot.rne(q[k], qd[k], qdd[k]), n, rep)
    res.times["rtb.ik_lm"] = best_ns(
        lambda k: ets.ik_LM(teps[k], q0=IK_Q0, tol=args.ik_tol, mask=POSITION_MASK,
                            joint_limits=False), n, rep)
    res.times["rtb.eval"] = best_ns(lambda k: ets.eval(q[k]), n, rep)
    res.times["rtb.accel"] = best_ns(lambda k: robot.accel(q[k], qd[k], tau[k]), n_acc, rep)
    res.times["py.fk"] = best_ns(lambda k: model.fk(q[k]), n, rep)
    res.times["py.ik"] = best_ns(lambda k: model.ik(x_ik[k]), n, rep)
    res.times["py.tau"] = best_ns(lambda k: model.inverse_dynamics(q[k], qd[k], qdd[k]), n, rep)
    res.times["py.fd"] = best_ns(lambda k: model.forward_dynamics(q[k], qd[k], tau[k]), n, rep)
    # the same C calls through bare ctypes with every pointer prebuilt: the binding's floor
    lib = _lib.LIB
    ref = ct.byref(model.raw)
    out = np.zeros(3)
    p_out = ptr(out)
    p_q = [ptr(row) for row in q]
    p_qd = [ptr(row) for row in qd]
    p_qdd = [ptr(row) for row in qdd]
    x_rows = np.ascontiguousarray(x_ik)
    p_x = [ptr(row) for row in x_rows]
    sol = _lib.RawIkSet()
    p_sol = ct.byref(sol)
    inv_dyn = lib.rrr_inverse_dynamics
    ik = lib.rrr_ik
    res.times["raw.tau"] = best_ns(lambda k: inv_dyn(ref, p_q[k], p_qd[k], p_qdd[k], p_out), n, rep)
    res.times["raw.ik"] = best_ns(lambda k: ik(ref, p_x[k], p_sol), n, rep)
    raw_diff = 0.0
    for k in range(n):
        if inv_dyn(ref, p_q[k], p_qd[k], p_qdd[k], p_out) != 0:
            sys.exit("run_bench: rrr_inverse_dynamics failed through ctypes")
        raw_diff = max(raw_diff, float(np.abs(out - tau[k]).max()))
    res.checks["raw_tau"] = raw_diff
    res.info["versions"] = f"roboticstoolbox-python {rtb.__version__}, numpy {np.__version__}"
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
            [sys.executable, str(GEN_SCRIPT), "--output-dir", tmp],
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


def fmt_diff(value: float | None) -> str:
    return "" if value is None else f"{value:.1e}"


@dataclass(frozen=True)
class Row:
    operation: str
    ours: str
    ours_ns: float
    ref: str
    ref_ns: float
    diff: str
    target: float | None = None

    @property
    def ratio(self) -> float:
        return self.ref_ns / self.ours_ns


def render_rows(rows: Sequence[Row]) -> list[str]:
    out = [
        "| operation | ours | ours (ns) | reference | reference (ns) | ratio ref/ours "
        "| agreement (max abs diff) | target |",
        "|---|---|---:|---|---:|---:|---|---|",
    ]
    for r in rows:
        target = ""
        if r.target is not None:
            verdict = "met" if r.ratio >= r.target else "MISSED"
            target = f">= {r.target:g}x: {verdict}"
        out.append(
            f"| {r.operation} | {r.ours} | {fmt_ns(r.ours_ns)} | {r.ref} | {fmt_ns(r.ref_ns)} "
            f"| {r.ratio:,.1f}x | {r.diff} | {target} |"
        )
    return out


def report(
    args: argparse.Namespace, core: list[dict[str, Any]], py: PyResults, gen: GenCount,
    load: tuple[str, str],
) -> tuple[str, dict[str, float]]:
    meta = next(r for r in core if r["kind"] == "meta")
    t = {r["id"]: float(r["ns"]) for r in core if r["kind"] == "time"}
    chk = {r["id"]: float(r["max_abs_diff"]) for r in core if r["kind"] == "check"}
    info = {r["id"]: r for r in core if r["kind"] == "info"}
    lm = info["ik.pin_lm"]
    lm_txt = (f"{lm['success']}/{lm['targets']} solved, "
              f"mean {lm['mean_iterations']:.1f} iterations")

    def c(*ids: str) -> str:
        return fmt_diff(max(chk[i] for i in ids))

    ik_diff = f"FK(IK(x)) - x: {c('ik_fk')}"
    rows_c = [
        Row("FK (position + orientation)", "`rrr_fk`", t["fk.ours"],
            "Pinocchio `forwardKinematics` + tip placement", t["fk.pin"],
            c("fk_position", "fk_rotation")),
        Row("IK, all branches (4 solutions)", "`rrr_ik`", t["ik.ours"],
            "RTB `ets.ik_LM` (1 solution; Python -> C++)", py.times["rtb.ik_lm"],
            f"{ik_diff}; LM: {fmt_diff(py.checks['ik_lm_position'])}", TARGET_IK_VS_LM),
        Row("IK, all branches (4 solutions)", "`rrr_ik`", t["ik.ours"],
            "same LM on Pinocchio kinematics (C++, this bench)", t["ik.pin_lm"],
            f"{ik_diff}; LM: {fmt_diff(lm['max_position_error'])}"),
        Row("IK, one branch (1 solution each)", "`rrr_ik_branch`", t["ik_branch.ours"],
            "RTB `ets.ik_LM` (Python -> C++)", py.times["rtb.ik_lm"], "a branch of `rrr_ik`",
            TARGET_IK_VS_LM),
        Row("tau = R p (inverse dynamics)", "`rrr_inverse_dynamics`", t["tau.ours"],
            "Pinocchio `rnea`", t["tau.pin"], c("tau"), TARGET_TAU_VS_RNEA),
        Row("tau = R p (inverse dynamics)", "`rrr_inverse_dynamics`", t["tau.ours"],
            "RTB `rne` (Python -> C)", py.times["rtb.rne"], fmt_diff(py.checks["tau_rne"])),
        Row("regressor R (3 x 16)", "`rrr_regressor`", t["regressor.ours"],
            "Pinocchio `computeJointTorqueRegressor` (3 x 30)", t["regressor.pin"],
            f"R p vs rnea: {c('regressor')}"),
        Row("D(q)", "`rrr_mass_matrix`", t["mass.ours"],
            "Pinocchio `crba` (upper triangle)", t["mass.pin"], c("mass")),
        Row("c(q, qd)", "`rrr_coriolis`", t["coriolis.ours"],
            "Pinocchio `nonLinearEffects` (c + h)", t["nle.pin"], f"vs nle - g: {c('coriolis')}"),
        Row("h(q)", "`rrr_gravity`", t["gravity.ours"],
            "Pinocchio `computeGeneralizedGravity`", t["gravity.pin"], c("gravity")),
        Row("c + h", "`rrr_inverse_dynamics`, qdd = 0", t["nle.ours"],
            "Pinocchio `nonLinearEffects`", t["nle.pin"], c("nle")),
        Row("forward dynamics", "`rrr_forward_dynamics`", t["fd.ours"],
            "Pinocchio `aba`", t["fd.pin"], c("fd")),
        Row("forward dynamics", "`rrr_forward_dynamics`", t["fd.ours"],
            "RTB `accel` (Python)", py.times["rtb.accel"], fmt_diff(py.checks["fd_accel"])),
    ]
    rows_py = [
        Row("FK", "`Model.fk`", py.times["py.fk"], "RTB `ets.eval`", py.times["rtb.eval"],
            fmt_diff(py.checks["fk_eval"])),
        Row("IK, all branches", "`Model.ik`", py.times["py.ik"], "RTB `ets.ik_LM`",
            py.times["rtb.ik_lm"], f"FK(IK(x)) - x: {fmt_diff(py.checks['ik_ours_py'])}"),
        Row("IK, all branches", "bare ctypes `rrr_ik`, pointers prebuilt", py.times["raw.ik"],
            "RTB `ets.ik_LM`", py.times["rtb.ik_lm"], ""),
        Row("tau = R p", "`Model.inverse_dynamics`", py.times["py.tau"], "RTB `rne`",
            py.times["rtb.rne"], fmt_diff(py.checks["tau_rne"])),
        Row("tau = R p", "bare ctypes `rrr_inverse_dynamics`, pointers prebuilt",
            py.times["raw.tau"], "RTB `rne`", py.times["rtb.rne"], fmt_diff(py.checks["raw_tau"])),
        Row("forward dynamics", "`Model.forward_dynamics`", py.times["py.fd"], "RTB `accel`",
            py.times["rtb.accel"], fmt_diff(py.checks["fd_accel"])),
    ]

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
        f"load average at start {load[0]}, at end {load[1]}")
    add(f"- C (librrr): {meta['c']}; C++ (driver + Pinocchio headers): {meta['cxx']}; "
        "no -march=native (the prebuilt libpinocchio crashes with it)")
    add(f"- Pinocchio {meta['pinocchio']} (prebuilt libpinocchio_default from the pin wheel), "
        f"Eigen {meta['eigen']}, {py.info['versions']}, Python {platform.python_version()}")
    add(f"- C/C++ rows: {meta['states']} random states (q in [-pi, pi], qd in [-3, 3], "
        f"qdd in [-10, 10]), the same for ours and Pinocchio; {meta['calls']} calls x "
        f"{meta['repeats']} repeats, best repeat in ns/call (throughput loop; empty loop "
        f"{t['loop.empty']:.1f} ns, not subtracted)")
    add(f"- libm floor in the same driver: sin + cos of q2 and q3 as in rrr_trig_of "
        f"(two sincos calls) {t['floor.trig']:.1f} ns, one atan2 {t['floor.atan2']:.1f} ns "
        f"(`rrr_ik` calls atan2 {ik_all.atan2} times, `rrr_ik_branch` {ik_one.atan2} times)")
    if "kernel.tau" in t:
        add(f"- diagnostic: the tau kernel alone (rrr_trig_of + generated code, no argument "
            f"checks, called from the driver) {t['kernel.tau']:.1f} ns of the "
            f"{t['tau.ours']:.1f} ns of `rrr_inverse_dynamics`")
    add(f"- Python rows: {args.py_states} states, best of {args.py_repeats} passes; "
        "includes interpreter and binding overhead on both sides (`Model`: the compiled binding "
        "rrr_robot.core._ext of the installed package; bare ctypes: this build's librrr.so)")
    add(f"- IK: position only (mask [1,1,1,0,0,0]), targets from q1 in [-pi, pi], "
        f"q2 in [-pi/2, pi/2], q3 in [0.2, 2.5]; LM solvers: q0 = (0.1, 0.2, 1.0), "
        f"tol = {args.ik_tol:g} on E = |e|^2/2, ilimit 30, slimit 100, joint_limits off. "
        f"RTB: {py.info['ik_lm']}; C++ LM: {lm_txt}. "
        f"Ours returns all {info['ik.ours']['mean_solutions']:.0f} branches per target.")
    add("- ratio = reference time / our time (> 1: ours is faster). "
        "Noisy shared VM: compare ratios, not absolute times.")
    add("")
    add("## Compiled: librrr (C) vs Pinocchio (C++) and RTB")
    add("")
    lines.extend(render_rows(rows_c))
    add("")
    add("## Through Python: our binding (`rrr_robot`) vs RTB")
    add("")
    lines.extend(render_rows(rows_py))
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
        ("rrr_gen_mass_matrix", "D(q)"),
        ("rrr_gen_coriolis", "c(q, qd)"),
        ("rrr_gen_gravity", "h(q)"),
    ):
        add(f"| {label} (`{name}`) | {gen.ops[name] + TRIG_PROLOGUE_OPS} ops + "
            f"{TRIG_PROLOGUE_CALLS} sin/cos ({gen.ops[name]} generated: {gen.detail[name]}) "
            "| | SymPy count_ops after CSE |")
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
    key = {
        "tau_vs_rnea": rows_c[4].ratio,
        "ik_vs_ik_lm": rows_c[1].ratio,
        "ik_branch_vs_ik_lm": rows_c[3].ratio,
        "ik_py_vs_ik_lm": rows_py[1].ratio,
        "tau_py_vs_rne": rows_py[3].ratio,
        "fd_vs_aba": rows_c[11].ratio,
        "mass_vs_crba": rows_c[7].ratio,
    }
    add(f"Key ratios: tau = R p vs rnea {key['tau_vs_rnea']:.1f}x (target >= "
        f"{TARGET_TAU_VS_RNEA:g}x); IK (C, all branches) vs ets.ik_LM {key['ik_vs_ik_lm']:,.0f}x, "
        f"one branch {key['ik_branch_vs_ik_lm']:,.0f}x (target >= {TARGET_IK_VS_LM:g}x); "
        f"IK through the Python API vs ets.ik_LM {key['ik_py_vs_ik_lm']:,.1f}x.")
    return "\n".join(lines), key


# ---------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build-dir", type=Path, default=BENCH / "build",
                        help="CMake build directory of the C++ driver (default: %(default)s)")
    parser.add_argument("--cmake", default=shutil.which("cmake") or "cmake")
    parser.add_argument("--skip-build", action="store_true", help="reuse an existing build")
    parser.add_argument("--states", type=int, default=1024, help="C++ states (power of 2)")
    parser.add_argument("--calls", type=int, default=200_000, help="C++ calls per repeat")
    parser.add_argument("--repeats", type=int, default=7, help="C++ repeats (best of)")
    parser.add_argument("--py-states", type=int, default=512, help="Python states/targets")
    parser.add_argument("--py-repeats", type=int, default=7, help="Python passes (best of)")
    parser.add_argument("--ik-tol", type=float, default=1e-12,
                        help="LM tolerance on E = |e|^2/2 (RTB's tol), default %(default)g")
    parser.add_argument("--seed", type=int, default=1, help="seed of the Python-side states")
    parser.add_argument("--json", type=Path, help="also write the raw results to this file")
    args = parser.parse_args(argv)

    load_start = load_average()
    build_dir = args.build_dir.resolve()
    if not args.skip_build:
        build(build_dir, args.cmake)
    exe = build_dir / "bench_core"
    lib = build_dir / "rrr" / "librrr.so"
    if not exe.is_file() or not lib.is_file():
        sys.exit(f"run_bench: {exe} or {lib} missing: run without --skip-build")

    # bare ctypes calls use the librrr.so of this very build; Model, the installed package (pip
    # install .[bench]: its compiled binding, which this checkout's sources alone do not have)
    os.environ["RRR_LIBRARY"] = str(lib)

    core = run_core(exe, args)
    py = python_side(args)
    gen = dynamics_count()
    load_end = load_average()
    text, key = report(args, core, py, gen, (load_start, load_end))
    print(text)
    if args.json:
        args.json.write_text(
            json.dumps({"core": core, "python": py.times, "python_checks": py.checks,
                        "ops": gen.ops, "key_ratios": key}, indent=1),
            encoding="utf-8",
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
