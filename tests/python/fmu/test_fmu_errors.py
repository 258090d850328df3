"""Refusals seen from FMPy: NaN/Inf values, illegal call sequences, invalid parameters and a
discarded step each give the documented status, a log message naming what is wrong, and leave
the instance as it was. (tests/c/test_fmu_harness.c tries every function in every state.)
"""

from __future__ import annotations

import math

import pytest
from fmpy.fmi2 import fmi2LastSuccessfulTime
from support.fmu_support import STEP, FMICallException, Slave, joint

FMI_DISCARD = 2
FMI_ERROR = 3

BAD_NUMBERS = [math.nan, math.inf, -math.inf]
SETTABLE = [
    ("plant", "u[1]"),
    ("plant", "q0[2]"),
    ("plant", "p[5]"),
    ("plant", "h_int"),
    ("plant", "rtol"),
    ("controller", "q_ref[3]"),
    ("controller", "qd[1]"),
    ("controller", "kd[2]"),
    ("controller", "w[1,3]"),
]


@pytest.mark.parametrize("bad", BAD_NUMBERS, ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize(("which", "name"), SETTABLE)
def test_non_finite_values_are_refused_and_the_old_value_kept(
    which: str, name: str, bad: float
) -> None:
    with Slave(which).instantiate() as s:
        s.fmu.enterInitializationMode()
        before = s.get([name])[0]
        with pytest.raises(FMICallException) as info:
            s.set({name: bad})
        assert info.value.status == FMI_ERROR
        assert any(name in m and "finite" in m for m in s.errors()), s.errors()
        assert s.get([name])[0] == before
        s.fmu.exitInitializationMode()  # nothing was corrupted
        s.fmu.doStep(0.0, STEP)


def test_inputs_are_checked_while_stepping() -> None:
    with Slave("plant").instantiate() as s:
        s.to_step_mode()
        s.set({"u[1]": 0.5})
        with pytest.raises(FMICallException):
            s.set({"u[1]": 2.0, "u[3]": math.nan})  # atomic: u[1] is not changed either
        assert s.get(joint("u")) == [0.5, 0.0, 0.0]
        s.fmu.doStep(0.0, STEP)
        assert all(math.isfinite(x) for x in s.get(joint("q")))


@pytest.mark.parametrize(
    ("which", "name", "value", "needle"),
    [
        ("plant", "q[1]", 0.0, "is an output"),
        ("plant", "a2", 0.5, "InitializationMode only"),
        ("controller", "u_c[2]", 0.0, "is an output"),
        ("controller", "kp[1]", 1.0, "InitializationMode only"),
    ],
)
def test_variables_that_may_not_be_set_now(
    which: str, name: str, value: float, needle: str
) -> None:
    with Slave(which).instantiate() as s:
        s.to_step_mode()
        before = s.get([name])[0]
        with pytest.raises(FMICallException):
            s.set({name: value})
        assert any(name in m and needle in m for m in s.errors()), s.errors()
        assert s.get([name])[0] == before


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        (lambda f: f.doStep(0.0, STEP), "fmi2DoStep: illegal call sequence"),
        (lambda f: f.exitInitializationMode(), "fmi2ExitInitializationMode: illegal call"),
        (lambda f: f.terminate(), "fmi2Terminate: illegal call sequence"),
        (lambda f: f.getReal([0]), "fmi2GetReal: illegal call sequence"),
    ],
)
def test_illegal_call_sequences_in_instantiated(call: object, needle: str) -> None:
    with Slave("plant").instantiate() as s:
        with pytest.raises(FMICallException) as info:
            call(s.fmu)  # type: ignore[operator]
        assert info.value.status == FMI_ERROR
        assert any(needle in m and "Instantiated" in m for m in s.errors()), s.errors()
        s.to_step_mode()  # the instance is still in Instantiated and usable


def test_illegal_call_sequences_after_terminate() -> None:
    with Slave("controller").instantiate() as s:
        s.to_step_mode()
        s.fmu.terminate()
        for call in (
            lambda: s.fmu.doStep(0.0, STEP),
            lambda: s.set({"q[1]": 0.1}),
            lambda: s.fmu.enterInitializationMode(),
            lambda: s.fmu.terminate(),
        ):
            with pytest.raises(FMICallException):
                call()
        assert sum("illegal call sequence" in m for m in s.errors()) == 4
        s.get(joint("u"))  # reading is still allowed
        s.fmu.reset()
        s.to_step_mode()


@pytest.mark.parametrize(
    ("which", "name", "value"),
    [
        ("plant", "a3", 0.0),
        ("plant", "kt[3]", -1.0),
        ("plant", "h_int", -1e-4),
        ("plant", "rtol", 0.5),
        ("plant", "atol", 0.0),
        ("controller", "u_max", 0.0),
        ("controller", "kd[2]", -1.0),
    ],
)
def test_invalid_parameters_are_named_at_exit_initialization(
    which: str, name: str, value: float
) -> None:
    with Slave(which).instantiate() as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.set({name: value})
        s.fmu.enterInitializationMode()
        with pytest.raises(FMICallException) as info:
            s.fmu.exitInitializationMode()
        assert info.value.status == FMI_ERROR
        assert any(f"parameter {name}" in m for m in s.errors()), s.errors()


def test_do_step_arguments() -> None:
    with Slave("plant").instantiate() as s:
        s.to_step_mode()
        s.fmu.doStep(0.0, STEP)
        for t, h, needle in [
            (STEP, 0.0, "communicationStepSize"),
            (STEP, -STEP, "communicationStepSize"),
            (0.5, STEP, "currentCommunicationPoint 0.5 differs from the FMU time 0.001"),
        ]:
            with pytest.raises(FMICallException):
                s.fmu.doStep(t, h)
            assert needle in s.errors()[-1]
        s.fmu.doStep(STEP, 2.5 * STEP)  # variable communication steps are fine
        assert s.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(3.5 * STEP)


def test_a_step_that_cannot_be_taken_is_discarded() -> None:
    with Slave("plant").instantiate() as s:
        s.fmu.setBoolean([s.vr["adaptive"]], [False])  # the fixed-step RK4
        s.to_step_mode()
        s.fmu.doStep(0.0, STEP)
        q = s.get(joint("q") + joint("qd"))
        with pytest.raises(FMICallException) as info:
            s.fmu.doStep(STEP, 1e4)  # 1e8 RK4 substeps: more than one step may take
        assert info.value.status == FMI_DISCARD
        assert any("substeps of h_int" in r.message for r in s.log if r.status == FMI_DISCARD)
        assert s.fmu.getRealStatus(fmi2LastSuccessfulTime) == STEP
        assert s.get(joint("q") + joint("qd")) == q
        s.fmu.terminate()


def test_unknown_debug_log_category() -> None:
    with Slave("plant").instantiate() as s:
        with pytest.raises(FMICallException):
            s.fmu.setDebugLogging(True, ["logEverything"])
        assert "logEverything" in s.errors()[-1]
        s.fmu.setDebugLogging(True, ["logCalls"])
        s.fmu.setupExperiment(startTime=0.0)
        assert any(r.category == "logCalls" for r in s.log)


@pytest.mark.parametrize(("f", "w"), [(1e8, 100.0), (1e4, 1e4), (0.08, 1e10)])
def test_a_plant_too_stiff_is_refused_at_exit_initialization(f: float, w: float) -> None:
    """Legal friction values that cost 0.45 s per doStep (f[1,3] = 1e8) or 18 s and a Discard
    (f >= 1e10): refused at exitInitializationMode, before any doStep integrates, naming both
    parameters and the stiffness estimate."""
    with Slave("plant").instantiate() as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.set({"f[1,3]": f, "w[1,3]": w})
        s.fmu.enterInitializationMode()
        with pytest.raises(FMICallException) as info:
            s.fmu.exitInitializationMode()
        assert info.value.status == FMI_ERROR
        assert any("f[1,3]" in m and "w[1,3]" in m and "too stiff" in m for m in s.errors()), \
            s.errors()
