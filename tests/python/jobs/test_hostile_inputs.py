"""Hostile values, logs and folders (issue 21: N13, N15, N19, the typed errors of the API and
--scale): each is one line naming the option or file at fault, exit 2, and no partial output.
The nodes of the CAN bench that die, freeze or receive tampered frames (N12, N17):
can/test_hostile_nodes.py."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.cli import main
from rrr_robot.core import outputs
from rrr_robot.core.outputs import ResultSet, folder_lock, make_folders
from rrr_robot.identify import logs


def _err(capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The lines on stderr that are not log messages."""
    return [x for x in capsys.readouterr().err.strip().splitlines()
            if not x.startswith(("INFO ", "DEBUG "))]


# ---- N19: identification logs ------------------------------------------------------------------


def _log(path: Path, n: int, comments: int = 0) -> Path:
    t = np.arange(n) * 1e-3
    rows = np.column_stack([t, np.sin(t), np.cos(t), t, 0.1 * t, -t, 2 * t])
    with path.open("w") as fh:
        fh.write("# a log\nt,q[1],q[2],q[3],u[1],u[2],u[3],extra\n")
        for k, r in enumerate(rows):
            if comments and k % (n // comments) == 0:
                fh.write("# a comment between rows\n")
            fh.write(",".join(f"{v:.17g}" for v in r) + ",7\n")
    return path


def test_a_log_is_read_in_blocks_as_a_whole_read_would(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    path = _log(tmp_path / "a.csv", 1000, comments=7)
    whole = logs.read_log(path)
    monkeypatch.setattr(logs, "_BLOCK_ROWS", 64)
    blocks = logs.read_log(path)
    assert np.array_equal(whole.t, blocks.t) and np.array_equal(whole.q, blocks.q)
    assert np.array_equal(whole.u, blocks.u) and len(blocks) == 1000


@pytest.mark.parametrize(("bound", "value", "message"), [
    ("MAX_LOG_ROWS", 500, "has more than 500 data rows"),
    ("MAX_LOG_BYTES", 10_000, "bytes: at most 10,000"),
])
def test_a_log_beyond_its_bounds_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str], bound: str,
                                            value: int, message: str) -> None:
    path = _log(tmp_path / "big.csv", 800)
    monkeypatch.setattr(logs, bound, value)
    monkeypatch.setattr(logs, "_BLOCK_ROWS", 100)
    out = tmp_path / "robot.toml"
    assert main(["identify", "--log", str(path), "--out", str(out), "-q"]) == 2
    err = _err(capsys)
    assert len(err) == 1 and message in err[0] and str(path) in err[0], err
    assert not out.exists()


def test_a_log_line_without_end_is_refused(tmp_path: Path) -> None:
    path = _log(tmp_path / "a.csv", 300)
    with path.open("a") as fh:
        fh.write("1" * 70_000)
    with pytest.raises(rr.BadInputError, match="line 303 is longer than 65,536 characters"):
        logs.read_log(path)


# ---- typed errors of the API -------------------------------------------------------------------

_INERTIA = [np.eye(3) * 0.01] * 3


@pytest.mark.parametrize(("call", "message"), [
    (lambda: rr.Model.default().with_params(p=["a"] * 16), r"^p must be finite numbers"),
    (lambda: rr.Model.default().with_params(kt=[1.0, float("nan"), 1.0]),
     r"^kt must be finite numbers"),
    (lambda: rr.Model.default().with_params(f=[[1, 2, 3]] * 2), r"^f must have shape \(3, 3\)"),
    (lambda: rr.bps_from_inertia({"a2": "x", "a3": 0.3}, [1, 1, 1], np.zeros((3, 3)),
                                 _INERTIA, [0, 0, 0]), r"^dh\['a2'\] must be a finite number"),
    (lambda: rr.bps_from_inertia({"a4": 1.0}, [1, 1, 1], np.zeros((3, 3)), _INERTIA,
                                 [0, 0, 0]), r"^dh\['a4'\] is no DH length"),
    (lambda: rr.bps_from_inertia({}, ["m", 1, 1], np.zeros((3, 3)), _INERTIA, [0, 0, 0]),
     r"^masses must be finite numbers"),
    (lambda: rr.bps_from_inertia({}, [1, 1, 1], np.zeros((3, 3)), _INERTIA, [0, np.inf, 0]),
     r"^rotor_inertia must be finite numbers"),
])
def test_api_values_get_the_typed_error_naming_the_parameter(call: Any, message: str) -> None:
    with pytest.raises(rr.BadInputError, match=message):
        call()


# ---- rrr writing: --scale, --animate, one folder for two runs ----------------------------------


@pytest.mark.parametrize(("scale", "message"), [
    ("-3", "the letter scale (--scale) must be a finite number > 0, got -3.0"),
    ("1e-3", "--scale 0.001 gives letters 0.07 mm high: the usable range of --scale is 0.143 "
             "to 1.11 for this text"),
])
def test_scale_is_named_with_its_usable_range(tmp_path: Path, scale: str,
                                              capsys: pytest.CaptureFixture[str],
                                              message: str) -> None:
    out = tmp_path / "out"
    assert main(["writing", "--scale", scale, "--out", str(out), "--engine", "native",
                 "--no-figures", "-q"]) == 2
    err = _err(capsys)
    assert len(err) == 1 and message in err[0] and "WritingSpec" not in err[0], err
    assert not out.exists()


def test_an_animation_too_long_is_refused_before_anything_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    import rrr_robot.writing.job as job

    runs: list[str] = []
    monkeypatch.setattr(job, "run_engine", lambda engine, *args: runs.append(engine))
    out = tmp_path / "out"
    assert main(["writing", "--animate", "gif", "--fps", "1000", "--out", str(out),
                 "--engine", "native", "--no-figures", "-q"]) == 2
    assert runs == []  # no co-simulation ran
    err = _err(capsys)
    assert len(err) == 1 and "at most 3000; lower --fps to 507 or less" in err[0], err
    assert not out.exists()
    with pytest.raises(SystemExit) as exc:  # argparse's own one-line error
        main(["writing", "--fps", "0", "--out", str(out)])
    assert exc.value.code == 2 and "--fps" in capsys.readouterr().err


def test_folders_are_made_race_free(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Another process creates the folder between our check and our mkdir: we go on."""
    real = Path.mkdir

    def raced(self: Path, *args: Any, **kwargs: Any) -> None:
        real(self, *args, **kwargs)  # the other process was first
        raise FileExistsError(17, "File exists", str(self))

    monkeypatch.setattr(Path, "mkdir", raced)
    target = tmp_path / "a" / "b"
    assert make_folders(target) == []  # created by "the other process", not by us
    assert target.is_dir()
    monkeypatch.setattr(Path, "mkdir", real)
    (tmp_path / "file").write_text("x")
    with pytest.raises(rr.BadInputError, match="cannot create the output folder"):
        make_folders(tmp_path / "file" / "sub")


def test_commits_into_one_folder_take_turns(tmp_path: Path) -> None:
    out = tmp_path / "out"
    rs = ResultSet(out, kind="writing").open()
    rs.write_text("a.csv", "1\n")
    rs.write_text("summary.json", "{}\n")
    done = threading.Event()
    with folder_lock(out, "commit"):  # another run's commit
        worker = threading.Thread(target=lambda: (rs.commit(), done.set()))
        worker.start()
        time.sleep(0.3)
        assert not done.is_set() and not (out / "summary.json").exists()
    worker.join(10)
    assert done.is_set() and (out / "summary.json").read_text() == "{}\n"
    assert sorted(p.name for p in out.iterdir()) == [".rrr-results-writing.json", "a.csv",
                                                     "summary.json"]
    assert outputs.LOCK_PREFIX == ".rrr-lock-"


def test_two_writing_runs_at_once_into_one_new_folder(tmp_path: Path) -> None:
    """N15: both runs succeed; the folder holds one run's files whole."""
    out = tmp_path / "new" / "out"
    cmd = [sys.executable, "-m", "rrr_robot", "writing", "--text", "l", "--scenario", "ctc",
           "--engine", "native", "--no-figures", "-q", "--out", str(out)]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    results = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], results
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == \
        summary["files"]
    assert [p.name for p in out.iterdir() if p.name.startswith(".rrr-")] == [
        ".rrr-results-writing.json"]
