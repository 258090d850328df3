"""SystemStructure.ssd of SSP 1.0: the description of a system, written from a plain
:class:`System` and checked against the SSP 1.0 schemas that FMPy ships.

Only what the writing task needs: one system of FMU components, Real outputs and inputs and Real
and Boolean parameters as connectors, inline parameter bindings (one ``ssv:ParameterSet`` per
component), connections, the units of the connectors, and a default experiment whose fixed step
is given in the Open Simulation Platform's annotation (the one libcosim reads; FMPy takes the
step as an argument).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..errors import BadInputError

__all__ = [
    "OSP_ANNOTATION",
    "RRR_ANNOTATION",
    "Component",
    "Connection",
    "System",
    "validate_ssd",
    "write_ssd",
]

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "rrr": "urn:rrr-robot:ssp",
}
#: Annotation type of the fixed step (libcosim's ssp_parser reads it).
OSP_ANNOTATION = "com.opensimulationplatform"
#: Annotation type of what `rrr ssp` records about the experiment (scenario, text, ...).
RRR_ANNOTATION = "org.rrr-robot.writing"
FMU_TYPE = "application/x-fmu-sharedlibrary"

#: SI base-unit exponents of the connector units (kg, m, s, A, rad).
UNITS: dict[str, dict[str, int]] = {
    "rad": {"rad": 1},
    "rad/s": {"s": -1, "rad": 1},
    "rad/s2": {"s": -2, "rad": 1},
    "m": {"m": 1},
    "s": {"s": 1},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
}

Value = float | bool


@dataclass(frozen=True)
class Component:
    """One FMU of the system: its name, archive path (``resources/<file>.fmu``), its Real
    outputs and inputs (name -> unit or None) and its parameter values."""

    name: str
    source: str
    outputs: Mapping[str, str | None] = field(default_factory=dict)
    inputs: Mapping[str, str | None] = field(default_factory=dict)
    parameters: Mapping[str, Value] = field(default_factory=dict)


@dataclass(frozen=True)
class Connection:
    """``start.start_connector -> end.end_connector``."""

    start: str
    start_connector: str
    end: str
    end_connector: str


@dataclass(frozen=True)
class System:
    """A system of components with a default experiment."""

    name: str
    system_name: str
    description: str
    components: Sequence[Component]
    connections: Sequence[Connection]
    start_time: float
    stop_time: float
    step: float
    generation_tool: str
    info: Mapping[str, str] = field(default_factory=dict)  # the rrr annotation's attributes


def _q(prefix: str, tag: str) -> str:
    return f"{{{NS[prefix]}}}{tag}"


def _num(x: float) -> str:
    if not math.isfinite(x):
        raise BadInputError(f"an SSP value must be finite, got {x!r}")
    return repr(float(x))  # the shortest text that reads back bit for bit


def _connector(parent: ET.Element, name: str, kind: str, kind_type: str,
               unit: str | None) -> None:
    c = ET.SubElement(parent, _q("ssd", "Connector"), name=name, kind=kind)
    attrs = {"unit": unit} if unit else {}
    ET.SubElement(c, _q("ssc", kind_type), attrs)


def _component(parent: ET.Element, comp: Component) -> None:
    el = ET.SubElement(parent, _q("ssd", "Component"), name=comp.name, type=FMU_TYPE,
                       source=comp.source)
    conns = ET.SubElement(el, _q("ssd", "Connectors"))
    for name, unit in comp.inputs.items():
        _connector(conns, name, "input", "Real", unit)
    for name, unit in comp.outputs.items():
        _connector(conns, name, "output", "Real", unit)
    for name, value in comp.parameters.items():
        _connector(conns, name, "parameter", "Boolean" if isinstance(value, bool) else "Real",
                   None)
    if not comp.parameters:
        return
    bindings = ET.SubElement(el, _q("ssd", "ParameterBindings"))
    binding = ET.SubElement(bindings, _q("ssd", "ParameterBinding"))
    values = ET.SubElement(binding, _q("ssd", "ParameterValues"))
    pset = ET.SubElement(values, _q("ssv", "ParameterSet"), version="1.0",
                         name=f"{comp.name}_values")
    params = ET.SubElement(pset, _q("ssv", "Parameters"))
    for name, value in comp.parameters.items():
        p = ET.SubElement(params, _q("ssv", "Parameter"), name=name)
        if isinstance(value, bool):
            ET.SubElement(p, _q("ssv", "Boolean"), value="true" if value else "false")
        else:
            ET.SubElement(p, _q("ssv", "Real"), value=_num(value))


def write_ssd(system: System) -> bytes:
    """The SystemStructure.ssd of ``system`` (UTF-8), valid against the SSP 1.0 schema."""
    for prefix, uri in NS.items():
        ET.register_namespace(prefix, uri)
    root = ET.Element(_q("ssd", "SystemStructureDescription"), version="1.0", name=system.name,
                      description=system.description, generationTool=system.generation_tool)
    sys_el = ET.SubElement(root, _q("ssd", "System"), name=system.system_name,
                           description=system.description)
    elements = ET.SubElement(sys_el, _q("ssd", "Elements"))
    for comp in system.components:
        _component(elements, comp)
    connections = ET.SubElement(sys_el, _q("ssd", "Connections"))
    for c in system.connections:
        ET.SubElement(connections, _q("ssd", "Connection"), startElement=c.start,
                      startConnector=c.start_connector, endElement=c.end,
                      endConnector=c.end_connector)
    used = sorted({u for comp in system.components
                   for u in (*comp.inputs.values(), *comp.outputs.values()) if u})
    if used:
        units = ET.SubElement(root, _q("ssd", "Units"))
        for name in used:
            u = ET.SubElement(units, _q("ssc", "Unit"), name=name)
            ET.SubElement(u, _q("ssc", "BaseUnit"), {k: str(v) for k, v in UNITS[name].items()})
    exp = ET.SubElement(root, _q("ssd", "DefaultExperiment"),
                        startTime=_num(system.start_time), stopTime=_num(system.stop_time))
    annotations = ET.SubElement(exp, _q("ssd", "Annotations"))
    osp = ET.SubElement(annotations, _q("ssc", "Annotation"), type=OSP_ANNOTATION)
    algorithm = ET.SubElement(osp, _q("osp", "Algorithm"))
    ET.SubElement(algorithm, _q("osp", "FixedStepAlgorithm"), baseStepSize=_num(system.step))
    if system.info:
        rrr = ET.SubElement(annotations, _q("ssc", "Annotation"), type=RRR_ANNOTATION)
        ET.SubElement(rrr, _q("rrr", "Experiment"), dict(system.info))
    ET.indent(root)
    text: bytes = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
    return text + b"\n"


def validate_ssd(data: bytes, where: str) -> None:
    """Check SystemStructure.ssd bytes against the SSP 1.0 schema (FMPy's copy of the standard's
    XSD files); BadInputError naming the first problems."""
    from fmpy.ssp.ssd import validate_tree
    from lxml import etree

    try:
        root = etree.fromstring(data)
    except etree.XMLSyntaxError as exc:
        raise BadInputError(f"{where}: SystemStructure.ssd is not well-formed XML: {exc}") \
            from exc
    try:
        validate_tree(root, "SystemStructureDescription.xsd")
    except Exception as exc:  # FMPy raises a bare Exception with the schema's messages
        lines = [x.strip() for x in str(exc).splitlines() if x.strip()]
        raise BadInputError(f"{where}: SystemStructure.ssd does not validate against the SSP "
                            f"1.0 schema: {'; '.join(lines[1:4]) or lines[0]}") from exc
