"""can/: the CAN bench (its C nodes, the Python sides, results, faults, bus load), CANopen (the
drives, their conformance suite, the masters, real time), and the bench over SocketCAN in the
QEMU guest (can_guest.py, the one harness: a guest booted once per session, the ``guest``
fixture below). Markers ``slow`` and ``bus``; ``vm`` for the cases over the socketcan transport
(the ``transport`` parameter's marks) and those that use the ``guest`` fixture."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from can_guest import CanGuest, GuestUnavailable, default_shares
from support.markers import folder_markers


def _uses_the_guest(item: pytest.Item) -> list[str]:
    return ["vm"] if "guest" in getattr(item, "fixturenames", ()) else []


pytest_ignore_collect = folder_markers(__file__, "slow", "bus", maybe=("vm",),
                                       of_item=_uses_the_guest)



@pytest.fixture(scope="session")
def tmp_checkout() -> Iterator[Path]:
    """A checkout under /tmp (where the guest has a tmpfs of its own), a blank in its name: a
    script that reads a file beside it, and a virtual environment (``python -m venv``) whose
    python links to this interpreter's."""
    tree = Path(tempfile.mkdtemp(prefix="rrr guest checkout ", dir="/tmp"))
    try:
        (tree / "tools").mkdir()
        (tree / "tools" / "probe.py").write_text(
            "import pathlib, sys\nprint(sys.prefix)\n"
            "print((pathlib.Path(__file__).parent / 'data.txt').read_text().strip())\n")
        (tree / "tools" / "data.txt").write_text("read from the checkout\n")
        subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tree / ".venv")],
                       check=True)
        yield tree
    finally:
        shutil.rmtree(tree, ignore_errors=True)


@pytest.fixture(scope="session")
def guest(tmp_path_factory: pytest.TempPathFactory, tmp_checkout: Path) -> Iterator[CanGuest]:
    """The CAN test guest, booted once for the session (a boot costs 5 to 15 s under
    emulation): every case over SocketCAN runs in it, the conformance suite too. It shares this
    checkout, its virtual environment and interpreter, and the checkout under /tmp above."""
    scratch = tmp_path_factory.mktemp("can guest")  # a blank in every path the jobs write to
    shares = [*default_shares(), *default_shares(tmp_checkout, tmp_checkout / ".venv/bin/python")]
    try:  # its life bounds the session's guest cases: an hour, far above what they need
        g = CanGuest(scratch, share=shares, max_seconds=3600).start()
    except GuestUnavailable as exc:  # not a skip: the test command provides all of it
        pytest.fail(f"the SocketCAN guest cannot be booted here: {exc}")
    print(f"guest: kernel {g.kernel_release}, booted in {g.boot_seconds:.1f} s")
    try:
        yield g
    finally:
        g.close()


@pytest.fixture(params=[pytest.param("socketcan", marks=pytest.mark.vm), "socketcand"])
def transport(request: pytest.FixtureRequest) -> str:
    """The transport of a bench case: SocketCAN (vcan0, vcan1) in the guest, or the C
    socketcand server on this machine (TCP on loopback). A test that takes it runs the same
    checks over each (python-can's back2back_test.py shape); over socketcan first, so that the
    socketcand runs a case compares with are made here while the guest runs (the emulator
    takes one CPU)."""
    return str(request.param)
