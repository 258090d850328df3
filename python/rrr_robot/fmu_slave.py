"""One FMI 2.0 co-simulation slave, driven through FMPy's FMU2Slave.

Owns the extraction folder and the instance (a context manager with an idempotent close), maps
variable names to value references, exchanges blocks of reals through preallocated ctypes
buffers viewed as numpy arrays (no per-step conversion), routes the FMU's log messages to
``logging``, and turns every failed FMI call into a :class:`CosimError` naming the FMU, the call,
the simulation time and the FMU's last error message.
"""

from __future__ import annotations

import ctypes as ct
import logging
import shutil
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Real,
    fmi2ValueReference,
)

from ._arrays import FloatArray
from .errors import BadInputError, CosimError

log = logging.getLogger(__name__)
_STATUS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]


@dataclass
class RealBlock:
    """A fixed set of Real variables exchanged in one FMI call; ``values`` views the buffer."""

    names: tuple[str, ...]
    vrs: ct.Array[fmi2ValueReference]
    buffer: ct.Array[fmi2Real]
    values: FloatArray


class FmuSlave:
    """An instantiated co-simulation FMU (see module docstring)."""

    def __init__(self, path: Path, instance_name: str) -> None:
        self.path = Path(path)
        self.name = instance_name
        self.time = 0.0
        self.last_message = ""
        self._closed = True
        md = read_model_description(str(self.path))
        self._vars = {v.name: v for v in md.modelVariables}
        self._unzipdir = extract(str(self.path))
        self._callbacks = self._make_callbacks()
        self._fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self._closed = False
        try:
            self._fmu.instantiate(callbacks=self._callbacks, loggingOn=False)
        except Exception as exc:  # FMPy raises a bare Exception here
            self.close()
            raise CosimError(f"{self.name}: fmi2Instantiate failed: {exc}") from exc
        self._initialized = False

    def _make_callbacks(self) -> fmi2CallbackFunctions:
        from fmpy.fmi2 import defaultCallbacks
        from fmpy.logging import addLoggerProxy

        def logger(_env: object, _inst: bytes, status: int, category: bytes, msg: bytes) -> None:
            text = msg.decode("utf-8", "replace")
            level = logging.ERROR if status >= 2 else logging.DEBUG
            if status >= 2:
                self.last_message = text
            log.log(level, "[%s] %s %s: %s", self.name, _STATUS[min(status, 5)],
                    category.decode("utf-8", "replace"), text)

        cb = fmi2CallbackFunctions()
        self._logger_ref = fmi2CallbackLoggerTYPE(logger)
        cb.logger = self._logger_ref
        cb.allocateMemory = defaultCallbacks.allocateMemory
        cb.freeMemory = defaultCallbacks.freeMemory
        addLoggerProxy(ct.byref(cb))
        return cb

    # ---- variables ---------------------------------------------------------------------------
    def vr(self, name: str) -> int:
        """Value reference of a variable; BadInputError names an unknown variable."""
        try:
            return int(self._vars[name].valueReference)
        except KeyError as exc:
            raise BadInputError(f"{self.name}: no variable named {name!r} in {self.path}") from exc

    def real_block(self, names: Sequence[str]) -> RealBlock:
        vrs = (fmi2ValueReference * len(names))(*[self.vr(n) for n in names])
        buffer = (fmi2Real * len(names))()
        return RealBlock(tuple(names), vrs, buffer, np.ctypeslib.as_array(buffer))

    def set_block(self, block: RealBlock) -> None:
        self._guard("fmi2SetReal", self._fmu.fmi2SetReal, self._fmu.component, block.vrs,
                    len(block.names), block.buffer)

    def get_block(self, block: RealBlock) -> FloatArray:
        self._guard("fmi2GetReal", self._fmu.fmi2GetReal, self._fmu.component, block.vrs,
                    len(block.names), block.buffer)
        return block.values

    def set_values(self, values: Mapping[str, float | bool]) -> None:
        """Set parameters or inputs by name (Real or Boolean), e.g. start values."""
        for name, value in values.items():
            var = self._vars.get(name)
            if var is None:
                raise BadInputError(f"{self.name}: no variable named {name!r}")
            if var.type == "Boolean":
                self._guard(f"fmi2SetBoolean({name})", self._fmu.setBoolean, [self.vr(name)],
                            [bool(value)])
            else:
                self._guard(f"fmi2SetReal({name})", self._fmu.setReal, [self.vr(name)],
                            [float(value)])

    def get_values(self, names: Sequence[str]) -> dict[str, float]:
        return {n: float(v) for n, v in zip(names, self.get_block(self.real_block(names)),
                                            strict=True)}

    # ---- lifecycle ---------------------------------------------------------------------------
    def initialize(self, start_time: float = 0.0, start_values: Mapping[str, float | bool] = {},
                   ) -> None:
        fmu = self._fmu
        self._guard("fmi2SetupExperiment", fmu.setupExperiment, startTime=start_time)
        self.set_values(start_values)
        self._guard("fmi2EnterInitializationMode", fmu.enterInitializationMode)
        self._guard("fmi2ExitInitializationMode", fmu.exitInitializationMode)
        self.time = start_time
        self._initialized = True

    def do_step(self, h: float) -> None:
        self._guard("fmi2DoStep", self._fmu.fmi2DoStep, self._fmu.component, self.time, h, 1)
        self.time += h

    def _guard(self, what: str, fn: object, *args: object, **kwargs: object) -> None:
        if self._closed:
            raise CosimError(f"{self.name}: {what} called after close()")
        try:
            fn(*args, **kwargs)  # type: ignore[operator]
        except FMICallException as exc:
            status = _STATUS[exc.status] if 0 <= exc.status < 6 else str(exc.status)
            detail = f": {self.last_message}" if self.last_message else ""
            raise CosimError(
                f"{self.name}: {what} returned {status} at t = {self.time:.6f} s{detail}",
                function=what, status=status,
            ) from exc

    def close(self) -> None:
        """Terminate and free the instance and remove the extraction folder (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._initialized:
                self._fmu.terminate()
        except FMICallException:
            log.warning("%s: fmi2Terminate failed", self.name)
        finally:
            if getattr(self._fmu, "component", None) is not None:
                self._fmu.freeInstance()
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
