"""``rrr writing --engine native`` runs the closed loop in librrr (rr.simulate) and writes the
same tables, to the last digit, as the default co-simulation of the FMUs through FMPy."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from rrr_robot.errors import BadInputError
from rrr_robot.writing.job import WritingJob, run_writing


def _writing(out: Path, *args: str) -> dict:
    result = subprocess.run(
        [sys.executable, "-m", "rrr_robot", "writing", "--out", str(out), "--quiet",
         "--no-figures", "--text", "rr", *args],
        capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    summary: dict = json.loads((out / "summary.json").read_text())
    return summary


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_native_engine_writes_the_fmus_tables_bit_for_bit(tmp_path: Path, fmt: str) -> None:
    fmus = _writing(tmp_path / "fmpy", "--format", fmt)
    native = _writing(tmp_path / "native", "--format", fmt, "--engine", "native")
    assert (fmus["engine"], fmus["fmi_version"]) == ("fmpy", "2.0")
    assert (native["engine"], native["fmi_version"]) == ("native", None)
    assert set(native["scenarios"]) == {"pd", "ctc", "mismatch"} == set(fmus["scenarios"])
    for name in fmus["scenarios"]:
        table = f"{name}.{fmt}"
        assert (tmp_path / "native" / table).read_bytes() == \
            (tmp_path / "fmpy" / table).read_bytes(), table
        for key in ("rms_u_n", "rms_u_c", "tip_error_max", "tip_error_rms"):
            assert native["scenarios"][name][key] == fmus["scenarios"][name][key], (name, key)
    assert native["files"] == fmus["files"]


def test_an_unknown_engine_fails_before_anything_runs(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(BadInputError, match="unknown engine 'fast': one of fmpy, native"):
        run_writing(WritingJob(out=out, engine="fast", figures=False))
    assert not out.exists()
    result = subprocess.run(
        [sys.executable, "-m", "rrr_robot", "writing", "--out", str(out), "--engine", "fast"],
        capture_output=True, text=True, timeout=120,
    )
    assert result.returncode == 2 and "invalid choice: 'fast'" in result.stderr
    assert not out.exists()
