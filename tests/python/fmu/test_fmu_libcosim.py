"""Both FMUs in libcosim (Open Simulation Platform, through libcosimpy), which parses them with
the FMI Library (FMIL): no [error] or [warning] line from its parser or anywhere else, and the
same outputs as FMPy for the same inputs.

libcosim runs in a subprocess: its log goes to the process's stdout/stderr, which the test reads
whole, and its threads stay out of the pytest process. The inputs libcosim applied are read back
with its last-value observer, then replayed through FMPy.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from support.fmu_support import STEP, Slave, fmu_file, joint

N_STEPS = 300

# Runs in a subprocess: python -c SCRIPT <plant.fmu> <controller.fmu> <n_steps>
SCRIPT = r"""
import json, math, sys
from libcosimpy.CosimEnums import CosimExecutionState
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave

log_output_level(CosimLogLevel.DEBUG)
plant_fmu, ctrl_fmu, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
keep = []  # the slave objects outlive their executions


def setup(*slaves):
    ex = CosimExecution.from_step_size(1_000_000)  # 1 ms in ns
    obs = CosimObserver.create_last_value()
    man = CosimManipulator.create_override()
    ex.add_observer(obs)
    ex.add_manipulator(man)
    keep.extend(CosimLocalSlave(fmu_path=f, instance_name=name) for f, name in slaves)
    idx = [ex.add_local_slave(s) for s in keep[-len(slaves):]]
    vrs = [{v.name.decode(): v.reference for v in ex.slave_variables(i)} for i in idx]
    return ex, obs, man, idx, vrs


def names(base):
    return [f"{base}[{i}]" for i in (1, 2, 3)]


out = {}
# 1. plant alone, time-varying voltages through the override manipulator
ex, obs, man, (p,), (pv,) = setup((plant_fmu, "plant"))
for name, value in zip(names("q0"), (0.1, 0.3, -0.8)):
    ex.real_initial_value(p, pv[name], value)
rec = []
watch = names("u") + names("q") + names("qd") + names("qdd") + ["tip.x", "tip.y", "tip.z"]
for k in range(n):
    t = k * 1e-3
    u = [0.8 * math.sin(5 * t), -1.0 + 0.3 * math.cos(3 * t), 0.2]
    man.slave_real_values(p, [pv[x] for x in names("u")], u)
    assert ex.step(1), "plant step failed"
    rec.append(obs.last_real_values(p, [pv[x] for x in watch]))
out["plant"] = {"names": watch, "rows": rec, "time": ex.status().current_time}
del ex, obs, man

# 2. controller alone, time-varying inputs
ex, obs, man, (c,), (cv,) = setup((ctrl_fmu, "controller"))
ins = names("q_ref") + names("qd_ref") + names("qdd_ref") + names("q") + names("qd")
watch = ins + names("u") + names("u_n") + names("u_c")
rec = []
for k in range(n):
    t = k * 1e-3
    vals = [0.05 * math.sin(2 * t + i) for i in range(15)]
    man.slave_real_values(c, [cv[x] for x in ins], vals)
    assert ex.step(1), "controller step failed"
    rec.append(obs.last_real_values(c, [cv[x] for x in watch]))
out["controller"] = {"names": watch, "rows": rec}
del ex, obs, man

# 3. closed loop: set-point regulation, controller -> plant -> controller
ex, obs, man, (p, c), (pv, cv) = setup((plant_fmu, "plant"), (ctrl_fmu, "controller"))
for a, b in zip(names("u"), names("u")):
    ex.connect_real_variables(c, cv[a], p, pv[b])
for a, b in zip(names("q") + names("qd"), names("q") + names("qd")):
    ex.connect_real_variables(p, pv[a], c, cv[b])
target = [0.3, 0.5, -0.6]
for name, value in zip(names("q_ref"), target):
    ex.real_initial_value(c, cv[name], value)
ok = ex.simulate_until(2_000_000_000)
status = ex.status()
out["loop"] = {
    "ok": bool(ok) and status.state == CosimExecutionState.STOPPED.value,
    "q": obs.last_real_values(p, [pv[x] for x in names("q")]),
    "target": target,
}
print("RESULT " + json.dumps(out))
"""


@pytest.fixture(scope="module")
def cosim() -> tuple[dict[str, dict[str, object]], str]:
    run = subprocess.run(
        [
            sys.executable,
            "-c",
            SCRIPT,
            str(fmu_file("plant")),
            str(fmu_file("controller")),
            str(N_STEPS),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    log = run.stdout + run.stderr
    assert run.returncode == 0, log[-4000:]
    line = next(x for x in run.stdout.splitlines() if x.startswith("RESULT "))
    return json.loads(line[len("RESULT ") :]), log


def test_fmil_parses_both_fmus_without_errors_or_warnings(
    cosim: tuple[dict[str, dict[str, object]], str],
) -> None:
    _, log = cosim
    assert "[FMI Library: FMILIB] Parsing finished successfully" in log
    assert log.count("Successfully loaded all the interface functions") >= 4
    bad = [x for x in log.splitlines() if "[error]" in x or "[warning]" in x or "[fatal]" in x]
    assert bad == []


def test_plant_matches_fmpy(cosim: tuple[dict[str, dict[str, object]], str]) -> None:
    data = cosim[0]["plant"]
    names: list[str] = data["names"]  # type: ignore[assignment]
    rows = np.array(data["rows"])
    assert data["time"] == N_STEPS * 1_000_000
    with Slave("plant").instantiate() as s:
        s.to_step_mode(dict(zip(joint("q0"), (0.1, 0.3, -0.8), strict=True)))
        ref = []
        for k in range(N_STEPS):
            s.set(dict(zip(joint("u"), rows[k, :3], strict=True)))  # the input libcosim applied
            s.fmu.doStep(k * STEP, STEP)
            ref.append(s.get(names))
    ref_arr = np.array(ref)
    # libcosim counts time in integer ns, so its step sizes differ from 1e-3 by ~1e-18 s
    np.testing.assert_allclose(rows, ref_arr, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(rows[:, 3:6] - rows[0, 3:6])) > 1e-3  # the arm moved
    print(f"libcosim vs FMPy, plant: max |diff| = {np.max(np.abs(rows - ref_arr)):.3g}")


def test_controller_matches_fmpy(cosim: tuple[dict[str, dict[str, object]], str]) -> None:
    data = cosim[0]["controller"]
    names: list[str] = data["names"]  # type: ignore[assignment]
    rows = np.array(data["rows"])
    n_in = 15
    with Slave("controller").instantiate() as s:
        s.to_step_mode()
        ref = []
        for k in range(N_STEPS):
            s.set(dict(zip(names[:n_in], rows[k, :n_in], strict=True)))
            ref.append(s.get(names[n_in:]))
            s.fmu.doStep(k * STEP, STEP)
    ref_arr = np.array(ref)
    assert np.array_equal(rows[:, n_in:], ref_arr)  # direct feedthrough: bit for bit
    assert np.ptp(rows, axis=0).min() > 0.0  # inputs and outputs all varied


def test_closed_loop_in_libcosim_reaches_the_set_point(
    cosim: tuple[dict[str, dict[str, object]], str],
) -> None:
    loop = cosim[0]["loop"]
    assert loop["ok"]
    err = max(abs(a - b) for a, b in zip(loop["q"], loop["target"], strict=True))  # type: ignore[call-overload]
    assert math.isfinite(err) and err < 1e-2, loop
