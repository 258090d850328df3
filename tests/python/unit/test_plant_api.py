"""rr.Plant: librrr's plant step from Python through the compiled binding (its steps equal the
plant FMU's doStep bit for bit: test_plant_fmu.py). Snapshots make reruns bit-exact, the
binding's plant step refuses hostile input without writing the state, a closed loop written in
Python with Model.ctc and Plant.step equals rr.simulate bit for bit, and hostile input is refused
without changing the state."""

from __future__ import annotations

import ctypes as ct

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core import _ext, _lib
from rrr_robot.core.param_names import model_fmu_values
from rrr_robot.sim.cosim import CosimOptions
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

U = np.array([0.5, 1.0, 0.3])
Q0 = np.array([0.1, 0.4, 1.0])
H = 1e-3


def test_snapshot_restore_reruns_bit_for_bit(model) -> None:
    plant = rr.Plant(model, q0=Q0)
    for _ in range(50):
        plant.step(U, H)
    snap = plant.snapshot()
    first = [plant.step(U * np.sin(k), H).copy() for k in range(40)]
    end = (plant.q, plant.qd, plant.t)
    plant.restore(snap)
    again = [plant.step(U * np.sin(k), H).copy() for k in range(40)]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert np.array_equal(end[0], plant.q) and np.array_equal(end[1], plant.qd)
    other = rr.Plant(model)  # another plant continues from the snapshot the same way
    other.restore(snap)
    assert np.array_equal(other.step(U * np.sin(0), H), first[0])
    # the adaptive step-size memory is part of the snapshot
    assert _state_of(snap).h_guess > 0.0 and _state_of(snap).err_prev > 0.0


def _state_of(snap: rr.PlantSnapshot) -> _lib.RawPlantState:
    return _lib.RawPlantState.from_buffer_copy(snap.state)


def test_the_binding_steps_in_place_and_refuses_without_writing(model) -> None:
    ext = model._k
    packed = rr.PlantIntegrator().packed
    state, stats = _lib.RawPlantState(), _lib.RawPlantStats()
    _ext.plant_state_init(Q0, np.zeros(3), state)
    plant = rr.Plant(model, q0=Q0)
    for k in range(100):  # the binding's step on a state of ours: rr.Plant's steps, bit for bit
        u = U * np.cos(0.1 * k)
        before = bytes(state)
        qdd = ext.plant_step(packed, u, H, state, stats)
        assert bytes(state) != before and stats.steps >= 1 and stats.evals >= stats.steps
        assert qdd.tobytes() == plant.step(u, H).tobytes()
        assert bytes(state) == plant.snapshot().state
        assert ext.plant_accel(state, u).tobytes() == plant.accel(u).tobytes()
    hostile = [
        ((packed, [np.nan, 0, 0], H), rr.BadInputError, "rrr_plant_step failed with "
                                                         "RRR_BAD_INPUT"),
        ((packed, np.zeros((2, 3)), H), rr.BadInputError, "one input voltage"),
        ((packed, "abc", H), rr.BadInputError, "u must be an array of numbers"),
        ((packed, U, 0.0), rr.BadInputError, "rrr_plant_step failed"),
        ((packed, U, -1e-3), rr.BadInputError, "rrr_plant_step failed"),
        ((packed, U, float("inf")), rr.BadInputError, "h must be a finite number"),
        ((packed, U, "x"), rr.BadInputError, "h must be a finite number"),
        ((b"short", U, H), TypeError, "plant_step needs the 40 bytes of an rrr_plant_integrator"),
    ]
    for args, exc, message in hostile:
        before = bytes(state)
        with pytest.raises(exc, match=message):
            ext.plant_step(*args, state, stats)
        assert bytes(state) == before  # nothing written on a refusal
    with pytest.raises(TypeError, match="writable rrr_plant_state"):
        ext.plant_step(packed, U, H, b"\0" * ct.sizeof(_lib.RawPlantState), stats)


def test_a_closed_loop_in_python_equals_rr_simulate(tmp_path) -> None:
    prep = prepare(WritingJob(out=tmp_path / "o", text="am", figures=False))
    ref = prep.reference
    n = 800
    t, q_ref, qd_ref, qdd_ref, x_ref = ref.t[:n], ref.q[:n], ref.qd[:n], ref.qdd[:n], ref.x[:n]
    scn = {s.name: s for s in prep.scenarios}["mismatch"]
    control = prep.robot.require_control()
    opts = CosimOptions(step=float(t[1] - t[0]), plant_values=model_fmu_values(prep.model),
                        controller_values=controller_fmu_values(scn, prep.model, control))
    native = rr.simulate(t, q_ref, qd_ref, qdd_ref, x_ref, opts)
    ctrl = scn.controller_model(prep.model)
    gains = rr.CtcGains(scn.kp or control.kp, scn.kd or control.kd, scn.feedforward)
    plant = rr.Plant(prep.model, q0=q_ref[0], qd0=qd_ref[0], t0=float(t[0]))
    step = opts.step
    for k in range(n):
        assert np.array_equal(plant.q, native.q[k]) and np.array_equal(plant.qd, native.qd[k])
        assert np.array_equal(plant.tip, native.tip[k])
        u, _, u_c = ctrl.ctc(gains, q_ref[k], qd_ref[k], qdd_ref[k], plant.q, plant.qd)
        assert np.array_equal(u, native.u[k]) and np.array_equal(u_c, native.u_c[k]), k
        # row 0: the acceleration under its own input; then the end of each step's
        assert np.array_equal(plant.accel(u) if k == 0 else plant.qdd, native.qdd[k]), k
        if k < n - 1:
            plant.step(u, step)


def test_bad_construction_and_restore_are_refused(model) -> None:
    with pytest.raises(rr.BadInputError, match="q0"):
        rr.Plant(model, q0=[0.0, np.nan, 0.0])
    with pytest.raises(rr.BadInputError):
        rr.Plant(model, qd0=np.zeros((4, 3)))
    with pytest.raises(rr.BadInputError, match="Model"):
        rr.Plant("model")  # type: ignore[arg-type]
    with pytest.raises(rr.BadInputError, match="rtol"):
        rr.PlantIntegrator(rtol=0.5)
    with pytest.raises(rr.BadInputError, match="h_int"):
        rr.PlantIntegrator.fixed_step(0.0)
    with pytest.raises(rr.BadInputError, match="adaptive"):
        rr.PlantIntegrator(adaptive=1)  # type: ignore[arg-type]
    with pytest.raises(rr.BadInputError, match="max_steps"):
        rr.PlantIntegrator(max_steps=0)
    plant = rr.Plant(model)
    with pytest.raises(rr.BadInputError, match="snapshot"):
        plant.restore("not a snapshot")  # type: ignore[arg-type]
    snap = plant.snapshot()
    bad = rr.PlantSnapshot(snap.state, (float("nan"), 0.0, 0.0), 0.0)
    with pytest.raises(rr.BadInputError, match="non-finite"):
        plant.restore(bad)
    # a step the integrator cannot finish (max_steps reached) leaves the plant as it was
    tight = rr.Plant(model, q0=Q0, integrator=rr.PlantIntegrator(max_steps=1, rtol=1e-14,
                                                                  atol=1e-14))
    before = tight.snapshot()
    with pytest.raises(rr.RrrError, match="rrr_plant_step"):
        tight.step(U, 0.5)
    assert tight.snapshot() == before


@pytest.mark.parametrize("adaptive", [True, False])
def test_rollout_equals_a_loop_of_steps_and_keeps_the_state_on_a_bad_row(model,
                                                                         adaptive: bool) -> None:
    """Plant.rollout (rrr_plant_rollout, in parts of ROLLOUT_PART rows) gives the numbers of a
    loop of Plant.step bit for bit, across the parts; a non-finite row raises naming it and
    leaves the plant after the row before it; bad tables and steps are refused before any
    step."""
    from rrr_robot.core.plant import ROLLOUT_PART

    integ = rr.PlantIntegrator(adaptive=adaptive, h_int=2.5e-4)
    n = ROLLOUT_PART + 300  # two C calls
    k = np.arange(n)[:, None]
    u = U * np.cos(0.003 * k * np.array([1.0, 1.7, 2.3]))
    a, b = rr.Plant(model, q0=Q0, integrator=integ), rr.Plant(model, q0=Q0, integrator=integ)
    rows = []
    for i in range(n):
        qdd = a.step(u[i], H)
        rows.append((a.t, a.q, a.qd, qdd))
    r = b.rollout(u, H)
    assert np.array_equal(r.t, [x[0] for x in rows])
    for j, field in ((1, r.q), (2, r.qd), (3, r.qdd)):
        assert np.array_equal(field, np.array([x[j] for x in rows]))
    assert a.snapshot() == b.snapshot() and r.stats.steps >= n and r.stats.evals > n
    # both continue the same way
    assert np.array_equal(a.step(U, H), b.rollout(U[None, :], H).qdd[0])
    # a NaN in row 700: rows before it applied, the plant after row 699, the row named
    bad = u.copy()
    bad[700, 2] = np.nan
    c = rr.Plant(model, q0=Q0, integrator=integ)
    with pytest.raises(rr.BadInputError, match="at row 700"):
        c.rollout(bad, H)
    assert np.array_equal(c.q, rows[699][1]) and c.t == rows[699][0]
    assert np.array_equal(c.qdd, rows[699][3])
    # refused before any step: the plant unchanged
    d = rr.Plant(model, q0=Q0, integrator=integ)
    before = d.snapshot()
    for table, h, what in ((U, H, "table of shape"), (np.ones((5, 2)), H, "shape"),
                           (u[:5], 0.0, "BAD_INPUT"), (u[:5], float("nan"), "BAD_INPUT"),
                           (u[:5], "1e-3", "h must be a number"),
                           ([["a", 1, 2]], H, "array of numbers")):
        with pytest.raises(rr.BadInputError, match=what):
            d.rollout(table, h)  # type: ignore[arg-type]
        assert d.snapshot() == before
    empty = d.rollout(np.empty((0, 3)), H)
    assert empty.q.shape == (0, 3) and d.snapshot() == before
