"""Read and check an SSP archive written by ``rrr ssp`` before any tool runs it.

Everything a tool would trip over later, or run silently wrong (FMPy's SSP reader, for one,
pairs an unconnected input with whatever connection it looked at last), is refused here with a
:class:`~rrr_robot.errors.BadInputError` that names the file and the problem: not a zip archive,
an entry that could land outside the extraction folder, a link, a duplicate, sizes or a
compression ratio beyond the bounds (:mod:`rrr_robot.core.archives`, also for each FMU inside),
no SystemStructure.ssd, an SSD that does not validate against the SSP 1.0 schema, a component
missing or its FMU missing from the archive, a connector that is no variable of its FMU (or of
the wrong causality), a connection whose ends do not exist or do not go from an output to an
input, an input connected twice or not at all, a parameter value outside the bounds a robot or
scenario file has (:mod:`.bindings`), no default experiment or fixed step, more than
:data:`MAX_STEPS` steps, an experiment outside the reference table, and a reference FMU without
its table. The SSD is checked against FMPy's copy of the SSP 1.0 schemas, then read with lxml.

Only what the SSD references is read (streamed, never whole into memory); with ``workdir`` those
entries are left there as an extracted SSP (SystemStructure.ssd and the FMUs), which is what
``rrr run-ssp`` hands the tools: an entry the SSD does not reference never reaches them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.archives import CheckedZip, scratch_folder
from ..errors import BadInputError, one_line
from ..writing.trajectory import MAX_REFERENCE_SAMPLES
from .bindings import check_bindings
from .export import COMPONENTS
from .ssd import NS, OSP_ANNOTATION, RRR_ANNOTATION, validate_ssd
from .table import TABLE_COLUMNS, TABLE_FILE

__all__ = ["MAX_STEPS", "SspArchive", "read_ssp", "reference_rows"]

#: The largest SystemStructure.ssd read (ours are about 40 kB).
MAX_SSD_BYTES = 10_000_000
#: The largest modelDescription.xml of an FMU read (ours are about 60 kB).
MAX_MODEL_DESCRIPTION_BYTES = 16_000_000
#: Most communication steps of an archive's default experiment: those of the longest reference
#: ``rrr ssp`` writes (MAX_REFERENCE_SAMPLES samples; 1000 s at 1 ms, about half a minute in
#: libcosim here). Beyond it an archive is refused before anything runs.
MAX_STEPS = MAX_REFERENCE_SAMPLES - 1


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
    steps = (stop - start) / step
    if steps > MAX_STEPS + 0.5:
        raise BadInputError(f"{where}: the default experiment has {steps:,.0f} steps of {step:g} "
                            f"s from {start:g} to {stop:g} s: at most {MAX_STEPS:,} (the longest "
                            "reference of rrr ssp)")
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


def _fmu(z: CheckedZip, source: str, work: Path, where: str) -> CheckedZip:
    """The FMU ``source`` of the archive, streamed to ``work/source`` and opened with the same
    checks (a zip in the zip)."""
    dest = work.joinpath(*source.split("/"))
    dest.parent.mkdir(parents=True, exist_ok=True)
    z.copy(source, dest)
    return CheckedZip(dest, "FMU", where=f"{where}: {source}")


def _variables(fmu: CheckedZip, source: str, where: str, comp: str,
               ) -> dict[str, tuple[str, str]]:
    """name -> (causality, type) of the FMU's variables (FMPy reads its model description)."""
    from fmpy import read_model_description

    with scratch_folder("rrr-ssp-") as tmp:
        xml = tmp / "modelDescription.xml"
        xml.write_bytes(fmu.read("modelDescription.xml", MAX_MODEL_DESCRIPTION_BYTES))
        try:
            md = read_model_description(str(xml), validate=False)
        except Exception as exc:  # FMPy raises bare exceptions for a broken FMU
            raise BadInputError(f"{where}: component {comp}: {source} is not a readable FMU: "
                                f"{one_line(exc)}") from exc
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise BadInputError(f"{where}: component {comp}: {source} must be an FMI 2.0 "
                            "Co-Simulation FMU")
    return {v.name: (v.causality, v.type) for v in md.modelVariables}


def _table(fmu: CheckedZip, source: str, where: str) -> dict[str, FloatArray]:
    from ..core.tables import read_csv_table

    entry = f"resources/{TABLE_FILE}"
    if not fmu.has(entry):
        raise BadInputError(f"{where}: the reference FMU {source} has no {entry}")
    with scratch_folder("rrr-ssp-") as tmp:
        path = fmu.copy(entry, tmp / TABLE_FILE)
        try:
            table = read_csv_table(path)
        except (ValueError, UnicodeError) as exc:
            raise BadInputError(f"{where}: resources/{TABLE_FILE} of {source} is malformed: "
                                f"{one_line(exc)}") from exc
    if tuple(table) != TABLE_COLUMNS or table["t"].size < 2 or \
            not all(np.all(np.isfinite(c)) for c in table.values()):
        raise BadInputError(f"{where}: resources/{TABLE_FILE} of {source} must have the columns "
                            f"{', '.join(TABLE_COLUMNS)}, finite values and two rows or more")
    return table


def reference_rows(table: Mapping[str, FloatArray], t: FloatArray, step: float,
                   where: str) -> dict[str, FloatArray]:
    """The table's samples at the times ``t``, which must be sample times of the table."""
    tt = table["t"]
    k = np.clip(np.searchsorted(tt, t - 1e-9 * step), 0, tt.size - 1)
    if not np.all(np.abs(tt[k] - t) <= 1e-6 * step):
        raise BadInputError(f"{where}: the step {step} s does not fall on the reference "
                            "table's samples")
    return {name: col[k] for name, col in table.items()}


def _check_span(table: Mapping[str, FloatArray], start: float, stop: float, step: float,
                where: str) -> None:
    """The experiment lies within the table and its steps fall on the table's samples."""
    tt = table["t"]
    tol = 1e-6 * step
    if start < tt[0] - tol or stop > tt[-1] + tol:
        raise BadInputError(f"{where}: the default experiment [{start:g}, {stop:g}] s is not "
                            f"within the reference table's [{tt[0]:g}, {tt[-1]:g}] s")
    n = round((stop - start) / step)
    reference_rows(table, start + step * np.arange(n + 1, dtype=np.float64), step, where)


def read_ssp(path: str | Path, workdir: Path | None = None) -> SspArchive:
    """Open and check the archive at ``path`` (see the module's docstring); with ``workdir`` (an
    empty folder) the SSD and the FMUs it references are left there, checked."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise BadInputError(f"{where}: no such SSP file")
    with CheckedZip(path, "SSP archive") as z, scratch_folder("rrr-ssp-") as tmp:
        return _read(z, path, where, workdir if workdir is not None else tmp)


def _read(z: CheckedZip, path: Path, where: str, work: Path) -> SspArchive:
    from lxml import etree

    if not z.has("SystemStructure.ssd"):
        raise BadInputError(f"{where}: the archive has no SystemStructure.ssd")
    data = z.read("SystemStructure.ssd", MAX_SSD_BYTES)
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
    types: dict[str, dict[str, str]] = {}
    params: dict[str, dict[str, float | bool]] = {}
    table: dict[str, FloatArray] = {}
    for name, c in comps.items():
        source = c.get("source", "")
        if not z.has(source):
            raise BadInputError(f"{where}: component {name}: its FMU {source!r} is not in "
                                "the archive")
        if source in sources.values():
            raise BadInputError(f"{where}: component {name}: its FMU {source!r} is the FMU of "
                                "another component")
        sources[name] = source
        with _fmu(z, source, work, where) as fmu:
            variables = _variables(fmu, source, where, name)
            if name == "reference":
                table = _table(fmu, source, where)
        types[name] = {v: t for v, (_, t) in variables.items()}
        for conn in c.findall("ssd:Connectors/ssd:Connector", NS):
            cname, kind = conn.get("name"), conn.get("kind")
            causality = variables[cname][0] if cname in variables else None
            if causality != kind:
                raise BadInputError(
                    f"{where}: component {name}: connector {cname!r} ({kind}) is no "
                    f"{kind} of {source}" + (f" (it is an {causality})"
                                             if causality is not None else ""))
            kinds[(name, cname)] = kind
        params[name] = {}
        for p in c.findall("ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues"
                           "/ssv:ParameterSet/ssv:Parameters/ssv:Parameter", NS):
            pname = p.get("name")
            if pname not in variables or variables[pname][0] != "parameter":
                raise BadInputError(f"{where}: component {name}: {pname!r} is no parameter "
                                    f"of {source}")
            if pname in params[name]:
                raise BadInputError(f"{where}: component {name}: parameter {pname} is bound "
                                    "twice")
            params[name][pname] = _value(p, where, name)
        if c.find("ssd:ParameterBindings/ssd:ParameterBinding[@source]", NS) is not None:
            raise BadInputError(f"{where}: component {name}: parameter bindings from files "
                                "(source=...) are not supported; bind values inline")
    check_bindings(params, types, where)
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
    _check_span(table, start, stop, step, where)
    (work / "SystemStructure.ssd").write_bytes(data)
    return SspArchive(path=path, name=root.get("name", path.stem), start_time=start,
                      stop_time=stop, step=step, sources=sources, parameters=params,
                      connections=tuple(connections), info=info, table=table)
