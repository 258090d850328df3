"""Helpers of the FMU tests (tests/python/fmu/, unit/test_version.py): where the FMUs are, and
FMPy slaves that keep the FMU's log messages.

The FMUs come from ``rrr_robot.fmu_path`` (the installed package, or ``$RRR_FMU_DIR`` pointing
at a CMake build's ``fmus/`` folder). Without them the FMU tests fail.
"""

from __future__ import annotations

import atexit
import itertools
import shutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.model_description import ModelDescription
from rrr_robot.sim._fmi_log import fmi2_callbacks
from rrr_robot.sim.fmus import FMU_NAMES

from support import REPO

#: The FMUs that hold the robot model (its parameters, librrr's defaults).
MODEL_FMUS = ("plant", "controller")
REPO_ROOT = REPO
#: Each FMU's committed FMI 2.0 modelDescription.xml: fmu/<name>/, the plant's at the top level
#: (fmu/CMakeLists.txt).
COMMITTED_XML = {
    which: REPO_ROOT / "modelDescription.xml" if which == "plant"
    else REPO_ROOT / "fmu" / which / "modelDescription.xml" for which in FMU_NAMES
}
STEP = 1e-3  # DefaultExperiment stepSize of every FMU, s


def fmu_file(which: str) -> Path:
    """Path of one FMI 2.0 FMU of FMU_NAMES (rrr_robot.fmu_path; fails if there is none)."""
    import rrr_robot

    return Path(rrr_robot.fmu_path(which))


# ---- log capture ------------------------------------------------------------------------------
# FMPy's addLoggerProxy (which formats the printf-style message) keeps ONE Python logger per
# process: rrr_robot.sim._fmi_log owns it (a permanent dispatcher) and routes each instance's
# messages to its receiver, here the list of the slave's (unique) instance name.


@dataclass(frozen=True)
class LogRecord:
    """One message of an FMU."""

    status: int  # fmi2Status: 0 OK, 1 Warning, 2 Discard, 3 Error, 4 Fatal
    category: str
    message: str


_LOGS: dict[str, list[LogRecord]] = {}


def _receiver(name: str) -> Callable[[int, str, str], None]:
    def receive(status: int, category: str, message: str) -> None:
        _LOGS.setdefault(name, []).append(LogRecord(status, category, message))
    return receive


# ---- slaves ---------------------------------------------------------------------------------

_EXTRACTED: dict[Path, str] = {}
_COUNTER = itertools.count()


def _cleanup() -> None:
    for folder in _EXTRACTED.values():
        shutil.rmtree(folder, ignore_errors=True)


atexit.register(_cleanup)


def unzipped(path: Path) -> str:
    """The FMU extracted once per test session."""
    if path not in _EXTRACTED:
        _EXTRACTED[path] = extract(str(path))
    return _EXTRACTED[path]


class Slave:
    """An FMPy FMU2Slave addressed by variable names, with its log messages."""

    def __init__(self, which: str, guid: str | None = None,
                 unzip_dir: str | Path | None = None) -> None:
        """``unzip_dir``: an unzipped copy of the FMU to load instead (e.g. with other
        resources)."""
        path = fmu_file(which)
        self.md: ModelDescription = read_model_description(str(path))
        self.vr: dict[str, int] = {v.name: v.valueReference for v in self.md.modelVariables}
        self.name = f"{which}-{next(_COUNTER)}"
        self.fmu = FMU2Slave(
            guid=guid if guid is not None else self.md.guid,
            unzipDirectory=str(unzip_dir) if unzip_dir is not None else unzipped(path),
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=self.name,
        )
        self.log: list[LogRecord] = _LOGS.setdefault(self.name, [])
        self._alive = False

    def instantiate(self) -> Slave:
        # the package's routing of FMI 2 log messages (one permanent native proxy callback)
        self._callbacks = fmi2_callbacks(_receiver(self.name))
        self.fmu.instantiate(callbacks=self._callbacks)
        self._alive = True
        return self

    def to_step_mode(self, params: Mapping[str, float] | None = None) -> Slave:
        """setupExperiment, parameters, enter/exit initialization mode."""
        self.fmu.setupExperiment(startTime=0.0)
        if params:
            self.set(params)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        return self

    def set(self, values: Mapping[str, float]) -> None:
        self.fmu.setReal([self.vr[k] for k in values], [float(v) for v in values.values()])

    def get(self, names: Iterable[str]) -> list[float]:
        return list(self.fmu.getReal([self.vr[k] for k in names]))

    def errors(self) -> list[str]:
        return [r.message for r in self.log if r.status >= 3]

    def close(self) -> None:
        if self._alive:
            self._alive = False
            self.fmu.freeInstance()

    def __enter__(self) -> Slave:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def joint(name: str) -> list[str]:
    """'q' -> ['q[1]', 'q[2]', 'q[3]']."""
    return [f"{name}[{i}]" for i in (1, 2, 3)]


__all__ = [
    "COMMITTED_XML",
    "FMU_NAMES",
    "MODEL_FMUS",
    "STEP",
    "FMICallException",
    "LogRecord",
    "Slave",
    "fmu_file",
    "joint",
    "unzipped",
]
