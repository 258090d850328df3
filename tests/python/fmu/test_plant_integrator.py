"""The plant FMU's integrator inside doStep: the adaptive Dormand-Prince 5(4) default against an
independent tight-tolerance solution (SciPy's DOP853 at rtol 1e-13 on the FMU's own Model
Exchange derivatives, which are librrr's rrr_plant_accel bit for bit), the fixed-step RK4 still
selectable, the parameters doing what docs/fmus.md says, and the writing task's tip path equal to
the fixed-step one within 1e-9 m.
"""

from __future__ import annotations

from ctypes import c_double
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Model
from scipy.integrate import solve_ivp
from support.fmu_support import STEP, Slave, fmu_file, joint, unzipped

Q0 = (0.1, 0.4, 1.0)
U = (0.5, 1.0, 0.3)
T_END = 2.0
N = round(T_END / STEP)


def cs_run(values: dict[str, float], flags: dict[str, bool] | None = None) -> np.ndarray:
    """q at every 1 ms communication point (N rows) of the Co-Simulation plant, open loop."""
    with Slave("plant").instantiate() as s:
        if flags:
            s.fmu.setBoolean([s.vr[k] for k in flags], list(flags.values()))
        s.to_step_mode({f"q0[{i + 1}]": q for i, q in enumerate(Q0)} | values)
        s.set(dict(zip(joint("u"), U, strict=True)))
        rows = []
        for k in range(N):
            s.fmu.doStep(k * STEP, STEP)
            rows.append(s.get(joint("q")))
        return np.array(rows)


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    """q at the same points by DOP853 (rtol = atol = 1e-13) on the Model Exchange derivatives."""
    path = fmu_file("plant")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Model(guid=md.guid, unzipDirectory=unzipped(path),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="dop853")
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.setReal([vr[f"q0[{i + 1}]"] for i in range(3)], list(Q0))
        fmu.setReal([vr[n] for n in joint("u")], list(U))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        xs, dx = (c_double * 6)(), (c_double * 6)()

        def rhs(t: float, x: np.ndarray) -> np.ndarray:
            fmu.setTime(t)
            xs[:] = x
            fmu.setContinuousStates(xs, 6)
            fmu.getDerivatives(dx, 6)
            return np.array(dx[:])

        t_eval = STEP * np.arange(1, N + 1)
        x0 = np.array([*Q0, 0.0, 0.0, 0.0])
        sols = [solve_ivp(rhs, (0.0, T_END), x0, method="DOP853", rtol=tol, atol=tol,
                          t_eval=t_eval) for tol in (1e-13, 1e-12)]
    finally:
        fmu.terminate()
        fmu.freeInstance()
    for sol in sols:
        assert sol.success, sol.message
    # the reference's own error, bounded by its distance from a 10x looser solution
    own = np.abs(sols[0].y[:3] - sols[1].y[:3]).max()
    print(f"DOP853 rtol 1e-13 vs 1e-12: {own:.3g} rad")
    assert own < 1e-10
    return sols[0].y[:3].T


def test_default_meets_1e_8_rad_over_2_s(reference: np.ndarray) -> None:
    err_default = np.abs(cs_run({}) - reference).max()
    err_fixed = np.abs(cs_run({}, {"adaptive": False}) - reference).max()
    print(f"open loop 2 s, max |q - q_DOP853|: default {err_default:.3g} rad, fixed-step RK4 "
          f"(h_int 1e-4 s) {err_fixed:.3g} rad")
    assert err_default <= 1e-8
    assert err_default < err_fixed  # more accurate than the former default, for less work


def test_tolerances_converge(reference: np.ndarray) -> None:
    errs = [np.abs(cs_run({"rtol": rtol, "atol": rtol / 10}) - reference).max()
            for rtol in (1e-6, 1e-9, 1e-12)]
    print("max error at rtol 1e-6, 1e-9, 1e-12: " + ", ".join(f"{e:.3g}" for e in errs))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-11


def test_h_int_applies_to_the_fixed_step_only() -> None:
    a = cs_run({})
    assert np.array_equal(a, cs_run({"h_int": 1e-3}))      # adaptive: h_int unused
    f1 = cs_run({"h_int": 1e-4}, {"adaptive": False})
    f2 = cs_run({"h_int": 5e-5}, {"adaptive": False})
    assert not np.array_equal(f1, f2)
    assert np.abs(f1 - f2).max() < 1e-7


def test_writing_task_tip_path_equals_the_fixed_step_one(tmp_path: Path) -> None:
    """The ctc scenario of the default writing task, co-simulated with the default plant and with
    the fixed-step plant (adaptive = false, h_int = 1e-4 s): tip paths within 1e-9 m."""
    from rrr_robot.core.param_names import model_fmu_values
    from rrr_robot.sim.cosim import CosimOptions, run_cosim
    from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, (scn,), ref = prepare(WritingJob(out=tmp_path / "w", scenarios=["ctc"]))
    plant = model_fmu_values(model)
    ctrl = controller_fmu_values(scn, model, robot.require_control())

    def tip(extra: dict[str, float | bool]) -> np.ndarray:
        options = CosimOptions(step=float(ref.t[1] - ref.t[0]), plant_values=plant | extra,
                               controller_values=ctrl, plant_fmu=fmu_file("plant"))
        return run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options).tip

    default, fixed = tip({}), tip({"adaptive": False, "h_int": 1e-4})
    diff = float(np.linalg.norm(default - fixed, axis=1).max())
    print(f"writing task ctc, {ref.t.size} steps: max |tip_default - tip_fixed| = {diff:.3g} m")
    assert not np.array_equal(default, fixed)  # the flag reached the plant
    assert diff <= 1e-9
