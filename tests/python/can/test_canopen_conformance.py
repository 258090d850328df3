"""The conformance suite of the simulated CiA 402 drives (canopen_conformance.py, listed in
docs/canopen-conformance.md), case by case over each transport (the ``transport`` fixture of
can/conftest.py): the C plant node's socketcand server here (the cases run in this process, one
plant for all, each case from NMT reset node), and SocketCAN (vcan0) in the session's CAN test
guest (can_guest.py: the same harness runs there as a script, once for all cases, and each case
here asserts its result)."""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from can_guest import CanGuest
from canopen_conformance import CASES, PLANT_ARGS, Case, Dut, run_case, table
from rrr_robot.hil.nodes import open_bus, start_plant
from support import REPO

HERE = Path(__file__).resolve().parent
PAGE = REPO / "docs" / "canopen-conformance.md"
#: An answer's timeout in the guest (s): Python runs emulated there, many times slower.
GUEST_TIMEOUT = 10.0


@pytest.fixture(scope="module")
def socketcand_dut() -> Iterator[Dut]:
    with start_plant(extra=PLANT_ARGS) as plant:
        bus = open_bus("socketcand", port=plant.port)
        try:
            yield Dut(bus, timeout=2.0)
        finally:
            bus.shutdown()


@pytest.fixture(scope="module")
def guest_results(guest: CanGuest) -> dict[str, Any]:
    """Every case in the CAN test guest over vcan0, by one run of canopen_conformance.py."""
    out = guest.scratch / "conformance" / "results.json"
    out.parent.mkdir()
    r = guest.run(f"{shlex.quote(sys.executable)} "
                  f"{shlex.quote(str(HERE / 'canopen_conformance.py'))} --socketcan vcan0 "
                  f"--timeout {GUEST_TIMEOUT:g} --out {shlex.quote(str(out))}", timeout=1000)
    print(f"conformance suite in the guest: exit {r.rc}, {r.seconds:.1f} s; "
          f"{r.stdout.strip()[-200:]}")
    assert out.exists(), r.stderr[-3000:]
    results: dict[str, Any] = json.loads(out.read_text())
    return results


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_conformance(case: Case, transport: str, request: pytest.FixtureRequest) -> None:
    if transport == "socketcand":
        run_case(request.getfixturevalue("socketcand_dut"), case)
    else:
        result = request.getfixturevalue("guest_results").get(case.name)
        assert result is not None, f"{case.name} did not run in the guest"
        assert result["ok"], result["detail"]


def test_the_manual_lists_every_case() -> None:
    """docs/canopen-conformance.md has the table of the cases as the suite describes them
    (``canopen_conformance.py --list``): at least 60, each run above over both transports."""
    assert len(CASES) >= 60 and len({c.name for c in CASES}) == len(CASES)
    assert table() in PAGE.read_text()
