"""The FMI-LS-BUS network FMUs as files: every archive passes FMPy's validation, its
terminalsAndIcons.xml and LS-BUS manifest validate against the standard's schemas (vendored in
third_party/, read with xmlschema: nothing is downloaded), and the three XML files equal the
committed copies generated from the variable tables (fmu/<dir>/rrr_<name>/)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.hil.lsbus.container import BUS_SIMULATION, lsbus_fmu_path
from rrr_robot.sim.fmus import fmu_dir
from support import REPO

SCHEMAS = REPO / "third_party"
MANIFEST = "extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml"
TERMINALS = "terminalsAndIcons/terminalsAndIcons.xml"
#: the URL the LS-BUS manifest schema imports its base from, and the vendored copy of it
BASE_URL = ("https://raw.githubusercontent.com/modelica/fmi-standard/v3.0.2/schema/"
            "fmi3LayeredStandardManifest.xsd")


def _local(uri: str) -> str:
    """The vendored copy of the base schema the LS-BUS manifest schema imports by URL."""
    if uri == BASE_URL:
        return str(SCHEMAS / "fmi-standard" / "schema" / "fmi3LayeredStandardManifest.xsd")
    return uri


def _names() -> list[str]:
    return (fmu_dir() / "lsbus_fmu_names.txt").read_text().split()


def _committed_dir(name: str) -> Path:
    folder = name.removesuffix("_countdown")
    return REPO / "fmu" / folder / f"rrr_{name}"


def test_the_list_holds_both_nodes_in_both_kinds() -> None:
    assert _names() == ["controller_can", "controller_can_countdown", "plant_can",
                        "plant_can_countdown"]


@pytest.mark.parametrize("name", ["controller_can", "controller_can_countdown", "plant_can",
                                  "plant_can_countdown", BUS_SIMULATION])
def test_fmpy_validates_the_archive(name: str) -> None:
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(lsbus_fmu_path(name))) == []


@pytest.mark.parametrize("name", ["controller_can", "controller_can_countdown", "plant_can",
                                  "plant_can_countdown"])
def test_terminals_and_manifest_validate_against_the_schemas(name: str) -> None:
    import xmlschema

    terminals = xmlschema.XMLSchema(
        str(SCHEMAS / "fmi-standard" / "schema" / "fmi3TerminalsAndIcons.xsd"))
    manifest = xmlschema.XMLSchema(
        str(SCHEMAS / "fmi-ls-bus" / "schema" / "fmi3LayeredStandardBusManifest.xsd"),
        uri_mapper=_local)
    with zipfile.ZipFile(lsbus_fmu_path(name)) as z:
        t, m = z.read(TERMINALS).decode(), z.read(MANIFEST).decode()
    terminals.validate(t)
    manifest.validate(m)
    # and what the schemas allow but a network FMU must say
    assert 'terminalKind="org.fmi-ls-bus.network-terminal"' in t
    assert 'matchingRule="org.fmi-ls-bus.transceiver"' in t
    assert 'isBusSimulationFMU="false"' in m


def test_the_bus_simulation_keeps_its_upstream_files() -> None:
    """The bus simulation FMU ships the terminals and manifest of its sources as they are: the
    terminals validate; its manifest declares FMI-LS-BUS 1.0.0-beta.1, whose description text
    the 1.0.0 schema's fixed value refuses (docs/ls-bus.md)."""
    import xmlschema

    terminals = xmlschema.XMLSchema(
        str(SCHEMAS / "fmi-standard" / "schema" / "fmi3TerminalsAndIcons.xsd"))
    with zipfile.ZipFile(lsbus_fmu_path(BUS_SIMULATION)) as z:
        t, m = z.read(TERMINALS).decode(), z.read(MANIFEST).decode()
    terminals.validate(t)
    assert 'isBusSimulationFMU="true"' in m and 'fmi-ls-version="1.0.0-beta.1"' in m


def test_a_wrong_manifest_is_refused_by_the_schema() -> None:
    """The validation can fail: a manifest of another layered standard is refused."""
    import xmlschema

    manifest = xmlschema.XMLSchema(
        str(SCHEMAS / "fmi-ls-bus" / "schema" / "fmi3LayeredStandardBusManifest.xsd"),
        uri_mapper=_local)
    with zipfile.ZipFile(lsbus_fmu_path("plant_can")) as z:
        m = z.read(MANIFEST).decode()
    with pytest.raises(xmlschema.XMLSchemaValidationError):
        manifest.validate(m.replace("org.fmi-standard.fmi-ls-bus", "org.fmi-standard.fmi-ls-ref"))


@pytest.mark.parametrize("name", ["controller_can", "controller_can_countdown", "plant_can",
                                  "plant_can_countdown"])
def test_the_archive_ships_the_committed_xml(name: str) -> None:
    committed = _committed_dir(name)
    with zipfile.ZipFile(lsbus_fmu_path(name)) as z:
        for member, file in (("modelDescription.xml", "modelDescription.xml"),
                             (TERMINALS, "terminalsAndIcons.xml"),
                             (MANIFEST, "fmi-ls-manifest.xml")):
            assert z.read(member).decode() == (committed / file).read_text(), (
                f"{committed / file} is stale: cmake --build <build> --target "
                "rrr_fmu_update_xml")


@pytest.mark.parametrize("name,tx_clock", [("plant_can", 'causality="output" variability='
                                            '"discrete" intervalVariability="triggered"'),
                                           ("plant_can_countdown", 'causality="input" variability'
                                            '="discrete" intervalVariability="countdown"')])
def test_the_terminal_variables(name: str, tx_clock: str) -> None:
    from fmpy import read_model_description

    md = read_model_description(str(lsbus_fmu_path(name)))
    by = {v.name: v for v in md.modelVariables}
    tx, rx = by["CAN.Tx_Data"], by["CAN.Rx_Data"]
    assert (tx.type, tx.causality, rx.type, rx.causality) == ("Binary", "output", "Binary",
                                                             "input")
    assert tx.clocks == [by["CAN.Tx_Clock"]] and rx.clocks == [by["CAN.Rx_Clock"]]
    assert md.coSimulation is not None and md.coSimulation.hasEventMode
    assert md.modelExchange is None
    assert by["BusNotifications"].start == "false"
    with zipfile.ZipFile(lsbus_fmu_path(name)) as z:
        xml = z.read("modelDescription.xml").decode()
    assert tx_clock in xml
    mime = 'mimeType="application/org.fmi-standard.fmi-ls-bus.can; version=&quot;1.0.0&quot;"'
    assert xml.count(mime) == 2  # Tx_Data and Rx_Data


def test_the_countdown_nodes_in_a_minimal_importer(tmp_path: Path) -> None:
    """The countdown variants where an importer delivers countdown-clocked values (fmucontainer
    2.0 does not): FMPy's FMU3Slave, the two nodes linked directly, each period one event in
    which both Tx clocks tick (fmi3GetIntervalDecimal announces them) and each node receives
    the other's Tx_Data. The controller commands at its tick from the newest state, one period
    old: every period after the first is commanded, no fault."""
    import csv

    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    period, periods = 1e-3, 100
    nodes = {}
    for role in ("controller", "plant"):
        path = lsbus_fmu_path(f"{role}_can_countdown")
        md = read_model_description(str(path))
        fmu = FMU3Slave(guid=md.instantiationToken,
                        unzipDirectory=extract(str(path), tmp_path / role),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=role)
        fmu.instantiate(eventModeUsed=True)
        vr = {v.name: v.valueReference for v in md.modelVariables}
        nodes[role] = (fmu, vr)
    plant, pvr = nodes["plant"]
    with zipfile.ZipFile(lsbus_fmu_path("controller_can_countdown")) as z:
        first = next(csv.DictReader(z.read("resources/reference.csv").decode().splitlines()))
    for name, col in (("q0[1]", "q_ref[1]"), ("q0[2]", "q_ref[2]"), ("q0[3]", "q_ref[3]")):
        plant.setFloat64([pvr[name]], [float(first[col])])
    for fmu, _ in nodes.values():
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
    import ctypes

    from fmpy.fmi3 import fmi3Float64, fmi3IntervalQualifier

    for k in range(periods + 1):
        if k > 0:
            for fmu, _ in nodes.values():
                fmu.enterEventMode()
        released = {}
        for role, (fmu, vr) in nodes.items():
            fmu.setClock([vr["CAN.Tx_Clock"]], [True])
            released[role] = fmu.getBinary([vr["CAN.Tx_Data"]])[0] or b""
        for role, other in (("controller", "plant"), ("plant", "controller")):
            fmu, vr = nodes[role]
            if released[other]:
                fmu.setClock([vr["CAN.Rx_Clock"]], [True])
                fmu.setBinary([vr["CAN.Rx_Data"]], [released[other]])
        for fmu, vr in nodes.values():
            fmu.updateDiscreteStates()
            intervals = (fmi3Float64 * 1)()
            qualifiers = (fmi3IntervalQualifier * 1)()
            fmu.getIntervalDecimal((ctypes.c_uint32 * 1)(vr["CAN.Tx_Clock"]), intervals,
                                   qualifiers)
            assert abs(intervals[0] - period) < 1e-12  # the next communication point
        if k == periods:
            break
        for fmu, _ in nodes.values():
            fmu.enterStepMode()
            fmu.doStep(k * period, period)
    cvr = nodes["controller"][1]
    ctrl = nodes["controller"][0]
    assert ctrl.getFloat64([cvr["status.commands"]])[0] >= periods - 1
    assert plant.getFloat64([pvr["status.faults"]])[0] == 0.0
    assert plant.getFloat64([pvr["status.cmd_missed"]])[0] <= 2.0
    assert plant.getFloat64([pvr["status.peer_baudrate"]])[0] == 1e6  # the Configuration came
    for fmu, _ in nodes.values():
        fmu.terminate()
        fmu.freeInstance()


@pytest.mark.parametrize("name", ["controller_can", "controller_can_countdown", "plant_can",
                                  "plant_can_countdown"])
def test_a_node_alone_simulates_in_fmpy(name: str) -> None:
    """FMPy's simulate_fmu (no event mode, no clocks): a node runs alone without a bus; the
    plant's supervisor then sees no command and applies 0 V after three periods."""
    import fmpy

    r = fmpy.simulate_fmu(str(lsbus_fmu_path(name)), stop_time=0.01, step_size=1e-3,
                          output_interval=1e-3)
    for col in r.dtype.names:
        assert all(abs(float(x)) < 1e12 for x in r[col]), col
    if name.startswith("plant"):
        assert r["status.timeout"][-1] == 1.0 and r["zero"][-1] == 1.0
    else:
        assert r["status.commands"][-1] == 0.0 and r["period"][-1] == -1.0


@pytest.mark.parametrize("name", ["controller_can", "plant_can"])
def test_the_sources_build_a_working_binary_and_the_documentation_lists_every_variable(
        tmp_path: Path, name: str) -> None:
    """As for the signal FMUs (test_fmu_variants.py): the plain compiler command of the
    archive's documentation builds the binary from sources/ alone (the LS-BUS headers and the
    bench's codec are there), and it runs as the shipped one; the documentation lists every
    variable, the terminal's four among them; the Linux binary needs glibc 2.28 at most."""
    import re
    import subprocess

    import fmpy
    from fmpy import extract

    unzip = Path(extract(str(lsbus_fmu_path(name)), str(tmp_path / "fmu")))
    doc = (unzip / "documentation" / "index.html").read_text()
    command = re.search(r"^cc .*-lm$", doc, re.MULTILINE)
    assert command is not None
    out = f"binaries/x86_64-linux/rrr_{name}.so"
    dump = subprocess.run(["objdump", "-T", str(unzip / out)], capture_output=True, text=True,
                          check=True).stdout
    versions = {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", dump)}
    assert versions and max(versions) <= (2, 28)
    shipped = fmpy.simulate_fmu(str(lsbus_fmu_path(name)), stop_time=0.005, step_size=1e-3)
    (unzip / out).unlink()
    sources = sorted(str(p.relative_to(unzip)) for p in (unzip / "sources").glob("*.c"))
    run = subprocess.run(["cc", "-std=c11", "-O2", "-shared", "-fPIC", "-fvisibility=hidden",
                          "-o", out, *sources, "-lm"], cwd=unzip, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rebuilt = fmpy.simulate_fmu(str(unzip), stop_time=0.005, step_size=1e-3)
    for col in shipped.dtype.names:
        assert np.array_equal(shipped[col], rebuilt[col]), col
    from fmpy import read_model_description

    for v in read_model_description(str(unzip)).modelVariables:
        assert f"<code>{v.name}</code>" in doc, v.name
