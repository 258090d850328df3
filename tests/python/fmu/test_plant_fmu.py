"""rr.Plant's steps equal the plant FMU's doStep bit for bit (FMPy), adaptive and fixed step."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr
from support.fmu_support import Slave, joint

U = np.array([0.5, 1.0, 0.3])
Q0 = np.array([0.1, 0.4, 1.0])
H = 1e-3


@pytest.mark.parametrize("settings", [{}, {"adaptive": False, "h_int": 2.5e-4}])
def test_plant_steps_equal_the_fmu_do_step_bit_for_bit(settings) -> None:
    integ = rr.PlantIntegrator(**settings)
    plant = rr.Plant(rr.Model.default(), q0=Q0, integrator=integ)
    reals = {f"q0[{i + 1}]": float(Q0[i]) for i in range(3)}
    reals |= {k: v for k, v in settings.items() if k != "adaptive"}
    names = joint("q") + joint("qd") + joint("qdd") + ["tip.x", "tip.y", "tip.z"]
    with Slave("plant").instantiate() as fmu:
        fmu.fmu.setupExperiment(startTime=0.0)
        fmu.set(reals)
        fmu.fmu.setBoolean([fmu.vr["adaptive"]], [integ.adaptive])
        fmu.fmu.enterInitializationMode()
        fmu.fmu.exitInitializationMode()
        first = fmu.get(names)
        assert first == [*plant.q, *plant.qd, *plant.qdd, *plant.tip]
        fmu.set(dict(zip(joint("u"), U.tolist(), strict=True)))
        t = 0.0
        for k in range(600):  # 0.6 s: joint 3 passes several rad/s
            u = U * (1.0 if k < 300 else -1.0)
            if k == 300:
                fmu.set(dict(zip(joint("u"), u.tolist(), strict=True)))
            fmu.fmu.doStep(t, H)
            t += H
            qdd = plant.step(u, H)
            assert fmu.get(names) == [*plant.q, *plant.qd, *qdd, *plant.tip], k
    assert plant.t == pytest.approx(0.6, abs=1e-12)
    assert plant.stats.evals >= 7 if integ.adaptive else plant.stats.evals == 17
