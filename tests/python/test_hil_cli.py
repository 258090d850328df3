"""The exit status of `rrr hil plant` reflects its sides': a run whose plant latched a fault
(here: the controller's commands dropped from period 200, so the plant times out and the C
controller's stop arrives out of sequence) exits with the plant's status, a clean run with 0."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def run_hil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rrr_robot", "hil", *args], capture_output=True,
                          text=True, timeout=300)


def test_a_failed_side_gives_a_nonzero_exit(tmp_path: Path) -> None:
    ok = run_hil("plant", "--text", "a", "--out", str(tmp_path / "ok"))
    assert ok.returncode == 0, ok.stderr
    bad = run_hil("plant", "--text", "a", "--drop-commands-from", "200",
                  "--out", str(tmp_path / "bad"))
    assert bad.returncode == 3, bad.stdout + bad.stderr  # the plant's status: controller lost
    assert "python plant: exit 3" in bad.stdout
    assert "Traceback" not in bad.stderr
