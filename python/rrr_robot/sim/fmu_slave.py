"""One co-simulation slave of FMI 2.0 or 3.0, driven through FMPy's FMU2Slave / FMU3Slave.

Owns the extraction folder and the instance (a context manager with an idempotent close), maps
variable names to value references, exchanges blocks of reals through preallocated ctypes
buffers viewed as numpy arrays (no per-step conversion), routes the FMU's log messages to
``logging``, and turns every failed FMI call into a :class:`CosimError` naming the FMU, the call,
the simulation time and the FMU's last error message. The FMI version is read from the FMU's
model description; both versions have the same variable names and value references, so the
callers never see the difference.
"""

from __future__ import annotations

import atexit
import ctypes as ct
import logging
import os
import shutil
import threading
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from types import TracebackType
from typing import Any, ClassVar

import fmpy
import numpy as np
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

from ..core._arrays import FloatArray
from ..core.archives import extract_to_temp
from ..errors import ArchiveError, BadInputError, CosimError, one_line
from . import _fmi_log

log = logging.getLogger(__name__)
_STATUS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]


@dataclass
class RealBlock:
    """A fixed set of Real variables exchanged in one FMI call; ``values`` views the buffer."""

    names: tuple[str, ...]
    vrs: ct.Array[Any]
    buffer: ct.Array[ct.c_double]
    values: FloatArray


class _Fmi2:
    """The FMI 2.0 calls FmuSlave needs, on FMPy's FMU2Slave."""

    version = 2
    renamed: ClassVar[Mapping[str, str]] = {}

    def __init__(self, md: Any, unzipdir: str, name: str) -> None:
        from fmpy.fmi2 import FMU2Slave

        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)

    def instantiate(self, logger: Callable[[int, str, str], None]) -> None:
        self._callbacks = _fmi_log.fmi2_callbacks(logger)  # kept as long as the instance
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=False)

    def release(self) -> None:
        if hasattr(self, "_callbacks"):
            _fmi_log.release(self._callbacks)

    def vr_array(self, vrs: Sequence[int]) -> ct.Array[Any]:
        from fmpy.fmi2 import fmi2ValueReference

        arr: ct.Array[Any] = (fmi2ValueReference * len(vrs))(*vrs)
        return arr

    def setup(self, start_time: float) -> None:
        self.fmu.setupExperiment(startTime=start_time)

    def enter_initialization(self, start_time: float) -> None:
        self.fmu.enterInitializationMode()

    def set_reals(self, vrs: ct.Array[Any], n: int, buf: ct.Array[ct.c_double]) -> None:
        self.fmu.fmi2SetReal(self.fmu.component, vrs, n, buf)

    def get_reals(self, vrs: ct.Array[Any], n: int, buf: ct.Array[ct.c_double]) -> None:
        self.fmu.fmi2GetReal(self.fmu.component, vrs, n, buf)

    def set_boolean(self, vr: int, value: bool) -> None:
        self.fmu.setBoolean([vr], [value])

    def do_step(self, t: float, h: float) -> None:
        self.fmu.fmi2DoStep(self.fmu.component, t, h, 1)

    # The stepping loop's calls go to the library's ctypes functions directly, checking the
    # status as FMPy's wrapper does (FMICallException above fmi2Warning): two Python frames
    # fewer per call, about a third of an FMU sweep's run (docs/performance.md, "Sweeps").
    # With FMPy's call logger set (debug), they go through FMPy's wrappers.
    def _raw(self, name: str) -> Any:
        functions = getattr(self.fmu, "_functions", None)  # FMPy keeps its ctypes functions there
        if self.fmu.fmiCallLogger is not None or not isinstance(functions, dict):
            return None
        return functions.get(name)

    def setter(self, vrs: ct.Array[Any], n: int) -> Callable[[Any], object]:
        raw = self._raw("fmi2SetReal")
        if raw is None:
            return partial(self.fmu.fmi2SetReal, self.fmu.component, vrs, n)
        return partial(_checked, raw, "fmi2SetReal", self.fmu.component, vrs, n)

    def getter(self, vrs: ct.Array[Any], n: int) -> Callable[[Any], object]:
        raw = self._raw("fmi2GetReal")
        if raw is None:
            return partial(self.fmu.fmi2GetReal, self.fmu.component, vrs, n)
        return partial(_checked, raw, "fmi2GetReal", self.fmu.component, vrs, n)

    def stepper(self) -> Callable[[float, float], object]:
        component = self.fmu.component
        raw = self._raw("fmi2DoStep")
        if raw is None:
            fmi2_do_step = self.fmu.fmi2DoStep
            return lambda t, h: fmi2_do_step(component, t, h, 1)

        def step(t: float, h: float) -> object:
            status = raw(component, t, h, 1)
            if status > 1:  # above fmi2Warning
                raise FMICallException(function="fmi2DoStep", status=status)
            return status
        return step


def _checked(raw: Any, name: str, *args: Any) -> object:
    """``raw(*args)`` (an FMI 2 function of the library), FMICallException above fmi2Warning."""
    status = raw(*args)
    if status > 1:
        raise FMICallException(function=name, status=status)
    return status


class _Fmi3:
    """The FMI 3.0 calls FmuSlave needs, on FMPy's FMU3Slave."""

    version = 3
    renamed: ClassVar[Mapping[str, str]] = {"SetReal": "SetFloat64", "GetReal": "GetFloat64"}

    def __init__(self, md: Any, unzipdir: str, name: str) -> None:
        from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

        self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self._flags = [fmi3Boolean() for _ in range(3)]
        self._last = fmi3Float64()

    def instantiate(self, logger: Callable[[int, str, str], None]) -> None:
        def log3(_env: object, status: int, category: bytes, msg: bytes) -> None:
            logger(int(status), category.decode("utf-8", "replace"),
                   msg.decode("utf-8", "replace"))

        self.fmu.instantiate(loggingOn=False, logMessage=log3)

    def release(self) -> None:
        """FMI 3 log messages are not variadic: FMPy keeps one callback per instance."""

    def vr_array(self, vrs: Sequence[int]) -> ct.Array[Any]:
        from fmpy.fmi3 import fmi3ValueReference

        arr: ct.Array[Any] = (fmi3ValueReference * len(vrs))(*vrs)
        return arr

    def setup(self, start_time: float) -> None:
        """FMI 3 takes the start time when initialization begins."""

    def enter_initialization(self, start_time: float) -> None:
        self.fmu.enterInitializationMode(startTime=start_time)

    def set_reals(self, vrs: ct.Array[Any], n: int, buf: ct.Array[ct.c_double]) -> None:
        self.fmu.fmi3SetFloat64(self.fmu.component, vrs, n, buf, n)

    def get_reals(self, vrs: ct.Array[Any], n: int, buf: ct.Array[ct.c_double]) -> None:
        self.fmu.fmi3GetFloat64(self.fmu.component, vrs, n, buf, n)

    def set_boolean(self, vr: int, value: bool) -> None:
        self.fmu.setBoolean([vr], [value])

    def do_step(self, t: float, h: float) -> None:
        event, terminate, early = self._flags
        self.fmu.fmi3DoStep(self.fmu.component, t, h, True, ct.byref(event),
                            ct.byref(terminate), ct.byref(early), ct.byref(self._last))

    def setter(self, vrs: ct.Array[Any], n: int) -> Callable[[Any], object]:
        fmi3_set, component = self.fmu.fmi3SetFloat64, self.fmu.component
        return lambda values: fmi3_set(component, vrs, n, values, n)

    def getter(self, vrs: ct.Array[Any], n: int) -> Callable[[Any], object]:
        fmi3_get, component = self.fmu.fmi3GetFloat64, self.fmu.component
        return lambda values: fmi3_get(component, vrs, n, values, n)

    def stepper(self) -> Callable[[float, float], object]:
        fmi3_do_step, component = self.fmu.fmi3DoStep, self.fmu.component
        tail = (*(ct.byref(flag) for flag in self._flags), ct.byref(self._last))
        return lambda t, h: fmi3_do_step(component, t, h, True, *tail)


#: The folders of an FMU's binaries that FMPy loads from on this host: ``binaries/<platform>``
#: for FMI 2.0 (linux64, win64, ... or aarch64-linux) and ``binaries/<platform tuple>`` for FMI
#: 3.0 (x86_64-linux, ...). The others (another OS, another CPU) are not extracted: a slave's
#: extraction writes a third of the bytes, and takes a third of the time.
_HOST_BINARIES = tuple(dict.fromkeys((f"binaries/{fmpy.platform}/",
                                      f"binaries/{fmpy.platform_tuple}/")))


def _needed(name: str) -> bool:
    """The entries of an FMU a slave uses: its model description, its resources and its
    binaries for this host (:data:`_HOST_BINARIES`)."""
    return name == "modelDescription.xml" or name.startswith(("resources/", *_HOST_BINARIES))


#: The calls of each FMI version, by the model description's fmiVersion.
_CALLS: dict[str, type[_Fmi2] | type[_Fmi3]] = {"2.0": _Fmi2, "3.0": _Fmi3}


class FmuSlave:
    """An instantiated co-simulation FMU (see module docstring)."""

    def __init__(self, path: Path, instance_name: str) -> None:
        self.path = Path(path)
        self.name = instance_name
        self.time = 0.0
        self.last_message = ""
        self._errors: list[str] = []  # the FMU's error messages during the current call
        self._closed = True
        self._initialized = False
        # the archive checked (core.archives) and the files a slave needs extracted into a
        # fresh folder, removed by close() or when anything below fails
        try:
            self._unzipdir = str(extract_to_temp(self.path, "FMU", include=_needed,
                                                 prefix="rrr-fmu-"))
        except ArchiveError as exc:
            raise CosimError(f"{self._who}: cannot read the FMU {self.path}: "
                             f"{one_line(exc, 500)}") from exc
        try:
            md = self._model_description()
            calls = _CALLS[md.fmiVersion]
            self.fmi_version: int = calls.version
            self._vars = {v.name: v for v in md.modelVariables}
            try:
                self._api: _Fmi2 | _Fmi3 = calls(md, self._unzipdir, instance_name)
            except Exception as exc:  # the binary is missing or does not load
                raise CosimError(f"{self._who}: cannot load the binary of {self.path}: "
                                 f"{one_line(exc, 500)}") from exc
        except BaseException:
            shutil.rmtree(self._unzipdir, ignore_errors=True)
            raise
        self._fmu = self._api.fmu
        self._closed = False
        what = f"fmi{self.fmi_version}Instantiate"
        try:
            self._api.instantiate(self._log)
        except Exception as exc:  # FMPy raises a bare Exception here
            self.close()
            raise CosimError(f"{self._who}: {what} failed{self._detail()}", function=what,
                             status="ERROR") from exc

    def _model_description(self) -> Any:
        """FMPy's model description of the extracted FMU (FMI 2.0 or 3.0, Co-Simulation)."""
        try:
            md = read_model_description(self._unzipdir)
        except Exception as exc:  # OSError, FMPy's validation errors (bare exceptions)
            raise CosimError(f"{self._who}: cannot read the FMU {self.path}: "
                             f"{one_line(exc, 500)}") from exc
        if md.coSimulation is None:
            raise CosimError(f"{self.path} has no Co-Simulation interface")
        if md.fmiVersion not in _CALLS:
            raise CosimError(f"{self.path}: FMI version {md.fmiVersion} is not supported "
                             "(2.0 and 3.0 are)")
        return md

    @property
    def _who(self) -> str:
        return self.name if self.name.strip() else f"FMU instance {self.name!r}"

    def _detail(self) -> str:
        """The FMU's own error messages during the call that failed (never those of an earlier
        call), for the exception."""
        return (": " + "; ".join(self._errors)) if self._errors else ""

    def _log(self, status: int, category: str, text: str) -> None:
        # An error message goes into the CosimError of the call that reports it (the right
        # place, with the instance's name), not to the log as well; should the call succeed
        # after all, _guard logs it as a warning.
        if status >= 2:
            self.last_message = text
            self._errors.append(text)
        log.debug("[%s] %s %s: %s", self.name, _STATUS[min(status, 5)], category, text)

    # ---- variables ---------------------------------------------------------------------------
    def vr(self, name: str) -> int:
        """Value reference of a variable; BadInputError names an unknown variable."""
        try:
            return int(self._vars[name].valueReference)
        except KeyError as exc:
            raise BadInputError(f"{self.name}: no variable named {name!r} in {self.path}") from exc

    def real_block(self, names: Sequence[str]) -> RealBlock:
        vrs = self._api.vr_array([self.vr(n) for n in names])
        buffer = (ct.c_double * len(names))()
        return RealBlock(tuple(names), vrs, buffer, np.ctypeslib.as_array(buffer))

    def set_block(self, block: RealBlock) -> None:
        self._guard("SetReal", self._api.set_reals, block.vrs, len(block.names), block.buffer)

    def get_block(self, block: RealBlock) -> FloatArray:
        self._guard("GetReal", self._api.get_reals, block.vrs, len(block.names), block.buffer)
        return block.values

    def set_values(self, values: Mapping[str, float | bool]) -> None:
        """Set parameters or inputs by name (Real or Boolean), e.g. start values."""
        for name, value in values.items():
            var = self._vars.get(name)
            if var is None:
                raise BadInputError(f"{self.name}: no variable named {name!r}")
            if var.type == "Boolean":
                self._guard(f"SetBoolean({name})", self._api.set_boolean, self.vr(name),
                            bool(value))
            else:
                block = self.real_block([name])
                block.values[0] = float(value)
                self._guard(f"SetReal({name})", self._api.set_reals, block.vrs, 1, block.buffer)

    def get_values(self, names: Sequence[str]) -> dict[str, float]:
        return {n: float(v) for n, v in zip(names, self.get_block(self.real_block(names)),
                                            strict=True)}

    # ---- lifecycle ---------------------------------------------------------------------------
    def initialize(self, start_time: float = 0.0, start_values: Mapping[str, float | bool] = {},
                   ) -> None:
        fmu = self._fmu
        self._guard("SetupExperiment", self._api.setup, start_time)
        self.set_values(start_values)  # parameters and inputs, in state Instantiated
        self._guard("EnterInitializationMode", self._api.enter_initialization, start_time)
        self._guard("ExitInitializationMode", fmu.exitInitializationMode)
        self.time = start_time
        self._initialized = True

    def reset(self) -> None:
        """Back to the state right after instantiation (fmi2Reset / fmi3Reset): every variable
        at its default, ready for :meth:`initialize` of another run."""
        self._guard("Reset", self._fmu.reset)
        self._initialized = False
        self.time = 0.0
        self.last_message = ""

    def do_step(self, h: float) -> None:
        self._guard("DoStep", self._api.do_step, self.time, h)
        self.time += h

    def _guard(self, what: str, fn: object, *args: object, **kwargs: object) -> None:
        if self._closed:
            raise CosimError(f"{self._who}: {what} called after close()")
        self._errors.clear()
        try:
            fn(*args, **kwargs)  # type: ignore[operator]
        except FMICallException as exc:
            raise self.call_failed(what, exc, self.time) from exc
        if self._errors:
            self.flush_messages(f"fmi{self.fmi_version}{self._api.renamed.get(what, what)}")

    # ---- the stepping loop's calls -----------------------------------------------------------
    # A master that makes thousands of calls per second binds them once and skips the per-call
    # guard: it runs its loop inside ``except FMICallException`` and turns the exception into
    # call_failed(...), and calls flush_messages(...) when ``messages`` is not empty. The value
    # arguments are anything FMPy accepts for a pointer to doubles (a ctypes array, or
    # ``ctypes.byref`` of a ``c_double`` with an offset, which points into a recording array).
    def setter(self, block: RealBlock) -> Callable[[Any], object]:
        """The SetReal (SetFloat64) of ``block``'s variables, called with the values."""
        return self._api.setter(block.vrs, len(block.names))

    def getter(self, block: RealBlock) -> Callable[[Any], object]:
        """The GetReal (GetFloat64) of ``block``'s variables, called with the destination."""
        return self._api.getter(block.vrs, len(block.names))

    def stepper(self) -> Callable[[float, float], object]:
        """The DoStep, called with the communication point and the step size."""
        return self._api.stepper()

    @property
    def messages(self) -> list[str]:
        """The FMU's error messages since the last guarded call or flush_messages (the same
        list object for the instance's lifetime: a loop may keep a reference)."""
        return self._errors

    def call_failed(self, what: str, exc: FMICallException, time: float) -> CosimError:
        """The CosimError for the call ``what`` (e.g. "DoStep") that raised ``exc`` at ``time``,
        with the FMU's messages; the caller raises it."""
        status = _STATUS[exc.status] if 0 <= exc.status < 6 else str(exc.status)
        function = f"fmi{self.fmi_version}{self._api.renamed.get(what, what)}"
        err = CosimError(f"{self._who}: {function} returned {status} at t = {time:.6f} s"
                         f"{self._detail()}", function=function, status=status)
        self._errors.clear()
        return err

    def flush_messages(self, where: str) -> None:
        """Log as warnings the error messages of calls that succeeded after all; ``where``
        names the call or the step."""
        for text in self._errors:
            log.warning("[%s] %s: the FMU reported an error: %s", self.name, where, text)
        self._errors.clear()

    def close(self) -> None:
        """Terminate and free the instance and remove the extraction folder (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._initialized:
                self._fmu.terminate()
        except FMICallException:
            log.warning("%s: fmi%dTerminate failed%s", self._who, self.fmi_version,
                        self._detail())
        finally:
            if getattr(self._fmu, "component", None) is not None:
                self._fmu.freeInstance()
            self._api.release()
            shutil.rmtree(self._unzipdir, ignore_errors=True)

    def __enter__(self) -> FmuSlave:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        if not getattr(self, "_closed", True):
            warnings.warn(f"FmuSlave {self.name} was not closed", ResourceWarning, stacklevel=1)
            self.close()


# ---- instances reused across runs --------------------------------------------------------------
# Extracting an FMU and instantiating it costs tens of milliseconds, more than a short run's
# stepping. pooled_slave() keeps the instances of the runs that succeeded, reset (fmi2Reset /
# fmi3Reset: every variable back at its default), and hands them to the next run of the same
# FMU file in the process; an instance whose run failed is closed, never reused.
# $RRR_FMU_REUSE=0 turns the reuse off (every run extracts and instantiates afresh).

#: Idle instances kept per FMU file and instance name.
POOL_SIZE = 4
_pool: dict[tuple[str, str, int, int], list[FmuSlave]] = {}
_pool_lock = threading.Lock()
_pool_pid = os.getpid()  # a forked child must not use (or remove) its parent's instances


def _pool_key(path: Path, name: str) -> tuple[str, str, int, int]:
    try:
        st = os.stat(path)
    except OSError:  # FmuSlave reports the missing file
        return (str(path), name, -1, -1)
    return (os.path.realpath(path), name, st.st_mtime_ns, st.st_size)


@contextmanager
def pooled_slave(path: Path, instance_name: str) -> Iterator[FmuSlave]:
    """An instantiated slave of ``path`` for one run: an idle one of an earlier run in this
    process (reset) or a new one. After a run that succeeded it goes back to the pool, reset;
    after a run that raised it is closed. The results equal those of a fresh instance bit for
    bit (tests/python/fmu/test_fmu_reuse.py). With ``$RRR_FMU_REUSE=0``: a fresh instance, closed
    after the run."""
    global _pool_pid
    if os.environ.get("RRR_FMU_REUSE", "1") == "0":
        with FmuSlave(path, instance_name) as fresh:
            yield fresh
        return
    key = _pool_key(Path(path), instance_name)
    with _pool_lock:
        if _pool_pid != os.getpid():
            _pool.clear()
            _pool_pid = os.getpid()
        idle = _pool.get(key)
        slave = idle.pop() if idle else None
    if slave is None:
        slave = FmuSlave(path, instance_name)
    try:
        yield slave
    except BaseException:
        slave.close()
        raise
    try:
        slave.reset()
    except CosimError:
        slave.close()
        return
    with _pool_lock:
        idle = _pool.setdefault(key, [])
        if len(idle) < POOL_SIZE:
            idle.append(slave)
            return
    slave.close()


def clear_pool() -> None:
    """Close every idle instance (at exit, or to make the next run instantiate afresh)."""
    with _pool_lock:
        slaves = ([s for idle in _pool.values() for s in idle] if _pool_pid == os.getpid()
                  else [])
        _pool.clear()
    for slave in slaves:
        slave.close()


atexit.register(clear_pool)
