"""The C nodes on PATH after ``pip install``: ``rrr_hil_plant`` and ``rrr_hil_controller`` in the
venv's bin (pyproject.toml's [project.scripts], rrr_robot.cli.nodes) exec the packaged binaries
with the same arguments: their help, their exit status and their signal handling are the
nodes' own, in the same process."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.cli.nodes import BIN_DIR
from rrr_robot.hil.nodes import export_reference

BIN = Path(sys.executable).parent


@pytest.mark.parametrize("name", ["rrr_hil_plant", "rrr_hil_controller"])
def test_help_and_exit_status_are_the_nodes(name: str) -> None:
    launcher = BIN / name
    assert launcher.exists(), f"{launcher}: not installed by pip install ."
    helped = subprocess.run([str(launcher), "--help"], capture_output=True, text=True,
                            timeout=60)
    assert helped.returncode == 0, helped.stderr
    assert f"usage: {name} " in helped.stdout + helped.stderr
    # an unknown option: the node's usage error, status 1, as the binary itself gives it
    direct = subprocess.run([str(BIN_DIR / name), "--bogus"],
                            capture_output=True, text=True, timeout=60)
    launched = subprocess.run([str(launcher), "--bogus"], capture_output=True, text=True,
                              timeout=60)
    assert launched.returncode == direct.returncode == 1
    assert launched.stderr == direct.stderr and "--bogus" in launched.stderr


def test_the_launcher_becomes_the_node(tmp_path: Path) -> None:
    """The launcher's process is the node (exec): its executable is the packaged binary, and
    SIGTERM reaches the node's handler (exit 4, interrupted), not Python's."""
    t = np.arange(3) * 1e-3
    z = np.zeros((3, 3))
    ref = export_reference(t, z, z, z, tmp_path / "reference.csv")
    proc = subprocess.Popen([str(BIN / "rrr_hil_controller"), "--reference", str(ref),
                             "--listen", "127.0.0.1:0"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # the node says where it listens, then waits for a client
        assert "listening" in line, line + proc.stderr.read() if proc.stderr else line
        assert Path(os.readlink(f"/proc/{proc.pid}/exe")) == BIN_DIR / "rrr_hil_controller"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 4, err
    assert "Traceback" not in err
