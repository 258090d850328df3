"""The two FMUs together, driven by FMPy.

Open-loop consistency: with zero gains the controller's feedforward u_n is the inverse model
(eq 10) along the reference. Applied to the plant started on the reference, held over each
1 ms step, it reproduces the reference. u_n is sampled at the middle of each step: the
zero-order hold of the midpoint value is second-order accurate (error O(h^2), measured 1.9e-5
rad here), the hold of the left-end value only first order (about 7e-3 rad).

Closed loop: with the default gains (PD + feedforward) the plant tracks the reference.
"""

from __future__ import annotations

import math

import numpy as np
from support.fmu_support import STEP, Slave, joint

Q_START = (0.1, 0.3, -0.8)
AMPLITUDE = (0.6, 0.4, 0.5)  # rad
OMEGA = (math.pi, 1.5 * math.pi, 1.25 * math.pi)  # rad/s
REF = joint("q_ref") + joint("qd_ref") + joint("qdd_ref")


def reference(t: float) -> list[float]:
    """A smooth reference: q_ref, qd_ref, qdd_ref at t."""
    q = [Q_START[i] + AMPLITUDE[i] * math.sin(OMEGA[i] * t) for i in range(3)]
    qd = [AMPLITUDE[i] * OMEGA[i] * math.cos(OMEGA[i] * t) for i in range(3)]
    qdd = [-AMPLITUDE[i] * OMEGA[i] ** 2 * math.sin(OMEGA[i] * t) for i in range(3)]
    return q + qd + qdd


def open_loop_error(sample_offset: float, t_end: float = 1.0) -> tuple[float, float]:
    """max |q - q_ref| over [0, t_end] and max |u_n|, with u_n sampled at t_k + offset * h."""
    gains = {n: 0.0 for n in joint("kp") + joint("kd")}
    start = reference(0.0)
    init = dict(zip(joint("q0") + joint("qd0"), start[:6], strict=True))
    err, u_peak = 0.0, 0.0
    with (
        Slave("plant").instantiate() as plant,
        Slave("controller").instantiate() as ctrl,
    ):
        plant.to_step_mode(init)
        ctrl.to_step_mode(gains)
        for k in range(round(t_end / STEP)):
            t = k * STEP
            ctrl.set(dict(zip(REF, reference(t + sample_offset * STEP), strict=True)))
            u_n = ctrl.get(joint("u_n"))
            assert ctrl.get(joint("u_c")) == [0.0, 0.0, 0.0]
            plant.set(dict(zip(joint("u"), u_n, strict=True)))
            plant.fmu.doStep(t, STEP)
            ctrl.fmu.doStep(t, STEP)
            q = plant.get(joint("q"))
            q_ref = reference(t + STEP)[:3]
            err = max(err, *(abs(a - b) for a, b in zip(q, q_ref, strict=True)))
            u_peak = max(u_peak, *(abs(x) for x in u_n))
        u_max = plant.get(["u_max"])[0]
    assert u_peak < u_max  # no saturation: the plant saw u_n itself
    return err, u_peak


def test_feedforward_reproduces_the_reference_open_loop() -> None:
    err, u_peak = open_loop_error(sample_offset=0.5)
    print(f"open loop, u_n held at the step midpoints: max |q - q_ref| = {err:.3g} rad over 1 s")
    assert err < 1e-4
    assert u_peak > 0.5  # a real motion, not a trivial one


def test_left_end_hold_is_first_order() -> None:
    """The same with u_n(t_k): the error is O(h), which is why the midpoint is sampled."""
    err, _ = open_loop_error(sample_offset=0.0, t_end=0.5)
    mid, _ = open_loop_error(sample_offset=0.5, t_end=0.5)
    assert err > 20 * mid


def test_closed_loop_tracks_the_reference() -> None:
    start = reference(0.0)
    init = dict(zip(joint("q0") + joint("qd0"), start[:6], strict=True))
    err = 0.0
    with (
        Slave("plant").instantiate() as plant,
        Slave("controller").instantiate() as ctrl,
    ):
        plant.to_step_mode({**init, "q0[1]": init["q0[1]"] + 0.02})  # start a little off
        ctrl.to_step_mode()
        for k in range(2000):
            t = k * STEP
            meas = plant.get(joint("q") + joint("qd"))
            ctrl.set(dict(zip(REF + joint("q") + joint("qd"), reference(t) + meas, strict=True)))
            plant.set(dict(zip(joint("u"), ctrl.get(joint("u")), strict=True)))
            plant.fmu.doStep(t, STEP)
            ctrl.fmu.doStep(t, STEP)
            if t > 1.0:
                q = plant.get(joint("q"))
                q_ref = reference(t + STEP)[:3]
                err = max(err, *(abs(a - b) for a, b in zip(q, q_ref, strict=True)))
    assert err < 1e-3


def test_feedforward_equals_the_python_binding() -> None:
    """u_n of the controller FMU = rrr_robot.Model.nominal_voltage (the same C core)."""
    import rrr_robot

    model = rrr_robot.Model.default()
    with Slave("controller").instantiate() as ctrl:
        ctrl.to_step_mode()
        for t in (0.0, 0.13, 0.7):
            r = reference(t)
            ctrl.set(dict(zip(REF, r, strict=True)))
            u_n = np.array(ctrl.get(joint("u_n")))
            expected = model.nominal_voltage(r[:3], r[3:6], r[6:])
            np.testing.assert_allclose(u_n, expected, rtol=1e-13, atol=1e-13)
