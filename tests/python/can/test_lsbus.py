"""``rrr ls-bus``: the CAN bench's nodes as FMI-LS-BUS network FMUs in a container built by
fmucontainer and run by FMPy. In direct communication the run equals ``rrr hil bench`` (the C
nodes over socketcand) bit for bit in q, u and the tip; the frames of the container's data log,
written as a pcap, decode with rrr_bench.dbc; through the bus simulation FMU the summary states
what the bus did to the frames, at 1 Mbit/s and at 250 kbit/s."""

from __future__ import annotations

import json
import struct
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rrr_robot.cli import main
from rrr_robot.hil.dbc.protocol import database
from rrr_robot.hil.logs.specs import CONTROLLER_LOG, PLANT_LOG, read_log

DURATION = "0.3"


def _summary(out: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((out / "summary.json").read_text())
    return data


@pytest.fixture(scope="module")
def direct(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ls bus") / "direct"  # a path with a space
    assert main(["ls-bus", "--duration", DURATION, "--out", str(out), "-q"]) == 0
    return out


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("hil") / "bench"
    assert main(["hil", "bench", "--duration", DURATION, "--out", str(out), "-q",
                 "--no-figures"]) == 0
    return out


def test_direct_run_equals_the_c_bench_bit_for_bit(direct: Path, bench: Path) -> None:
    a, b = _summary(direct), _summary(bench)
    assert a["bench"]["tip_error_max"] == b["bench"]["tip_error_max"]
    assert a["bench"]["tip_error_rms"] == b["bench"]["tip_error_rms"]
    # every column of both logs: the plant's state, voltage and tip, the state the controller
    # received (quantised by JointState), its voltages and Enable bit
    for name, spec in (("plant.csv", PLANT_LOG), ("controller.csv", CONTROLLER_LOG)):
        la, lb = read_log(direct / name, spec), read_log(bench / name, spec)
        assert la.rows.shape == lb.rows.shape, name
        for col in spec.names:
            assert np.array_equal(la.col(col), lb.col(col)), f"{name}: {col}"
    # the same safety outcome: nothing fired, every command arrived
    assert a["faults"]["faults"] == 0 and a["missed_commands"] == 0
    assert a["plant_exit"] == b["plant_exit"] == 0


def test_the_container_was_built_by_fmucontainer(direct: Path) -> None:
    ls = _summary(direct)["ls_bus"]
    assert ls["built_by"].startswith("fmu_manipulation_toolbox 2.0")
    assert ls["run_by"].startswith("FMPy")
    container = direct / "rrr_bench_can.fmu"
    with zipfile.ZipFile(container) as z:
        names = z.namelist()
    assert "resources/container.txt" in names  # fmucontainer's runtime configuration
    assert any(n.endswith("controller.fmu/modelDescription.xml") or "controller" in n
               for n in names)
    # every frame went across, none was lost
    for key in ("controller_to_plant", "plant_to_controller"):
        assert ls[key]["sent"] > 0 and ls[key]["lost"] == 0, key
    assert ls["periods_without_a_command"] == 0


def _pcap_frames(path: Path) -> list[tuple[float, int, bytes]]:
    raw = path.read_bytes()
    magic, _major, _minor, _zone, _sig, _snap, link = struct.unpack(">IHHiIII", raw[:24])
    assert magic == 0xA1B2C3D4 and link == 227  # SocketCAN frames
    frames, pos = [], 24
    while pos < len(raw):
        sec, usec, incl, _orig = struct.unpack(">IIII", raw[pos:pos + 16])
        can_id, n = struct.unpack(">IB", raw[pos + 16:pos + 21])
        frames.append((sec + usec * 1e-6, can_id & 0x1FFFFFFF, raw[pos + 24:pos + 24 + n]))
        pos += 16 + incl
    return frames


def test_the_pcap_decodes_with_the_dbc(direct: Path) -> None:
    db = database()
    frames = _pcap_frames(direct / "frames.pcap")
    periods = round(float(DURATION) / 1e-3) + 1
    counts: dict[str, int] = {}
    for _t, can_id, data in frames:
        msg = db.get_message_by_frame_id(can_id)
        msg.decode(data)  # every frame decodes with rrr_bench.dbc (cantools)
        counts[msg.name] = counts.get(msg.name, 0) + 1
    assert counts["VoltageCmd"] == periods and counts["JointState1"] == periods
    assert counts["PlantStatus"] == periods and counts["Sync"] == periods - 1
    assert counts["StopCmd"] == 1
    # fmucontainer's own converter, datalog2pcap, writes the first operation of each value only
    from fmu_manipulation_toolbox.cli.datalog2pcap import DatalogConverter

    log = direct / "rrr_bench_can-datalog.csv"
    DatalogConverter(log).convert()
    theirs = _pcap_frames(log.with_suffix(".pcap"))
    assert 0 < len(theirs) < len(frames)
    for _t, can_id, data in theirs:
        db.get_message_by_frame_id(can_id).decode(data)


@pytest.fixture(scope="module", params=[1_000_000, 250_000])
def bus_run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory,
            ) -> tuple[int, dict[str, Any]]:
    out = tmp_path_factory.mktemp("bus") / str(request.param)
    rc = main(["ls-bus", "--bus-sim", "--bitrate", str(request.param), "--duration", DURATION,
               "--out", str(out), "-q", "--no-figures"])
    return rc, _summary(out)


def test_the_bus_simulation_states_what_it_did_to_the_frames(
        bus_run: tuple[int, dict[str, Any]]) -> None:
    rc, s = bus_run
    ls = s["ls_bus"]
    assert ls["link"].startswith("bus simulation") and ls["bitrate"] in (1_000_000, 250_000)
    for key in ("controller_to_plant", "plant_to_controller"):
        d = ls[key]
        assert d["sent"] > 0 and d["delivered"] + d["lost"] + d["in_flight_at_end"] == d["sent"]
        assert d["delay_mean_s"] > 0.0 and d["delay_max_s"] >= d["delay_mean_s"]
    load = s["bus"]["load"]
    assert load["bitrate"] == ls["bitrate"]  # the loads of the simulated bus
    if ls["bitrate"] == 1_000_000:
        # a period's frames fit: each arrives within the period it was sent in or the next
        assert rc == 0 and s["faults"]["faults"] == 0
        assert ls["plant_to_controller"]["delay_max_s"] < 1e-3
        assert load["measured_percent"] < 100.0
    else:
        # they do not fit into 1 ms at 250 kbit/s: the queue grows, states arrive ever later,
        # the bus drops frames, the plant times out: a completed run, status 7 (safety policy)
        d = ls["plant_to_controller"]
        assert d["delayed_to_a_later_period"] > 0 and d["delay_max_s"] > 2e-3
        assert d["lost"] > 0 and load["measured_percent"] > 100.0
        assert rc == 7 and s["faults"]["faults"] > 0 and s["plant_exit"] == 7


def test_bitrate_needs_the_bus_simulation(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                          ) -> None:
    assert main(["ls-bus", "--bitrate", "250000", "--out", str(tmp_path / "x")]) == 2
    assert "--bus-sim" in capsys.readouterr().err
    assert main(["ls-bus", "--bus-sim", "--bitrate", "5000", "--out", str(tmp_path / "x")]) == 2
    assert "10000 to 1000000" in capsys.readouterr().err
