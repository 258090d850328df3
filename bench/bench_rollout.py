#!/usr/bin/env python3
"""Open loop from Python: ``rr.Plant.rollout`` (one C call along an input table) against a Python
loop of ``rr.Plant.step`` and MuJoCo's ``rollout`` (RK4) at matched accuracy, interleaved.

The robot: the default model with only the viscous part b of its friction (the tanh terms of
eq 9 set to 0), so that MuJoCo, which has no eq 9, integrates the same equations: the motor
torque k_t u applied as ``qfrc_applied`` and k_t b qd as the joints' damping of the MuJoCo model
read from our URDF, with the rotor inertias as its armature and our gravity, continuous joints
and no contacts. The input: smooth voltages, held over 5 ms intervals (a zero-order hold, what
all three integrate), ``--runs`` runs of ``--seconds`` each from random starts near
q0 = (0.1, 0.4, 1.0) at rest (short runs: over longer ones the swinging arm's motion is
chaotic, and every integrator's error grows without bound).

Accuracy: the error of each method is max |q - q_ref| over the 5 ms grid, q_ref from our
adaptive integrator at rtol = atol = 1e-12. MuJoCo's RK4 steps are 5 ms / k for k = 1, 2, 4, ...:
the table shows each k's error, and the timing uses the coarsest step whose error is at most
ours at the default tolerances ("matched"), since a coarser RK4 step is faster but less
accurate. Both agree with the reference before they are timed (the script stops otherwise).

Timing: blocks of each method on the same input, interleaved (``bench/_timing.py``), the wall
time per simulated second as min / median / max over ``--repeats``. A measurement, not a test.

Usage:
    python bench/bench_rollout.py [--seconds S] [--repeats N] [--quick]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rrr_robot as rr
from _timing import add_quick, apply_quick, interleaved, logger

DEFAULT_HOLD = 5e-3
HOLD = DEFAULT_HOLD  # s: --hold-ms / 1e3 (set by main)
Q0 = (0.1, 0.4, 1.0)
log = logger("bench_rollout")


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


def main() -> int:
    global HOLD
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=1.0,
                    help="simulated time of each run (default 1)")
    ap.add_argument("--hold-ms", type=float, default=DEFAULT_HOLD * 1e3,
                    help="input hold, ms: the table's step (default 5; 1 is a 1 kHz controller's)")
    ap.add_argument("--runs", type=int, default=20, help="runs from other starts (default 20)")
    ap.add_argument("--repeats", type=int, default=7, help="interleaved blocks (default 7)")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"seconds": 0.5, "runs": 2, "repeats": 2})
    HOLD = args.hold_ms * 1e-3
    try:
        import mujoco  # noqa: F401
    except ImportError:
        log("MuJoCo is not installed: pip install mujoco (the bench extra has it)")
        return 1
    r = rr.read_robot_file()  # the packaged robot: its links (the URDF) and motors
    model = viscous(r.model)
    q0, u = inputs(model, args.seconds, args.runs)
    ref = ours(model, q0, u, rr.PlantIntegrator(rtol=1e-12, atol=1e-12))
    mine = ours(model, q0, u, rr.PlantIntegrator())
    err_ours = float(np.abs(mine - ref).max())
    err_loop = float(np.abs(ours_loop(model, q0, u) - mine).max())
    if err_loop != 0.0:
        log(f"Plant.rollout and the Plant.step loop differ by {err_loop:.3g} rad: stop")
        return 1
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
    print(f"Open loop, {args.runs} runs of {args.seconds:g} s ({sim:g} s simulated), input held "
          f"over {HOLD * 1e3:g} ms, the default robot with viscous friction only; error = max "
          "|q - q_ref| (q_ref: ours at rtol = atol = 1e-12)\n")
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
