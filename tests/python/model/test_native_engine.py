"""rr.simulate, the closed loop in C (librrr's rrr_sim_closed_loop), equals the co-simulation of
the controller and plant FMUs by the FMPy master bit for bit, for every built-in scenario (same C
functions in the same order), and refuses what belongs to the FMU engine."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core.param_names import model_fmu_values
from rrr_robot.sim.cosim import CosimOptions, run_cosim
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare
from rrr_robot.writing.scenarios import BUILTIN

FIELDS = ("q", "qd", "qdd", "tip", "u", "u_n", "u_c")


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    return prepare(WritingJob(out=tmp_path_factory.mktemp("out"), text="am", figures=False))


def options_for(prep, name: str) -> CosimOptions:
    """The options the writing task gives the FMU master for scenario ``name``."""
    scn = {s.name: s for s in prep.scenarios}[name]
    return CosimOptions(step=float(prep.reference.t[1] - prep.reference.t[0]),
                        plant_values=model_fmu_values(prep.model),
                        controller_values=controller_fmu_values(
                            scn, prep.model, prep.robot.require_control()))


@pytest.mark.parametrize("name", list(BUILTIN))
def test_native_equals_the_fmu_cosimulation_bit_for_bit(prepared, name: str) -> None:
    ref = prepared.reference
    opts = options_for(prepared, name)
    fmu = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)
    native = rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)
    for f in FIELDS:
        assert np.array_equal(getattr(fmu, f), getattr(native, f)), f
    assert native.q.shape == (ref.t.size, 3)


def test_native_equals_the_fmu_with_fixed_step_and_fmi3(prepared) -> None:
    ref = prepared.reference
    base = options_for(prepared, "ctc")
    opts = CosimOptions(step=base.step, plant_values={**base.plant_values, "adaptive": False,
                                                      "h_int": 2.5e-4},
                        controller_values=base.controller_values, fmi_version=3)
    fmu = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)
    native = rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                         CosimOptions(step=opts.step, plant_values=opts.plant_values,
                                      controller_values=opts.controller_values))
    for f in FIELDS:
        assert np.array_equal(getattr(fmu, f), getattr(native, f)), f


def test_native_refuses_what_belongs_to_the_fmus(prepared) -> None:
    ref = prepared.reference
    base = options_for(prepared, "ctc")
    with pytest.raises(rr.BadInputError, match="hooks"):
        rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                    CosimOptions(step=base.step, measure=lambda x: x))
    with pytest.raises(rr.BadInputError, match="no variable 'mass'"):
        rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                    CosimOptions(step=base.step, plant_values={"mass": 1.0}))
    with pytest.raises(rr.ModelError):
        rr.simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                    CosimOptions(step=base.step, controller_values={"kt[2]": 0.0}))
    bad = ref.qd.copy()
    bad[7, 1] = np.nan
    with pytest.raises(rr.BadInputError, match="NaN"):
        rr.simulate(ref.t, ref.q, bad, ref.qdd, ref.x, CosimOptions(step=base.step))


@pytest.mark.parametrize("engine", ["fmpy", "native"])
def test_row_0_shows_the_acceleration_of_its_own_input(prepared, engine: str) -> None:
    """Row 0 of the signal table (t = 0): its qdd is the plant's acceleration under row 0's u
    (before: the free fall under the FMU's start input u = 0 beside the applied u); the rows
    after it are the end of the step to them, under the step's input u[k-1]."""
    ref = prepared.reference
    opts = options_for(prepared, "ctc")  # u[0] holds gravity: far from the free fall
    run = run_cosim if engine == "fmpy" else rr.simulate
    res = run(ref.t, ref.q, ref.qd, ref.qdd, ref.x, opts)
    assert np.abs(res.u[0]).max() > 0.1
    plant = rr.Plant(prepared.model, q0=res.q[0], qd0=res.qd[0])
    assert np.array_equal(res.qdd[0], plant.accel(res.u[0]))  # bit for bit
    assert np.abs(res.qdd[0] - plant.accel(np.zeros(3))).max() > 1.0  # not the free fall
    # row 1: the end of the first step, under u[0]
    plant.step(res.u[0], float(ref.t[1] - ref.t[0]))
    assert np.array_equal(res.qdd[1], plant.qdd)
