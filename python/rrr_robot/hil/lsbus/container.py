"""The CAN bench as one FMU: the two network FMUs of FMI-LS-BUS (``rrr_controller_can``,
``rrr_plant_can``), linked terminal to terminal or through the open CAN bus simulation FMU
(``rrr_can_bus_simulation``), assembled by fmu_manipulation_toolbox's ``fmucontainer`` (its
``Assembly``: the same code as the command).

Each node is a copy of the packaged FMU with the run's files in its ``resources/``: the
controller's ``reference.csv`` (the table the C controller node reads) and each node's
``start_values.csv`` (fmu/common's start values: the plant's q0, qd0, the controller's gains
and model, the baud rate, whether Sync is sent), every double exactly.
"""

from __future__ import annotations

import json
import logging
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ...core import fmu_vars as fv
from ...errors import BadInputError, HilError
from ...sim.fmus import fmu_dir

__all__ = ["BUS_SIMULATION", "CONTAINER", "NODES", "ContainerSpec", "build_container",
           "lsbus_fmu_path", "outputs"]

log = logging.getLogger(__name__)

#: The network FMUs (fmu/CMakeLists.txt's RRR_LSBUS_FMU_NAMES), by role: the triggered-output
#: Tx clock variants, which fmucontainer 2.0 delivers (docs/ls-bus.md).
NODES = {"controller": "controller_can", "plant": "plant_can"}
#: The bus simulation FMU (third_party/fmi-ls-bus-examples, built by fmu/lsbus_sim).
BUS_SIMULATION = "can_bus_simulation"
#: The container's file name.
CONTAINER = "rrr_bench_can.fmu"
#: Each node's terminal, and its terminal at the bus simulation.
TERMINAL = "CAN"
BUS_TERMINALS = {"controller": "Node1", "plant": "Node2"}


def lsbus_fmu_path(name: str) -> Path:
    """The packaged FMI 3.0 archive ``rrr_<name>.fmu`` of a network FMU or the bus simulation
    (HilError when the build made none)."""
    path = fmu_dir() / "fmi3" / f"rrr_{name}.fmu"
    if not path.is_file():
        raise HilError(f"{path} does not exist: the package was built without the LS-BUS FMUs "
                       "(reinstall with pip install .)")
    return path


@dataclass(frozen=True)
class ContainerSpec:
    """What the container runs: the reference table, the start values of each node (FMU
    variable names), the bus simulation (or the direct link) and its bit rate."""

    reference_csv: Path
    plant_values: Mapping[str, float | bool] = field(default_factory=dict)
    controller_values: Mapping[str, float | bool] = field(default_factory=dict)
    bus_sim: bool = False
    bitrate: int = 1_000_000
    step: float = 1e-3


def _csv_value(v: float | bool) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(float(v))  # every double exactly


def _node_copy(src: Path, dst: Path, files: Mapping[str, bytes]) -> Path:
    """The archive src with the files added (resources/...), written to dst."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            if item.filename not in files:
                zout.writestr(item, zin.read(item.filename))
        for name, data in files.items():
            zout.writestr(name, data)
    return dst


def _parameter_names(fmu: Path) -> set[str]:
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    return {v.name for v in md.modelVariables if v.causality == "parameter"}


def _start_values(fmu: Path, role: str, values: Mapping[str, float | bool]) -> bytes:
    known = _parameter_names(fmu)
    unknown = sorted(set(values) - known)
    if unknown:
        raise BadInputError(f"the {role} node (rrr_{NODES[role]}) has no parameter "
                            f"{', '.join(unknown)}")
    lines = ["name,value", *(f"{k},{_csv_value(v)}" for k, v in values.items())]
    return ("\n".join(lines) + "\n").encode()


def outputs(role: str) -> list[str]:
    """The variables of node ``role`` the container exposes (as ``<role>.<name>``): what the
    bench's logs hold, and every ``status.*`` counter."""
    if role == "plant":
        names = [*fv.names("plant", "q"), *fv.names("plant", "qd"), *fv.names("plant", "u"),
                 *fv.names("plant", "qdd"), *fv.names("plant", "tip"), "zero"]
    else:
        names = [*fv.names("controller", "u"), *fv.names("controller", "u_n"),
                 *fv.names("controller", "u_c"), *fv.names("controller", "q"),
                 *fv.names("controller", "qd"), "period", "enable"]
    from fmpy import read_model_description

    md = read_model_description(str(lsbus_fmu_path(NODES[role])))
    return names + [v.name for v in md.modelVariables if v.name.startswith("status.")]


def build_container(spec: ContainerSpec, work: Path) -> Path:
    """The node copies, the container's JSON description and the container itself in ``work``
    (fmucontainer's Assembly, FMI 3.0, with its data log); returns the container's path."""
    try:
        from fmu_manipulation_toolbox.assembly import Assembly, AssemblyError
        from fmu_manipulation_toolbox.container import FMUContainerError
    except ImportError as exc:
        raise BadInputError("rrr ls-bus needs fmu_manipulation_toolbox (pip install "
                            "'rrr_robot[lsbus]', or pip install fmu-manipulation-toolbox)"
                            ) from exc
    work.mkdir(parents=True, exist_ok=True)
    c_src, p_src = lsbus_fmu_path(NODES["controller"]), lsbus_fmu_path(NODES["plant"])
    ctrl_values = {**spec.controller_values, "baudrate": float(spec.bitrate)}
    plant_values = {**spec.plant_values, "baudrate": float(spec.bitrate)}
    _node_copy(c_src, work / "controller.fmu", {
        "resources/reference.csv": spec.reference_csv.read_bytes(),
        "resources/start_values.csv": _start_values(c_src, "controller", ctrl_values)})
    _node_copy(p_src, work / "plant.fmu", {
        "resources/start_values.csv": _start_values(p_src, "plant", plant_values)})
    fmus = ["controller.fmu", "plant.fmu"]
    links = [["controller.fmu", TERMINAL, "plant.fmu", TERMINAL]]
    if spec.bus_sim:
        bus = lsbus_fmu_path(BUS_SIMULATION)
        (work / "bus.fmu").write_bytes(bus.read_bytes())
        # the bus first: fmucontainer 2.0 hands a value to an FMU listed after its sender only
        # when the sender answers within the event (docs/ls-bus.md)
        fmus = ["bus.fmu", *fmus]
        links = [[f"{role}.fmu", TERMINAL, "bus.fmu", BUS_TERMINALS[role]] for role in NODES]
    description = {
        "name": CONTAINER, "fmu": fmus, "link": links, "step_size": spec.step,
        "auto_input": False, "auto_output": False, "auto_link": False,
        "output": [[f"{role}.fmu", name, f"{role}.{name}"]
                   for role in NODES for name in outputs(role)],
    }
    (work / "container.json").write_text(json.dumps(description, indent=1) + "\n")
    # fmucontainer logs each port it leaves open (the bus simulation's BusErrorProbability,
    # which keeps its start value 0, as an ERROR line) and each output it does not expose: the
    # build's own errors raise, so its log goes to DEBUG here
    tool_log = logging.getLogger("fmu_manipulation_toolbox")
    level = tool_log.level
    tool_log.setLevel(logging.CRITICAL if not log.isEnabledFor(logging.DEBUG) else level)
    try:
        assembly = Assembly("container.json", fmu_directory=work)
        assembly.make_fmu(fmi_version=3, datalog=True)
    except (FMUContainerError, AssemblyError, OSError, KeyError) as exc:
        raise HilError(f"fmucontainer could not build the container in {work}: {exc}") from exc
    finally:
        tool_log.setLevel(level)
    path = work / CONTAINER
    if not path.is_file():
        raise HilError(f"fmucontainer wrote no {path}")
    return path
