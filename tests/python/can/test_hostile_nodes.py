"""Hostile nodes of the CAN bench (issue 21: N12, N17): a node that dies, freezes, receives a
tampered frame or writes its log on a full disk is one line naming the node at fault, exit 2,
and no partial output. The hostile values, logs and folders of the other commands:
jobs/test_hostile_inputs.py."""

from __future__ import annotations

import os
import shlex
import time
from pathlib import Path
from typing import Any

import pytest
from rrr_robot.cli import main
from rrr_robot.hil.canopen.drives import EXPECTED_MAPPING
from scd_relay import Relay


def _err(capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The lines on stderr that are not log messages."""
    return [x for x in capsys.readouterr().err.strip().splitlines()
            if not x.startswith(("INFO ", "DEBUG "))]


# ---- N12, N17: a node of the CAN bench that dies -----------------------------------------------


#: A node that gets SIGKILL (or SIGSTOP: it freezes) once its --log has grown to 20 kB (about a
#: hundred periods of the thousands of a run, however fast the machine): a watcher started
#: before the node is exec'd in its place (it gives up after 30 s).
_DYING = """#!/bin/sh
log=""; prev=""
for a in "$@"; do [ "$prev" = "--log" ] && log="$a"; prev="$a"; done
me=$$
( i=0
  while [ "$(stat -c %s "$log" 2>/dev/null || echo 0)" -lt 20000 ] && [ $i -lt 3000 ]; do
    sleep 0.01; i=$((i + 1)); done
  [ $i -lt 3000 ] && [ -d /proc/$me ] && kill -{signal} $me ) >/dev/null 2>&1 </dev/null &
exec {node} "$@"
"""


@pytest.fixture
def dying_nodes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    """RRR_HIL_BIN_DIR with the real nodes, one of which is made to die (_DYING; ``signal``
    STOP: to freeze)."""
    from rrr_robot.hil.nodes import node_executable

    real = {w: node_executable(w) for w in ("plant", "controller")}
    folder = tmp_path / "bin"
    folder.mkdir()

    def make(dies: str, signal: str = "KILL") -> None:
        for which, path in real.items():
            node = folder / f"rrr_hil_{which}"
            if which == dies:
                node.write_text(_DYING.format(node=shlex.quote(str(path)), signal=signal))
                node.chmod(0o755)
            else:
                node.symlink_to(path)
        monkeypatch.setenv("RRR_HIL_BIN_DIR", str(folder))
    return make


@pytest.mark.parametrize(("side", "dies"), [("controller", "plant"), ("bench", "controller"),
                                            ("bench", "plant"), ("plant", "controller")])
def test_a_node_that_dies_is_named_with_its_signal_and_log(
        tmp_path: Path, dying_nodes: Any, capsys: pytest.CaptureFixture[str], side: str,
        dies: str) -> None:
    dying_nodes(dies)
    out = tmp_path / "out"
    assert main(["hil", side, "--out", str(out), "-q", "--no-figures"]) == 2
    err = [x for x in _err(capsys) if not x.startswith(("ERROR ", "WARNING "))]
    name = f"rrr_hil_{dies}"
    assert len(err) == 1 and f"the node {name} (pid " in err[0], err
    assert "was killed by SIGKILL; its output is in" in err[0], err
    assert f"{out / name}.failed.log" in err[0]
    # the failure log and nothing that looks like a result
    assert sorted(p.name for p in out.iterdir()) == [f"{name}.failed.log"]


def _children() -> set[int]:
    """The processes whose parent is this one (zombies included: not reaped yet)."""
    mine = str(os.getpid())
    kids = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rpartition(")")[2].split()
        except OSError:
            continue
        if fields[1] == mine:
            kids.add(int(stat.parent.name))
    return kids


@pytest.mark.parametrize(("side", "frozen"), [("bench", "controller"), ("bench", "plant"),
                                              ("canopen", "controller"), ("controller", "plant"),
                                              ("plant", "controller")])
def test_a_frozen_node_is_named_and_the_run_ends_with_nothing_left(
        tmp_path: Path, dying_nodes: Any, capsys: pytest.CaptureFixture[str], side: str,
        frozen: str) -> None:
    """A node that stops answering (SIGSTOP: a deadlock, a stuck call) a hundred periods into a
    30 s run: the other node (or the Python side) ends within its 5 s limit on a silent peer, and
    the parent stops the frozen one and names it, whatever the run's length (before: it waited
    300 s, or 60 s plus 10 ms per period, for the controller alone, and left the plant unreaped;
    the Python plant's side waited 120 s for the controller node). Behaviour, not a
    latency: the run is cut short (exit 2, the frozen node named, nothing left);
    the time it took is printed, never asserted."""
    dying_nodes(frozen, "STOP")
    out = tmp_path / "out"
    before = _children()
    argv = ["hil", side, "--duration", "30", "--out", str(out), "-q", "--no-figures"]
    if side == "canopen":
        argv += ["--master", "c"]
    start = time.monotonic()
    rc = main(argv)
    elapsed = time.monotonic() - start
    err = [x for x in _err(capsys) if not x.startswith(("ERROR ", "WARNING "))]
    name = f"rrr_hil_{frozen}"
    assert rc == 2 and len(err) == 1, err
    assert f"the node {name} (pid " in err[0] and "stopped answering" in err[0], err
    assert "stopped by a signal (SIGSTOP?)" in err[0], err
    print(f"{side}: {name} frozen, the run ended after {elapsed:.1f} s of its 30 s")
    assert _children() <= before  # every node reaped, none left running
    pid = int(err[0].split(f"{name} (pid ")[1].split(")")[0])
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def _through_relay(monkeypatch: pytest.MonkeyPatch, module: Any, frame_id: int, nth: int,
                   how: str) -> list[Relay]:
    """The controller node that ``module`` starts reaches the plant through a Relay."""
    relays: list[Relay] = []
    real = module.start_controller

    def start(ref: Path, *, connect: str = "", **kwargs: Any) -> Any:
        relays.append(Relay(int(connect.rpartition(":")[2]), frame_id, nth, how))
        return real(ref, connect=f"127.0.0.1:{relays[-1].port}", **kwargs)

    monkeypatch.setattr(module, "start_controller", start)
    return relays


#: The length of a drive's TPDO1 by its mapping (bytes).
_TPDO1_BYTES = sum(bits for _, bits in EXPECTED_MAPPING["TPDO1"]) // 8


@pytest.mark.parametrize(("how", "message"), [
    ("twice", "drive 2: two TPDO1 in SYNC 299"),
    ("longer", f"drive 2: TPDO1 of {_TPDO1_BYTES + 1} bytes, {_TPDO1_BYTES} mapped")])
@pytest.mark.parametrize("master", ["c", "python"])
def test_a_tampered_tpdo_ends_the_master_run_naming_the_drive_and_the_frame(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        how: str, message: str, master: str) -> None:
    """The 300th TPDO1 of drive 2 (its answer to SYNC 299) sent twice, or one byte longer, on
    the way to the master: the run ends in that SYNC with exit status 8 and one line naming the
    drive and the frame (before: the C master took the later frame, counted a wrong length and
    ended with 0)."""
    from rrr_robot.hil.canopen import c_master
    from rrr_robot.hil.canopen import master as py_master

    if master == "c":
        relays = _through_relay(monkeypatch, c_master, 0x182, 300, how)
    else:
        relays = []
        real = py_master.open_bus

        def open_bus(interface: str = "socketcand", **kwargs: Any) -> Any:
            relays.append(Relay(kwargs.pop("port"), 0x182, 300, how))
            return real(interface, port=relays[-1].port, **kwargs)

        monkeypatch.setattr(py_master, "open_bus", open_bus)
    out = tmp_path / "out"
    rc = main(["hil", "canopen", "--master", master, "--duration", "1", "--out", str(out), "-q",
               "--no-figures"])
    err = _err(capsys)
    assert relays[0].changed == 1
    assert rc == 8 and len(err) == 1 and message in err[0], err
    if master == "c":  # the node's own line: the period of that SYNC, its exit status
        assert "exit 8 (tampered input) at period 298" in err[0], err
        assert "TPDO" in (out / "rrr_hil_controller.failed.log").read_text()
    assert not (out / "summary.json").exists()


def test_a_tampered_tpdo_ends_the_c_master_run_in_real_time(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same in real time (the C master's clock): it counts the TPDOs of each drive against
    the SYNCs it sent, so the repeated frame ends the run at once, in SYNC 299 or, when the drives'
    answers lag behind the clock, when the count shows it."""
    from rrr_robot.errors import TamperedError
    from rrr_robot.hil.canopen import c_master
    from rrr_robot.hil.canopen.realtime import CanopenRealTime
    from rrr_robot.hil.canopen.results import writing_controller
    from rrr_robot.hil.results import extend_reference

    relays = _through_relay(monkeypatch, c_master, 0x182, 300, "twice")
    w = writing_controller(None, "ctc")
    ref = extend_reference(w.ref, 1.0)
    rt = CanopenRealTime(fifo=0, consumer_ms=2000, rpdo_timeout=255)
    with pytest.raises(TamperedError, match=r"drive 2: two TPDO1 in SYNC (\d+)") as info:
        c_master.run_c_master(ref.t, ref.q, ref.qd, ref.qdd, w.controller_model,
                              w.controller_values, tmp_path, realtime=rt)
    assert relays[0].changed == 1
    sync = int(str(info.value).split("in SYNC ")[1].split(":")[0])
    assert 299 <= sync < ref.t.size


def test_a_repeated_joint_state_ends_the_lockstep_bench(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The DBC controller in lockstep takes one JointState per joint and period: the 300th
    JointState2 (period 299, alive counter 11) sent twice ends the run with exit status 8 naming
    it (before: the later frame was taken, or counted as overtaken, and the run ended with 0)."""
    from rrr_robot.hil.dbc import bench
    from rrr_robot.hil.dbc.protocol import frame_id

    relays = _through_relay(monkeypatch, bench, frame_id("JointState2"), 300, "twice")
    out = tmp_path / "out"
    rc = main(["hil", "bench", "--duration", "1", "--out", str(out), "-q", "--no-figures"])
    err = _err(capsys)
    assert relays[0].changed == 1
    assert rc == 8 and len(err) == 1, err
    assert "joint 2: two JointState2 with alive counter 11 in period 299" in err[0], err
    assert not (out / "summary.json").exists()


@pytest.mark.parametrize("master", ["python", "c"])
def test_a_plant_that_dies_under_a_canopen_master_is_one_line(
        tmp_path: Path, dying_nodes: Any, capsys: pytest.CaptureFixture[str],
        master: str) -> None:
    """The drives' node killed a hundred periods into the run: one line naming it and how it
    ended, exit 2, and nothing of python-can's or canopen's threads (their tracebacks and
    ERROR lines: before, python-can's receive thread printed its traceback, issue 38)."""
    dying_nodes("plant")
    out = tmp_path / "out"
    rc = main(["hil", "canopen", "--master", master, "--duration", "5", "--out", str(out),
               "--no-figures"])
    err = capsys.readouterr().err
    lines = [x for x in err.strip().splitlines() if not x.startswith(("INFO ", "DEBUG "))]
    assert rc == 2 and len(lines) == 1, err
    assert "plant node" in lines[0] or "the node rrr_hil_plant" in lines[0], lines
    assert "SIGKILL" in lines[0], lines
    assert "Traceback" not in err and "Exception in thread" not in err, err


@pytest.mark.parametrize("node", ["controller", "plant"])
def test_a_node_log_on_a_full_disk_ends_the_run_naming_it(tmp_path: Path, node: str) -> None:
    """A node's --log on a full disk (/dev/full: a real write that fails): the node ends with
    exit status 2 naming its log and what to do, never 0 with a log cut short (before: the
    write errors went unchecked and the run ended with 0)."""
    from rrr_robot.errors import HilError
    from rrr_robot.hil.canopen.results import writing_controller
    from rrr_robot.hil.nodes import export_reference, start_controller, start_plant, watch_nodes

    ref = writing_controller(None, "ctc").ref
    n = 300
    csv = export_reference(ref.t[:n], ref.q[:n], ref.qd[:n], ref.qdd[:n], tmp_path / "ref.csv")
    logs = {w: Path("/dev/full") if w == node else tmp_path / f"{w}.csv"
            for w in ("controller", "plant")}
    with start_plant(q0=ref.q[0], log_csv=logs["plant"]) as plant, \
            start_controller(csv, connect=f"127.0.0.1:{plant.port}",
                             log_csv=logs["controller"]) as ctrl:
        with pytest.raises(HilError) as info:
            watch_nodes([ctrl, plant], "the bench failed")
    text = str(info.value)
    assert f"the node rrr_hil_{node} (pid " in text and "exited with status 2" in text, text
    assert ("cannot write the log /dev/full: No space left on device: free space, or write it "
            "elsewhere") in text, text
