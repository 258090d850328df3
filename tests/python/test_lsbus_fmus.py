"""The FMI-LS-BUS network FMUs as files: every archive passes FMPy's validation, its
terminalsAndIcons.xml and LS-BUS manifest validate against the standard's schemas (vendored in
third_party/, read with xmlschema: nothing is downloaded), and the three XML files equal the
committed copies generated from the variable tables (fmu/<dir>/rrr_<name>/)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from rrr_robot.hil.lsbus.container import BUS_SIMULATION, lsbus_fmu_path
from rrr_robot.sim.fmus import fmu_dir

ROOT = Path(__file__).resolve().parents[2]
SCHEMAS = ROOT / "third_party"
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
    return ROOT / "fmu" / folder / f"rrr_{name}"


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
