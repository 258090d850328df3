"""The CAN test guest itself (can_guest.py, the one harness of the cases over SocketCAN): its
interfaces, files, exit statuses and time bounds, a checkout under /tmp seen in it, its refusals.
The guest is the session's (can/conftest.py); the bench cases that run in it are in
test_bench_transports.py."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import pytest
from can_guest import CanGuest, GuestError, Result


def run(guest: CanGuest, command: str, what: str, timeout: float = 120.0) -> Result:
    r = guest.run(command, timeout=timeout)
    print(f"{what}: exit {r.rc}, {r.seconds:.1f} s ({r.guest_seconds:.1f} s in the guest)")
    return r


def test_guest_interfaces(guest: CanGuest) -> None:
    """vcan0 classical (MTU 16), vcan1 CAN FD (MTU 72), both up; the kernel has AF_CAN."""
    r = run(guest, "ip -details -json link show type vcan", "ip link")
    assert r.rc == 0, r.stderr
    links = {link["ifname"]: link for link in json.loads(r.stdout)}
    assert set(links) == {"vcan0", "vcan1"}
    assert links["vcan0"]["mtu"] == 16 and links["vcan1"]["mtu"] == 72
    assert all("UP" in link["flags"] for link in links.values())
    r = run(guest, f"{shlex.quote(sys.executable)} -c 'import socket; socket.socket(socket.PF_CAN, "
            "socket.SOCK_RAW, "
            "socket.CAN_RAW).bind((\"vcan1\",)); print(\"bound\")'", "AF_CAN socket")
    assert (r.rc, r.stdout.strip()) == (0, "bound"), r.stderr


def test_guest_files_status_and_time_bound(guest: CanGuest) -> None:
    """Output and exit status come back, the host tree is read-only, the scratch folder is
    written through, and a job past its timeout is killed (status 137) in time."""
    here = Path(__file__).resolve()
    r = run(guest, f"head -c 3 {shlex.quote(str(here))}; echo err >&2; exit 7", "status")
    assert (r.rc, r.stdout, r.stderr) == (7, '"""', "err\n")
    r = run(guest, f"touch {shlex.quote(str(here.parent / 'guest_was_here'))}", "read-only")
    assert r.rc != 0 and "Read-only file system" in r.stderr
    assert not (here.parent / "guest_was_here").exists()
    target = guest.scratch / "from_guest.txt"
    r = run(guest, f"echo from the guest > {shlex.quote(str(target))}; uname -r", "scratch")
    assert r.rc == 0 and target.read_text() == "from the guest\n"
    assert r.stdout.strip() == guest.kernel_release
    r = run(guest, "sleep 60 & sleep 60; echo never", "timeout", timeout=2)
    assert r.rc == 137 and r.stdout == ""  # killed before the sleep ended
    r = run(guest, "pgrep -c -x -f 'sleep 60' || true", "leftovers")  # killed with the job
    assert r.stdout.strip() == "0"


def test_guest_sees_a_checkout_under_tmp(guest: CanGuest, tmp_checkout: Path) -> None:
    """A checkout under /tmp: its virtual environment's python runs its script by path in the
    guest (the checkout, the venv and the interpreter it links to are there, read-only, at their
    own paths), while the guest's /tmp stays its own and writable."""
    python, probe = tmp_checkout / ".venv" / "bin" / "python", tmp_checkout / "tools" / "probe.py"
    r = run(guest, shlex.join([str(python), str(probe)]), "a checkout under /tmp")
    assert r.rc == 0, r.stderr
    assert r.stdout.splitlines() == [str(tmp_checkout / ".venv"), "read from the checkout"]
    r = run(guest, f"touch {shlex.quote(str(tmp_checkout / 'guest_was_here'))}", "read-only")
    assert r.rc != 0 and "Read-only file system" in r.stderr
    assert not (tmp_checkout / "guest_was_here").exists()
    mine = f"/tmp/{tmp_checkout.name}.guest-own"
    r = run(guest, f"echo own > {shlex.quote(mine)} && cat {shlex.quote(mine)}", "own /tmp")
    assert (r.rc, r.stdout) == (0, "own\n"), r.stderr
    assert not Path(mine).exists()  # on the guest's tmpfs, not here


def test_guest_bad_use(guest: CanGuest, tmp_path: Path) -> None:
    """A scratch path with a newline is refused before anything boots; a stopped guest
    refuses."""
    with pytest.raises(ValueError, match="newline"):
        CanGuest(tmp_path / "a\nb")
    idle = CanGuest(tmp_path / "idle")
    with pytest.raises(GuestError, match="not running"):
        idle.run("true")
