"""Generated code is reproducible: regenerating the dynamics from the SymPy derivation gives the
committed C files byte for byte."""

from __future__ import annotations

import subprocess
import sys

from support import REPO

ROOT = REPO


def test_regenerating_dynamics_gives_committed_files() -> None:
    script = ROOT / "c_src" / "rrr" / "gen" / "derive_dynamics.py"
    result = subprocess.run(
        [sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_regenerating_the_hil_log_header_gives_the_committed_file() -> None:
    """c_src/hil/nodes/gen/rrr_hil_logs.h (the C nodes' CSV log headers) is tools/gen_hil_logs.py's
    output from rrr_robot.hil.logs.specs, byte for byte."""
    script = ROOT / "tools" / "gen_hil_logs.py"
    result = subprocess.run([sys.executable, str(script), "--check"], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
