"""FMU state from FMPy: get at t1, run on, set back, rerun gives bit-identical outputs; the
same through serialize/deserialize (also into a fresh instance); corrupted bytes are refused;
two instances in one process stay independent.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy.fmi2 import fmi2LastSuccessfulTime
from support.fmu_support import STEP, FMICallException, Slave, joint

PLANT_OUT = joint("q") + joint("qd") + joint("qdd") + ["tip.x", "tip.y", "tip.z"]
CTRL_IN = joint("q_ref") + joint("qd_ref") + joint("qdd_ref")
Q0 = {"q0[1]": 0.1, "q0[2]": 0.3, "q0[3]": -0.8}


def reference(t: float) -> list[float]:
    a, w = (0.6, 0.4, 0.5), (3.0, 4.5, 4.0)
    q = [Q0[f"q0[{i + 1}]"] + a[i] * math.sin(w[i] * t) for i in range(3)]
    qd = [a[i] * w[i] * math.cos(w[i] * t) for i in range(3)]
    qdd = [-a[i] * w[i] ** 2 * math.sin(w[i] * t) for i in range(3)]
    return q + qd + qdd


def run(plant: Slave, ctrl: Slave, k0: int, n: int) -> np.ndarray:
    """n closed-loop steps from step k0; rows: plant outputs + controller u."""
    rows = []
    for k in range(k0, k0 + n):
        t = k * STEP
        q = plant.get(joint("q") + joint("qd"))
        ctrl.set(dict(zip(CTRL_IN + joint("q") + joint("qd"), reference(t) + q, strict=True)))
        u = ctrl.get(joint("u"))
        plant.set(dict(zip(joint("u"), u, strict=True)))
        plant.fmu.doStep(t, STEP)
        ctrl.fmu.doStep(t, STEP)
        rows.append(plant.get(PLANT_OUT) + u)
    return np.array(rows)


@pytest.fixture
def pair() -> tuple[Slave, Slave]:
    plant = Slave("plant").instantiate().to_step_mode(Q0)
    ctrl = Slave("controller").instantiate().to_step_mode()
    yield plant, ctrl
    plant.close()
    ctrl.close()


def test_get_set_state_replays_bit_identically(pair: tuple[Slave, Slave]) -> None:
    plant, ctrl = pair
    run(plant, ctrl, 0, 150)
    sp, sc = plant.fmu.getFMUstate(), ctrl.fmu.getFMUstate()
    first = run(plant, ctrl, 150, 250)
    plant.fmu.setFMUstate(sp)
    ctrl.fmu.setFMUstate(sc)
    assert plant.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(150 * STEP)
    again = run(plant, ctrl, 150, 250)
    assert np.array_equal(first, again)
    plant.fmu.freeFMUstate(sp)
    ctrl.fmu.freeFMUstate(sc)


def test_serialized_state_replays_bit_identically(pair: tuple[Slave, Slave]) -> None:
    plant, ctrl = pair
    run(plant, ctrl, 0, 100)
    sp, sc = plant.fmu.getFMUstate(), ctrl.fmu.getFMUstate()
    bp, bc = plant.fmu.serializeFMUstate(sp), ctrl.fmu.serializeFMUstate(sc)
    plant.fmu.freeFMUstate(sp)
    ctrl.fmu.freeFMUstate(sc)
    first = run(plant, ctrl, 100, 200)

    # back into the same instances
    sp, sc = plant.fmu.deSerializeFMUstate(bp), ctrl.fmu.deSerializeFMUstate(bc)
    plant.fmu.setFMUstate(sp)
    ctrl.fmu.setFMUstate(sc)
    assert np.array_equal(first, run(plant, ctrl, 100, 200))
    plant.fmu.freeFMUstate(sp)
    ctrl.fmu.freeFMUstate(sc)

    # and into fresh instances that were never initialized
    with Slave("plant").instantiate() as p2, Slave("controller").instantiate() as c2:
        sp, sc = p2.fmu.deSerializeFMUstate(bp), c2.fmu.deSerializeFMUstate(bc)
        p2.fmu.setFMUstate(sp)
        c2.fmu.setFMUstate(sc)
        assert np.array_equal(first, run(p2, c2, 100, 200))
        p2.fmu.freeFMUstate(sp)
        c2.fmu.freeFMUstate(sc)


def test_corrupted_or_foreign_bytes_are_refused(pair: tuple[Slave, Slave]) -> None:
    plant, ctrl = pair
    run(plant, ctrl, 0, 10)
    sp = plant.fmu.getFMUstate()
    good = bytes(plant.fmu.serializeFMUstate(sp))
    plant.fmu.freeFMUstate(sp)
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x04
    cases = [
        (bytes(flipped), plant, "checksum"),
        (good[:-8], plant, "size"),
        (b"\x00" * len(good), plant, "magic"),
        (good, ctrl, "another model"),  # a plant state offered to the controller
    ]
    for data, slave, needle in cases:
        with pytest.raises(FMICallException):
            slave.fmu.deSerializeFMUstate(data)
        assert needle in slave.errors()[-1], slave.errors()[-1]
    run(plant, ctrl, 10, 5)  # both still step normally


def test_two_instances_are_independent() -> None:
    u_a, u_b = [1.0, 0.0, 0.0], [0.0, -1.5, 0.5]
    with (
        Slave("plant").instantiate() as a,
        Slave("plant").instantiate() as b,
        Slave("plant").instantiate() as solo,
    ):
        a.to_step_mode()
        b.to_step_mode({"q0[2]": 0.7})
        solo.to_step_mode()
        a.set(dict(zip(joint("u"), u_a, strict=True)))
        b.set(dict(zip(joint("u"), u_b, strict=True)))
        ra, rb = [], []
        for k in range(200):
            a.fmu.doStep(k * STEP, STEP)
            b.fmu.doStep(k * STEP, STEP)
            ra.append(a.get(PLANT_OUT))
            rb.append(b.get(PLANT_OUT))
        solo.set(dict(zip(joint("u"), u_a, strict=True)))
        rs = []
        for k in range(200):
            solo.fmu.doStep(k * STEP, STEP)
            rs.append(solo.get(PLANT_OUT))
    assert np.array_equal(np.array(ra), np.array(rs))
    assert not np.array_equal(np.array(ra), np.array(rb))
