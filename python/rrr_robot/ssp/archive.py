"""Read and check an SSP archive written by ``rrr ssp`` before any tool runs it.

Everything a tool would trip over later, or run silently wrong (FMPy's SSP reader, for one,
pairs an unconnected input with whatever connection it looked at last), is refused here with a
:class:`~rrr_robot.errors.BadInputError` that names the file and the problem: not a zip archive,
no SystemStructure.ssd, an SSD that does not validate against the SSP 1.0 schema, a component
missing or its FMU missing from the archive, a connector that is no variable of its FMU (or of
the wrong causality), a connection whose ends do not exist or do not go from an output to an
input, an input connected twice or not at all, a parameter value that is not a finite number or
a Boolean, no default experiment or fixed step, and a reference FMU without its table.
The SSD is checked against FMPy's copy of the SSP 1.0 schemas, then read with lxml.
"""

from __future__ import annotations

import math
import tempfile
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..errors import BadInputError
from .export import COMPONENTS
from .ssd import NS, OSP_ANNOTATION, RRR_ANNOTATION, validate_ssd
from .table import TABLE_COLUMNS, TABLE_FILE

__all__ = ["SspArchive", "read_ssp"]

#: The largest SystemStructure.ssd read (ours are about 40 kB).
MAX_SSD_BYTES = 10_000_000


@dataclass(frozen=True)
class SspArchive:
    """A checked archive: its path, name, default experiment, components (name -> FMU path in
    the archive), parameter values per component, connections, the rrr annotation, and the
    reference FMU's table (column -> values)."""

    path: Path
    name: str
    start_time: float
    stop_time: float
    step: float
    sources: Mapping[str, str]
    parameters: Mapping[str, Mapping[str, float | bool]]
    connections: tuple[tuple[str, str, str, str], ...]
    info: Mapping[str, str]
    table: Mapping[str, FloatArray]

    @property
    def scenario(self) -> str:
        """The scenario the archive was written for (its name when the annotation lacks it)."""
        return self.info.get("scenario", self.name)

    @property
    def n_steps(self) -> int:
        """Communication steps from the start to the stop time."""
        return round((self.stop_time - self.start_time) / self.step)


def _float(text: str | None, what: str, where: str) -> float:
    try:
        value = float(text if text is not None else "")
    except ValueError:
        raise BadInputError(f"{where}: {what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise BadInputError(f"{where}: {what} must be finite, got {text!r}")
    return value


def _experiment(root: Any, where: str) -> tuple[float, float, float, dict[str, str]]:
    exp = root.find("ssd:DefaultExperiment", NS)
    if exp is None:
        raise BadInputError(f"{where}: SystemStructure.ssd has no DefaultExperiment (start and "
                            "stop time)")
    start = _float(exp.get("startTime", "0"), "DefaultExperiment startTime", where)
    stop = _float(exp.get("stopTime"), "DefaultExperiment stopTime", where)
    step_el = None
    info: dict[str, str] = {}
    for ann in exp.findall("ssd:Annotations/ssc:Annotation", NS):
        if ann.get("type") == OSP_ANNOTATION:
            step_el = ann.find("osp:Algorithm/osp:FixedStepAlgorithm", NS)
        elif ann.get("type") == RRR_ANNOTATION:
            e = ann.find("rrr:Experiment", NS)
            info = dict(e.attrib) if e is not None else {}
    if step_el is None:
        raise BadInputError(f"{where}: the DefaultExperiment has no fixed step (annotation "
                            f"{OSP_ANNOTATION}: osp:FixedStepAlgorithm baseStepSize)")
    step = _float(step_el.get("baseStepSize"), "baseStepSize", where)
    if not (step > 0 and stop > start):
        raise BadInputError(f"{where}: the default experiment needs step > 0 and stopTime > "
                            f"startTime, got step {step}, [{start}, {stop}]")
    if (stop - start) / step > 10_000_000:
        raise BadInputError(f"{where}: more than 1e7 steps of {step} s from {start} to {stop} s")
    return start, stop, step, info


def _value(p: Any, where: str, comp: str) -> float | bool:
    name = p.get("name")
    real = p.find("ssv:Real", NS)
    if real is not None:
        return _float(real.get("value"), f"parameter {comp}.{name}", where)
    boolean = p.find("ssv:Boolean", NS)
    if boolean is not None and boolean.get("value") in ("true", "false", "1", "0"):
        return boolean.get("value") in ("true", "1")
    raise BadInputError(f"{where}: parameter {comp}.{name} must be a Real or a Boolean value")


def _variables(z: zipfile.ZipFile, source: str, where: str, comp: str) -> dict[str, str]:
    """name -> causality of the FMU's variables (FMPy reads its model description)."""
    from fmpy import read_model_description

    with tempfile.TemporaryDirectory(prefix="rrr-ssp-") as tmp:
        fmu = Path(tmp) / Path(source).name
        fmu.write_bytes(z.read(source))
        try:
            md = read_model_description(str(fmu), validate=False)
        except Exception as exc:  # FMPy raises bare exceptions for a broken FMU
            raise BadInputError(f"{where}: component {comp}: {source} is not a readable FMU: "
                                f"{exc}") from exc
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise BadInputError(f"{where}: component {comp}: {source} must be an FMI 2.0 "
                            "Co-Simulation FMU")
    return {v.name: v.causality for v in md.modelVariables}


def _table(z: zipfile.ZipFile, source: str, where: str) -> dict[str, FloatArray]:
    from ..core.tables import read_csv_table

    with tempfile.TemporaryDirectory(prefix="rrr-ssp-") as tmp:
        fmu = Path(tmp) / "reference.fmu"
        fmu.write_bytes(z.read(source))
        try:
            with zipfile.ZipFile(fmu) as zf:
                data = zf.read(f"resources/{TABLE_FILE}")
        except (KeyError, zipfile.BadZipFile) as exc:
            raise BadInputError(f"{where}: the reference FMU {source} has no resources/"
                                f"{TABLE_FILE}: {exc}") from exc
        path = Path(tmp) / TABLE_FILE
        path.write_bytes(data)
        try:
            table = read_csv_table(path)
        except ValueError as exc:
            raise BadInputError(f"{where}: resources/{TABLE_FILE} of {source} is malformed: "
                                f"{exc}") from exc
    if tuple(table) != TABLE_COLUMNS or table["t"].size < 2 or \
            not all(np.all(np.isfinite(c)) for c in table.values()):
        raise BadInputError(f"{where}: resources/{TABLE_FILE} of {source} must have the columns "
                            f"{', '.join(TABLE_COLUMNS)}, finite values and two rows or more")
    return table


def read_ssp(path: str | Path) -> SspArchive:
    """Open and check the archive at ``path`` (see the module's docstring)."""
    from lxml import etree

    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise BadInputError(f"{where}: no such SSP file")
    try:
        z = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise BadInputError(f"{where}: not an SSP archive (zip): {exc}") from exc
    with z:
        names = set(z.namelist())
        if "SystemStructure.ssd" not in names:
            raise BadInputError(f"{where}: the archive has no SystemStructure.ssd")
        if z.getinfo("SystemStructure.ssd").file_size > MAX_SSD_BYTES:
            raise BadInputError(f"{where}: SystemStructure.ssd is larger than {MAX_SSD_BYTES} "
                                "bytes")
        data = z.read("SystemStructure.ssd")
        validate_ssd(data, where)
        root = etree.fromstring(data)
        start, stop, step, info = _experiment(root, where)
        system = root.find("ssd:System", NS)
        comps = {c.get("name"): c for c in system.findall("ssd:Elements/ssd:Component", NS)}
        missing = [n for n in COMPONENTS if n not in comps]
        if missing:
            raise BadInputError(f"{where}: no component {', '.join(missing)} (an archive of "
                                f"rrr ssp has the components {', '.join(COMPONENTS)})")
        sources: dict[str, str] = {}
        kinds: dict[tuple[str, str], str] = {}
        params: dict[str, dict[str, float | bool]] = {}
        for name, c in comps.items():
            source = c.get("source", "")
            if source not in names:
                raise BadInputError(f"{where}: component {name}: its FMU {source!r} is not in "
                                    "the archive")
            sources[name] = source
            variables = _variables(z, source, where, name)
            for conn in c.findall("ssd:Connectors/ssd:Connector", NS):
                cname, kind = conn.get("name"), conn.get("kind")
                if variables.get(cname) != kind:
                    raise BadInputError(
                        f"{where}: component {name}: connector {cname!r} ({kind}) is no "
                        f"{kind} of {source}" + (f" (it is an {variables[cname]})"
                                                 if cname in variables else ""))
                kinds[(name, cname)] = kind
            params[name] = {}
            for p in c.findall("ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues"
                               "/ssv:ParameterSet/ssv:Parameters/ssv:Parameter", NS):
                pname = p.get("name")
                if variables.get(pname) != "parameter":
                    raise BadInputError(f"{where}: component {name}: {pname!r} is no parameter "
                                        f"of {source}")
                params[name][pname] = _value(p, where, name)
            if c.find("ssd:ParameterBindings/ssd:ParameterBinding[@source]", NS) is not None:
                raise BadInputError(f"{where}: component {name}: parameter bindings from files "
                                    "(source=...) are not supported; bind values inline")
        connections = []
        fed: dict[tuple[str, str], int] = {}
        for conn in system.findall("ssd:Connections/ssd:Connection", NS):
            a = (conn.get("startElement"), conn.get("startConnector"))
            b = (conn.get("endElement"), conn.get("endConnector"))
            text = f"{a[0]}.{a[1]} -> {b[0]}.{b[1]}"
            if kinds.get(a) != "output" or kinds.get(b) != "input":
                raise BadInputError(
                    f"{where}: bad connection {text}: it must go from an output connector to "
                    "an input connector of the components "
                    f"(start is {kinds.get(a, 'not a connector')}, end is "
                    f"{kinds.get(b, 'not a connector')})")
            fed[b] = fed.get(b, 0) + 1
            connections.append((*a, *b))
        for key, kind in kinds.items():
            if kind == "input" and fed.get(key, 0) != 1:
                raise BadInputError(f"{where}: input {key[0]}.{key[1]} has "
                                    f"{fed.get(key, 0)} connections, expected 1")
        table = _table(z, sources["reference"], where)
    return SspArchive(path=path, name=root.get("name", path.stem), start_time=start,
                      stop_time=stop, step=step, sources=sources, parameters=params,
                      connections=tuple(connections), info=info, table=table)
