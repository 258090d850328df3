"""``rrr ssp``: the writing task's closed loop for one scenario as an SSP 1.0 archive.

The archive holds ``SystemStructure.ssd`` (:mod:`.ssd`) and, in ``resources/``, the three FMI 2.0
Co-Simulation FMUs: ``rrr_reference.fmu`` (the packaged reference FMU with the writing
reference's table in its ``resources/``), ``rrr_controller.fmu`` and ``rrr_plant.fmu`` as they
are installed. Components ``reference``, ``controller`` and ``plant``; connections reference ->
controller (q_ref, qd_ref, qdd_ref), plant -> controller (q, qd), controller u -> plant u; the
parameter values that ``rrr writing`` gives each FMU (the same functions compute them:
``model_fmu_values``, ``controller_fmu_values``, the plant starting at the reference's first
sample); a default experiment over the reference at its sample period.

Each FMU in the archive also carries those values as its start values, so that an importer
that ignores the SSD's parameter bindings (FMPy's ``simulate_ssp`` without a parameter set)
runs the same system: its ``resources/start_values.csv`` (``name,value``, read by the FMU's
binary at instantiation and reset over its compiled defaults; fmu/common) and the ``start``
attributes of its modelDescription.xml, rewritten to the same numbers (the GUID stays the
packaged FMU's: the binary is the same).

The masters of other tools pass a step's outputs to the other FMUs only after every FMU took the
step (libcosim, FMPy: a Jacobi data flow), so the plant integrates each step with the voltage
computed from the reference and the measurement of one step earlier. The archive compensates it
inside the system, by ``lookahead_steps`` communication steps (default 1): the reference FMU's
``lookahead`` gives the controller the reference of the step the plant will integrate, and the
controller's ``lead`` carries the measured state forward by as much (``rrr_predict_state``)
(docs/ssp.md).
"""

from __future__ import annotations

import logging
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import __version__
from ..core import fmu_vars as fv
from ..core.archives import CheckedZip
from ..core.model import DEFAULT_ROBOT_TOML
from ..core.outputs import atomic_path, check_folder
from ..core.param_names import model_fmu_values
from ..errors import BadInputError
from ..sim.cosim import initial_state_values
from ..sim.fmus import FMU_NAMES, fmu_path
from ..writing.job import WritingJob, controller_fmu_values, prepare
from .ssd import Component, Connection, System, write_ssd
from .table import TABLE_FILE, write_reference_table

log = logging.getLogger(__name__)

__all__ = ["COMPONENTS", "SspJob", "export_ssp"]


def _ports(fmu: str, causality: str) -> dict[str, str]:
    """The ``causality`` variables of ``fmu`` and their units, in model-description order."""
    return {v.name: v.unit for v in fv.variables(fmu) if v.causality == causality}


#: Component name (the FMU's) -> FMU file in the archive's resources/.
COMPONENTS = {name: FMU_NAMES[name] for name in ("reference", "controller", "plant")}
#: The components' connectors: name -> unit (the FMUs' inputs and outputs).
REF_OUT = _ports("reference", "output")
CTRL_IN = _ports("controller", "input")
CTRL_OUT = _ports("controller", "output")
PLANT_IN = _ports("plant", "input")
PLANT_OUT = _ports("plant", "output")
#: Most steps of look-ahead (the reference FMU allows up to 1 s).
MAX_LOOKAHEAD_STEPS = 10


@dataclass(frozen=True)
class SspJob:
    """What to export: the archive's path, the writing task's text, one scenario, the robot file,
    the letter scale, the compensation in communication steps (the reference FMU's
    ``lookahead`` and the controller's ``lead``; 0: none) and the controller's own robot file
    (``rrr ssp --controller-robot``: its model in the controller's parameters)."""

    out: Path
    text: str | None = None
    scenario: str = "ctc"
    robot: Path = DEFAULT_ROBOT_TOML
    scale: float = 1.0
    lookahead_steps: int = 1
    # the controller's model from this robot file (None: the plant's, from ``robot``)
    controller_robot: Path | None = None


def connections() -> list[Connection]:
    """reference -> controller (q_ref, qd_ref, qdd_ref), plant -> controller (q, qd, qdd),
    controller u -> plant u."""
    out = [Connection("reference", n, "controller", n)
           for n in REF_OUT if not n.startswith("x_ref")]
    out += [Connection("plant", n, "controller", n)
            for s in ("q", "qd", "qdd") for n in fv.names("plant", s)]
    out += [Connection("controller", n, "plant", n) for n in fv.names("plant", "u")]
    return out


def _check_out(out: Path) -> None:
    if out.suffix.lower() != ".ssp":
        raise BadInputError(f"--out must name an .ssp file, got {str(out)!r}")
    if out.is_dir():
        raise BadInputError(f"--out {str(out)!r} is a folder; name the .ssp file to write")
    check_folder(out.parent if str(out.parent) else Path("."))


#: The FMU's file of start values in its resources/ (fmu/common: FMU_START_FILE).
START_FILE = "start_values.csv"


def _start_text(value: float | bool) -> str:
    """A start value as the XML and the start file write it (every bit of a double)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(float(value))


def start_values_csv(values: Mapping[str, float | bool]) -> str:
    """The FMU's resources/start_values.csv of ``values``."""
    return "name,value\n" + "".join(f"{k},{_start_text(v)}\n" for k, v in values.items())


def with_start_values(xml: bytes, values: Mapping[str, float | bool], where: str) -> bytes:
    """modelDescription.xml with the ``start`` of each variable in ``values`` rewritten."""
    root = ET.fromstring(xml)
    todo = dict(values)
    for var in root.iter("ScalarVariable"):
        name = var.get("name")
        if name in todo:
            typed = next((c for c in var if c.tag in ("Real", "Boolean")), None)
            if typed is None:
                raise BadInputError(f"{where}: variable {name} has no Real or Boolean element")
            typed.set("start", _start_text(todo.pop(name)))
    if todo:
        raise BadInputError(f"{where}: no variables {', '.join(sorted(todo))}")
    body = ET.tostring(root, encoding="unicode")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<!-- Generated from the variable table by '
            "fmu/common/fmu_xml.c; the start values of this system's parameters rewritten by "
            f"rrr ssp (resources/{START_FILE} holds the same). -->\n{body}\n").encode()


def _component_fmu(src: Path, values: Mapping[str, float | bool],
                   resources: Mapping[str, Path] = {}) -> bytes:
    """The packaged FMU ``src`` with ``values`` as its start values (resources/start_values.csv
    and the XML's start attributes) and ``resources`` (name -> file) in its resources/."""
    replaced = {"modelDescription.xml", f"resources/{START_FILE}",
                *(f"resources/{name}" for name in resources)}
    with tempfile.TemporaryDirectory(prefix="rrr-ssp-") as tmp:
        dst = Path(tmp) / src.name
        with CheckedZip(src, "FMU") as zin, \
                zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
            for name, item in zin.entries.items():
                if name not in replaced:
                    zout.writestr(item, b"".join(zin.chunks(name)))
            zout.writestr("modelDescription.xml", with_start_values(
                b"".join(zin.chunks("modelDescription.xml")), values, str(src)))
            zout.writestr(f"resources/{START_FILE}", start_values_csv(values))
            for name, path in resources.items():
                zout.write(path, f"resources/{name}")
        return dst.read_bytes()


def export_ssp(job: SspJob) -> dict[str, Any]:
    """Write the SSP archive of ``job`` atomically; returns what it holds (for the CLI):
    scenario, duration, step, samples, lookahead."""
    _check_out(job.out)
    if not 0 <= job.lookahead_steps <= MAX_LOOKAHEAD_STEPS:
        raise BadInputError(f"the look-ahead must be 0 to {MAX_LOOKAHEAD_STEPS} steps, got "
                            f"{job.lookahead_steps}")
    prepared = prepare(WritingJob(out=job.out.parent, text=job.text, scenarios=[job.scenario],
                                  robot=job.robot, scale=job.scale, figures=False,
                                  controller_robot=job.controller_robot))
    model, robot, (scn,), ref = prepared
    fmus = {name: fmu_path(name, 2) for name in COMPONENTS}
    step = float(ref.t[1] - ref.t[0])
    plant_values = initial_state_values(ref.q[0], ref.qd[0])
    plant_values |= model_fmu_values(model)
    lookahead = job.lookahead_steps * step
    ctrl_values = controller_fmu_values(scn, model, robot.require_control())
    ctrl_values["lead"] = lookahead
    info = {
        "scenario": scn.name, "text": ref.spec.text, "scale": repr(job.scale),
        "robot": job.robot.name, "lookahead_steps": str(job.lookahead_steps),
        **({} if job.controller_robot is None
           else {"controller_robot": job.controller_robot.name}),
        "min_workspace_margin_m": repr(ref.min_margin_m),
        "min_elbow_margin": repr(ref.min_elbow_margin),
        "min_shoulder_margin_m": repr(ref.min_shoulder_margin_m),
    }
    system = System(
        name=f"rrr_writing_{scn.name}", system_name="writing",
        description=f"RRR arm writing task, scenario {scn.name}: reference -> computed-torque "
                    "controller -> plant",
        components=[
            Component("reference", f"resources/{COMPONENTS['reference']}", outputs=REF_OUT,
                      parameters={"lookahead": lookahead}),
            Component("controller", f"resources/{COMPONENTS['controller']}", inputs=CTRL_IN,
                      outputs=CTRL_OUT, parameters=ctrl_values),
            Component("plant", f"resources/{COMPONENTS['plant']}", inputs=PLANT_IN,
                      outputs=PLANT_OUT, parameters=plant_values),
        ],
        connections=connections(),
        start_time=float(ref.t[0]), stop_time=float(ref.t[-1]), step=step,
        generation_tool=f"rrr_robot {__version__} (rrr ssp)", info=info,
    )
    ssd = write_ssd(system)
    with tempfile.TemporaryDirectory(prefix="rrr-ssp-") as tmp:
        table = write_reference_table(Path(tmp) / TABLE_FILE, ref)
        archived = {c.name: _component_fmu(fmus[c.name], c.parameters,
                                           {TABLE_FILE: table} if c.name == "reference" else {})
                    for c in system.components}
    job.out.parent.mkdir(parents=True, exist_ok=True)  # check_folder: it can be created
    with atomic_path(job.out) as part, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", ssd)
        for name, data in archived.items():
            z.writestr(f"resources/{COMPONENTS[name]}", data)
    log.info("%s: scenario %s, %.2f s at %g s (%d samples), look-ahead %d step(s)", job.out,
             scn.name, ref.t[-1] - ref.t[0], step, ref.t.size, job.lookahead_steps)
    return {"scenario": scn.name, "duration": float(ref.t[-1] - ref.t[0]), "step": step,
            "samples": int(ref.t.size), "lookahead_steps": job.lookahead_steps}
