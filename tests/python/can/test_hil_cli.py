"""The exit status of `rrr hil plant` reflects its sides': a run whose plant latched a fault
(here: the controller's commands dropped from period 200, so the plant times out and the C
controller's stop arrives out of sequence) exits with the plant's status, a clean run with 0."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from rrr_robot.hil.logs import frames as fl


def run_hil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rrr_robot", "hil", *args], capture_output=True,
                          text=True, timeout=300)


def test_a_failed_side_gives_a_nonzero_exit(tmp_path: Path) -> None:
    ok = run_hil("plant", "--text", "a", "--out", str(tmp_path / "ok"), "--no-figures")
    assert ok.returncode == 0, ok.stderr
    bad = run_hil("plant", "--text", "a", "--drop-commands-from", "200", "--no-figures",
                  "--out", str(tmp_path / "bad"))
    assert bad.returncode == 3, bad.stdout + bad.stderr  # the plant's status: controller lost
    assert "python plant: exit 3" in bad.stdout
    assert "Traceback" not in bad.stderr
    # both runs wrote their results; the failed one says what went wrong
    good = json.loads((tmp_path / "ok" / "summary.json").read_text())
    assert good["side"] == "plant" and good["faults"]["faults"] == 0
    assert good["bench"]["tip_error_max"] < 1e-3
    s = json.loads((tmp_path / "bad" / "summary.json").read_text())
    assert s["plant_exit"] == 3 and s["faults"]["timeout"] == 1 and s["missed_commands"] > 800
    assert s["bench"]["tip_error_max"] > 0.1  # 0 V from period 202 on: the arm fell
    records = fl.read_node_log(tmp_path / "bad" / "frames.rrrcan")
    assert fl.compare(records, fl.read_can_log(tmp_path / "bad" / "frames.blf")) is None


def test_controller_side_writes_results(tmp_path: Path) -> None:
    """The controller FMU (FMPy, python-can) against the C plant node: the plant node's frame
    log (Tx: its frames), the controller log written from Python, the summary."""
    run = run_hil("controller", "--text", "a", "--out", str(tmp_path), "--no-figures", "-q")
    assert run.returncode == 0, run.stderr
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["side"] == "controller" and s["faults"]["faults"] == 0
    assert max(s["difference_to_unquantised"]["q_max_abs"]) < 1e-5
    records = fl.read_node_log(tmp_path / "frames.rrrcan")
    tx = records[records["dir"] == 1]
    assert set(int(i) for i in tx["id"]) == {0x201, 0x202, 0x203, 0x300, 0x702}
    assert fl.compare(records, fl.read_can_log(tmp_path / "frames.blf")) is None


def test_nodes_refuse_fd_without_socketcan(tmp_path: Path) -> None:
    """--fd on a C node over socketcand (--connect, --listen): exit 2 (setup) before anything
    connects or listens, with the reason: the socketcand protocol carries classical frames."""
    import numpy as np
    from rrr_robot.hil.nodes import export_reference, node_executable

    t = np.arange(3) * 1e-3
    z = np.zeros((3, 3))
    ref = export_reference(t, z, z, z, tmp_path / "reference.csv")
    for link in (["--connect", "127.0.0.1:9"], ["--listen", "127.0.0.1:0"]):
        r = subprocess.run([str(node_executable("controller")), "--reference", str(ref), *link,
                            "--fd"], capture_output=True, text=True, timeout=60)
        assert r.returncode == 2, (link, r.stdout, r.stderr)
        assert ("rrr_hil_controller: --fd needs --socketcan IF: the socketcand protocol carries "
                "classical CAN frames only") in r.stderr
        assert "listening" not in r.stdout
