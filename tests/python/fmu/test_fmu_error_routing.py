"""FMU errors reach the right place: a failed call of the controller FMU inside run_cosim raises
CosimError naming the controller and carrying the controller FMU's own reason (never the plant,
which is instantiated after it: FMPy's FMI 2 logger proxy keeps one callback per process, and the
per-instance routing of sim/_fmi_log.py is what keeps the controller's messages its own); a
failed instantiation, or an FMU that cannot be read, is a CosimError with the reason."""

from __future__ import annotations

import ctypes as ct
import logging
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.sim import _fmi_log
from rrr_robot.sim.cosim import CosimOptions, run_cosim
from rrr_robot.sim.fmu_slave import FmuSlave

T = np.arange(0.0, 0.01, 1e-3)
Q = np.tile([0.3, 0.4, 1.0], (T.size, 1))
ZERO = np.zeros_like(Q)
REASON = "parameter kt[2] is invalid"  # the FMUs' message for a k_t <= 0


def failing_run(which: str, fmi: int, caplog: pytest.LogCaptureFixture,
                ) -> tuple[rr.CosimError, list[str]]:
    """run_cosim with an invalid parameter in one FMU (exitInitializationMode fails); the error
    and the FMU log messages that mention the reason."""
    values = {"kt[2]": -1.0}
    options = CosimOptions(fmi_version=fmi, **{f"{which}_values": values})  # type: ignore
    caplog.set_level(logging.DEBUG, logger="rrr_robot.sim")
    with pytest.raises(rr.CosimError) as info:
        run_cosim(T, Q, ZERO, ZERO, ZERO, options)
    logged = [r.getMessage() for r in caplog.records if "kt[2]" in r.getMessage()]
    return info.value, logged


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_controller_failure_names_the_controller_and_its_reason(
        fmi: int, caplog: pytest.LogCaptureFixture) -> None:
    err, logged = failing_run("controller", fmi, caplog)
    message = str(err)
    assert message.startswith(f"controller: fmi{fmi}ExitInitializationMode returned ERROR "
                              "at t = 0.000000 s: "), message
    assert REASON in message  # the controller FMU's own words
    assert "plant" not in message
    assert err.function == f"fmi{fmi}ExitInitializationMode" and err.status == "ERROR"
    assert logged and all(m.startswith("[controller]") for m in logged), logged


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_plant_failure_names_the_plant_and_its_reason(
        fmi: int, caplog: pytest.LogCaptureFixture) -> None:
    err, logged = failing_run("plant", fmi, caplog)
    assert str(err).startswith(f"plant: fmi{fmi}ExitInitializationMode returned ERROR")
    assert REASON in str(err) and "controller" not in str(err)
    assert logged and all(m.startswith("[plant]") for m in logged), logged


def test_the_check_catches_messages_routed_to_the_wrong_instance(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """The test above can fail: with the old routing (every FMI 2 instance's messages to the
    receiver registered last, as FMPy's one-callback proxy does) the controller's reason goes to
    the plant and the controller's error has none."""
    shared: dict[str, Any] = {}

    def one_receiver_per_process(receiver: _fmi_log.Receiver) -> Any:
        shared["receiver"] = receiver  # the last one registered wins

        def dispatch(env: int | None, instance: bytes | None, status: int,
                     category: bytes | None, message: bytes | None) -> None:
            shared["receiver"](int(status), (category or b"").decode(),
                               (message or b"").decode())

        cb = _fmi_log.fmi2CallbackFunctions()
        shared.setdefault("keep", []).append(_fmi_log.fmi2CallbackLoggerTYPE(dispatch))
        cb.logger = shared["keep"][-1]
        cb.allocateMemory = _fmi_log.defaultCallbacks.allocateMemory
        cb.freeMemory = _fmi_log.defaultCallbacks.freeMemory
        cb.componentEnvironment = ct.c_void_p(0)
        _fmi_log.addLoggerProxy(ct.byref(cb))
        return cb

    monkeypatch.setattr(_fmi_log, "fmi2_callbacks", one_receiver_per_process)
    try:
        err, logged = failing_run("controller", 2, caplog)
        assert REASON not in str(err)  # what the routing test would catch
        assert logged and all(m.startswith("[plant]") for m in logged), logged
    finally:
        monkeypatch.undo()
        _fmi_log.fmi2_callbacks(lambda *a: None)  # the permanent dispatcher back in the proxy


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("which", ["plant", "controller"])
def test_a_failed_instantiation_is_a_cosim_error_with_the_fmus_message(which: str,
                                                                       fmi: int) -> None:
    """Before: an AttributeError from close() ('_initialized') hid the FMU's message."""
    with pytest.raises(rr.CosimError) as info:
        FmuSlave(rr.fmu_path(which, fmi), "   ")  # the FMUs refuse a blank instance name
    message = str(info.value)
    assert f"fmi{fmi}Instantiate failed" in message
    assert "instanceName must be a non-empty string" in message
    assert info.value.function == f"fmi{fmi}Instantiate"


def test_an_fmu_that_cannot_be_read_is_a_cosim_error(tmp_path: Path) -> None:
    not_zip = tmp_path / "not_a_zip.fmu"
    not_zip.write_text("hello")
    no_binary = tmp_path / "no_binary.fmu"
    with zipfile.ZipFile(rr.fmu_path("plant")) as src, zipfile.ZipFile(no_binary, "w") as dst:
        for item in src.infolist():
            if not item.filename.startswith("binaries/"):
                dst.writestr(item, src.read(item))
    for path, needle in [(tmp_path / "missing.fmu", "cannot read the FMU"),
                         (not_zip, "cannot read the FMU"),
                         (no_binary, "cannot load the binary")]:
        with pytest.raises(rr.CosimError, match=needle) as info:
            FmuSlave(path, "plant")
        assert str(info.value).startswith("plant: ") and str(path) in str(info.value)


def _nan_at(k_bad: int) -> Any:
    """A measure/actuate function that passes values through except at its k_bad-th call."""
    calls = [0]

    def f(x: np.ndarray) -> np.ndarray:
        calls[0] += 1
        return np.full_like(x, np.nan) if calls[0] == k_bad + 1 else np.array(x)

    return f


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("which", ["measure", "actuate"])
def test_a_failure_inside_the_stepping_loop_names_the_fmu_the_call_and_the_time(
        fmi: int, which: str) -> None:
    """The master binds its FMI calls once and guards the whole loop: a refused input at step
    k is still a CosimError of the FMU that refused it, its call and t_k, with its reason."""
    options = CosimOptions(fmi_version=fmi, **{which: _nan_at(4)})  # type: ignore[arg-type]
    with pytest.raises(rr.CosimError) as info:
        run_cosim(T, Q, ZERO, ZERO, ZERO, options)
    who = "controller" if which == "measure" else "plant"
    function = f"fmi{fmi}SetReal" if fmi == 2 else "fmi3SetFloat64"
    message = str(info.value)
    assert message.startswith(f"{who}: {function} returned ERROR at t = 0.004000 s: "), message
    assert "must be finite, got nan" in message, message  # the FMU's own reason
    assert info.value.function == function and info.value.status == "ERROR"


def test_a_discarded_step_inside_the_loop_is_the_plants_do_step() -> None:
    options = CosimOptions(plant_values={"adaptive": False, "h_int": 1e-12})
    with pytest.raises(rr.CosimError) as info:
        run_cosim(T, Q, ZERO, ZERO, ZERO, options)
    assert str(info.value).startswith("plant: fmi2DoStep returned DISCARD at t = 0.000000 s: ")
    assert "substeps of h_int" in str(info.value)
    assert info.value.function == "fmi2DoStep"
