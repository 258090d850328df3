"""Outputs a user can trust (rrr_robot.core.outputs): every file appears complete or not at all,
the files of a run appear together or not at all, an interrupted or killed run leaves the
previous results as they were (its leftovers are hidden, recognisable and cleaned at the next
run), and summary.json is strict JSON (a non-finite metric is null with a status)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.cli import main
from rrr_robot.core import outputs, tables
from rrr_robot.core.outputs import (
    ResultSet,
    atomic_open,
    atomic_path,
    atomic_write_text,
    check_folder,
    clean_stale,
    is_temporary,
    strict_json,
)
from rrr_robot.errors import OutputError
from rrr_robot.sim.cosim import CosimResult
from rrr_robot.writing import job as job_module
from rrr_robot.writing.job import WritingJob, run_writing, scenario_summary
from support import default_signals


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) with its content."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def leftovers(folder: Path) -> list[str]:
    """Temporary files and staging folders (not the manifests, which belong to the results)."""
    return sorted(p.name for p in folder.iterdir()
                  if p.name.startswith((outputs.TEMP_PREFIX, outputs.STAGING_PREFIX)))


def strict_loads(text: str) -> Any:
    """json.loads that refuses NaN, Infinity and -Infinity (as a strict parser does)."""
    def refuse(token: str) -> None:
        raise ValueError(f"not strict JSON: {token}")

    return json.loads(text, parse_constant=refuse)


# ---- single files -----------------------------------------------------------------------------


def test_atomic_write_gives_the_whole_file_with_default_permissions(tmp_path: Path) -> None:
    target = tmp_path / "a.json"
    atomic_write_text(target, "one")
    atomic_write_text(target, "two")
    assert target.read_text() == "two"
    assert os.listdir(tmp_path) == ["a.json"]
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt, OSError])
def test_a_failure_while_writing_keeps_the_old_file(tmp_path: Path,
                                                    error: type[BaseException]) -> None:
    target = tmp_path / "log.csv"
    target.write_text("old,complete\n")
    with pytest.raises(error), atomic_open(target, newline="") as fh:
        fh.write("new,")
        assert list(tmp_path.glob("*.csv")) == [target]  # the half file never looks like one
        raise error("interrupted")
    assert target.read_text() == "old,complete\n"
    assert os.listdir(tmp_path) == ["log.csv"]


def test_a_failed_rename_keeps_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            ) -> None:
    target = tmp_path / "a.txt"
    target.write_text("old")

    def refuse(src: object, dst: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(outputs.os, "replace", refuse)
    with pytest.raises(OSError, match="No space"):
        atomic_write_text(target, "new")
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["a.txt"]


# ---- a write that fails names what it was writing ------------------------------------------


_FULL = "No space left on device; free space on its file system, or write the results elsewhere"


def test_a_full_disk_names_the_file_and_what_to_do(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """An atomic write whose data meets a full disk (a real write to /dev/full: the kernel's
    ENOSPC at the flush): the error names the file, not the temporary name, and what to do; the
    old file stays (before: "[Errno 28] No space left on device" and nothing else)."""
    import builtins

    target = tmp_path / "ctc.csv"
    target.write_text("old")
    monkeypatch.setattr(outputs, "open", lambda path, *a, **kw: builtins.open("/dev/full", *a,
                                                                               **kw),
                        raising=False)
    with pytest.raises(OutputError) as info:
        atomic_write_text(target, "t,q\n" * 10000)
    assert str(info.value) == f"cannot write {target}: {_FULL} (--out)"
    assert isinstance(info.value, OSError) and info.value.errno == 28
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["ctc.csv"]


@pytest.mark.parametrize("where", ["reserve", "fsync", "rename"])
def test_every_step_of_an_atomic_write_names_the_file(tmp_path: Path, where: str,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    def full(*args: Any, **kwargs: Any) -> None:
        raise OSError(28, "No space left on device")

    name = {"reserve": "_reserve", "fsync": "_fsync_file", "rename": "replace"}[where]
    monkeypatch.setattr(outputs.os if where == "rename" else outputs, name, full)
    with pytest.raises(OSError, match=f"^cannot write {tmp_path / 'a.json'}: No space"):
        atomic_write_text(tmp_path / "a.json", "{}")
    assert os.listdir(tmp_path) == []


def test_a_full_disk_in_a_result_set_names_the_output_folder_or_its_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A result written into the result set's hidden staging folder is named as the output
    folder's file; the commit's failure names the output folder."""
    out = tmp_path / "out"
    with pytest.raises(OutputError, match=f"^cannot write {out / 'fig.png'}: No space"), \
            ResultSet(out, kind="writing") as rs:
        raise OSError(28, "No space left on device", str(rs.path("fig.png")))
    with pytest.raises(OutputError, match=f"^cannot write {out}: No space"), \
            ResultSet(out, kind="writing"):
        raise OSError(28, "No space left on device")

    def read_only(src: Any, dst: Any) -> None:
        raise OSError(30, "Read-only file system")

    with pytest.raises(OutputError, match=f"^cannot write {out}: Read-only file system; its "
                       "file system is read-only"):
        with ResultSet(out, kind="writing") as rs:
            rs.write_text("a.txt", "x")
            monkeypatch.setattr(outputs.os, "replace", read_only)
    monkeypatch.undo()
    # an OSError that is not a failed write (an input not found) stays as it was
    with pytest.raises(FileNotFoundError), ResultSet(out, kind="writing"):
        Path(tmp_path / "missing.csv").read_text()


def test_rrr_writing_on_a_full_disk_is_one_line_naming_the_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import builtins

    monkeypatch.setattr(outputs, "open", lambda path, *a, **kw: builtins.open("/dev/full", *a,
                                                                               **kw),
                        raising=False)
    out = tmp_path / "out"
    rc = main(["-q", "writing", "--scenario", "pd", "--engine", "native", "--no-figures",
               "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == [f"rrr: error: cannot write {out / 'pd.csv'}: {_FULL} (--out)"]


def test_temporary_names_are_hidden_and_never_end_like_results(tmp_path: Path) -> None:
    with atomic_path(tmp_path / "ctc.csv") as tmp:
        assert tmp.parent == tmp_path  # the rename never crosses a file system
        assert tmp.name.startswith(".") and not tmp.name.endswith(".csv")
        assert is_temporary(tmp)
        tmp.write_text("x")
    assert not is_temporary(tmp_path / "ctc.csv")
    assert (tmp_path / "ctc.csv").read_text() == "x"


def test_cosim_csv_interrupted_midway_is_not_left_truncated(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Before: CosimResult.to_csv wrote into the result's own name, so an interruption left a
    shorter ctc.csv with a valid header and whole rows, which looks complete."""
    target = tmp_path / "ctc.csv"
    target.write_text("previous run\n")

    real_open = tables.atomic_open

    class FailingFile:
        """Lets the header and the first block of rows through, then Ctrl-C."""

        def __init__(self, fh: Any) -> None:
            self.fh, self.writes = fh, 0

        def write(self, text: str) -> int:
            self.writes += 1
            if self.writes > 2:
                raise KeyboardInterrupt
            return int(self.fh.write(text))

    @contextlib.contextmanager
    def failing_open(*args: Any, **kwargs: Any) -> Iterator[FailingFile]:
        with real_open(*args, **kwargs) as fh:
            yield FailingFile(fh)

    monkeypatch.setattr(tables, "_BLOCK_ROWS", 10)
    monkeypatch.setattr(tables, "atomic_open", failing_open)
    with pytest.raises(KeyboardInterrupt):
        fake_result(np.arange(100) * 1e-3).to_csv(target)
    assert target.read_text() == "previous run\n"
    assert os.listdir(tmp_path) == ["ctc.csv"]


def test_strict_json_writes_null_for_non_finite_numbers() -> None:
    value = {"a": float("nan"), "b": [1.5, float("inf"), -float("inf")], "c": (True, None, "x"),
             "d": {"e": 2}}
    text = strict_json(value)
    assert strict_loads(text) == {"a": None, "b": [1.5, None, None], "c": [True, None, "x"],
                                  "d": {"e": 2}}
    with pytest.raises(TypeError):
        strict_json({"a": object()})


# ---- result sets ------------------------------------------------------------------------------


def write_run(folder: Path, files: dict[str, str], kind: str = "writing") -> None:
    with ResultSet(folder, kind=kind) as rs:
        for name, text in files.items():
            rs.write_text(name, text)


def test_a_result_set_appears_at_the_end_summary_last(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    write_run(out, {"pd.csv": "old pd", "summary.json": "old"})
    before = snapshot(out)
    order: list[str] = []
    real_replace = os.replace

    def record(src: Any, dst: Any) -> None:
        order.append(Path(dst).name)
        real_replace(src, dst)

    with ResultSet(out, kind="writing") as rs:
        rs.write_text("summary.json", "new")
        rs.write_text("pd.csv", "new pd")
        during = {k: v for k, v in snapshot(out).items() if not k.startswith(".rrr-staging-")}
        assert during == before  # nothing of the run is visible before its end
        monkeypatch.setattr(outputs.os, "replace", record)
    results = [n for n in order if not n.startswith(".")]
    assert results == ["pd.csv", "summary.json"]
    assert (out / "pd.csv").read_text() == "new pd" and (out / "summary.json").read_text() == "new"
    assert leftovers(out) == []


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt, SystemExit])
def test_a_failed_run_leaves_the_previous_results(tmp_path: Path,
                                                  error: type[BaseException]) -> None:
    out = tmp_path / "out"
    write_run(out, {"pd.csv": "old pd", "ctc.csv": "old ctc", "summary.json": "old"})
    before = snapshot(out)
    with pytest.raises(error), ResultSet(out, kind="writing") as rs:
        rs.write_text("pd.csv", "new pd")  # the first file of the run, then the failure
        raise error()
    assert snapshot(out) == before
    assert leftovers(out) == []


def test_a_failed_run_removes_the_folders_it_created(tmp_path: Path) -> None:
    with pytest.raises(KeyboardInterrupt), ResultSet(tmp_path / "a" / "b", kind="writing") as rs:
        rs.write_text("pd.csv", "x")
        raise KeyboardInterrupt
    assert os.listdir(tmp_path) == []


def test_files_of_the_previous_run_of_the_kind_go_others_stay(tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_run(out, {"pd.csv": "1", "ctc.csv": "1", "summary.json": "1"})
    write_run(out, {"plant.csv": "hil"}, kind="hil")
    (out / "notes.txt").write_text("the user's")
    write_run(out, {"ctc.csv": "2", "summary.json": "2"})  # fewer scenarios than before
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "ctc.csv", "notes.txt", "plant.csv", "summary.json"]
    manifest = strict_loads((out / ".rrr-results-writing.json").read_text())
    assert manifest == {"kind": "writing", "files": ["ctc.csv", "summary.json"]}


def test_result_names_are_plain_file_names(tmp_path: Path) -> None:
    with ResultSet(tmp_path, kind="writing") as rs:
        for bad in ["../evil.csv", "a/b.csv", ".hidden", "", "..", ".rrr-results-writing.json"]:
            with pytest.raises(rr.BadInputError, match="cannot name an output file"):
                rs.path(bad)
    assert os.listdir(tmp_path) == []


def test_an_output_folder_that_cannot_be_one(tmp_path: Path) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("keep")
    for folder in (blocker, blocker / "sub"):
        with pytest.raises(rr.BadInputError, match="output folder"):
            check_folder(folder)
        with pytest.raises(rr.BadInputError, match="output folder"):
            ResultSet(folder, kind="writing").open()
    assert blocker.read_text() == "keep" and os.listdir(tmp_path) == ["a_file"]


KILLED_RUN = textwrap.dedent("""
    import os, signal, sys
    from pathlib import Path
    from rrr_robot.core import outputs, tables
    from rrr_robot.core.outputs import ResultSet
    out, when = Path(sys.argv[1]), sys.argv[2]
    rs = ResultSet(out, kind="writing").open()
    rs.write_text("pd.csv", "new pd")
    rs.write_text("summary.json", "new")
    if when == "run":
        with outputs.atomic_open(rs.path("ctc.csv")) as fh:  # killed while writing a file
            fh.write("new ct")
            os.kill(os.getpid(), signal.SIGKILL)
    real_replace, moved = os.replace, []
    def replace(src, dst):
        real_replace(src, dst)
        if Path(src).parent == rs.staging and Path(dst).parent == out:
            moved.append(dst)
            os.kill(os.getpid(), signal.SIGKILL)  # killed after the first file is in place
    outputs.os.replace = replace
    rs.commit()
""")


def killed_run(out: Path, when: str) -> None:
    proc = subprocess.run([sys.executable, "-c", KILLED_RUN, str(out), when],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == -signal.SIGKILL, proc.stderr


def test_a_killed_run_leaves_hidden_leftovers_that_the_next_run_removes(tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_run(out, {"pd.csv": "old pd", "summary.json": "old"})
    before = snapshot(out)
    killed_run(out, "run")
    left = leftovers(out)
    assert len(left) == 1 and is_temporary(left[0])  # the staging folder, hidden
    results = {k: v for k, v in snapshot(out).items() if not k.startswith(".rrr-staging-")}
    assert results == before  # the previous results as they were
    assert list(out.glob("*.csv")) == [out / "pd.csv"]
    write_run(out, {"pd.csv": "newer pd", "summary.json": "newer"})  # the next run cleans
    assert leftovers(out) == []
    assert (out / "summary.json").read_text() == "newer"


def test_a_run_killed_during_its_commit_is_finished_by_the_next(tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_run(out, {"pd.csv": "old pd", "ctc.csv": "old ctc", "summary.json": "old"})
    killed_run(out, "commit")
    # killed after the first rename: the old summary.json is gone (removed first), so nothing
    # describes a mix of old and new files
    assert (out / "pd.csv").read_text() == "new pd"
    assert not (out / "summary.json").exists()
    assert clean_stale(out)  # what the next run does first: finishes the commit
    assert leftovers(out) == []
    assert (out / "summary.json").read_text() == "new"
    assert not (out / "ctc.csv").exists()  # the killed run did not write it: not its result


def test_leftovers_of_a_running_process_are_not_touched(tmp_path: Path) -> None:
    with ResultSet(tmp_path, kind="writing") as rs:
        rs.write_text("pd.csv", "x")
        assert clean_stale(tmp_path) == []  # this process is still writing
        assert (rs.staging / "pd.csv").exists()
    stale = tmp_path / f"{outputs.TEMP_PREFIX}{os.getpid()}-0badcafe-ctc.csv.part"
    stale.write_text("left by an earlier process with our pid (a container's pid 1)")
    assert clean_stale(tmp_path) == [stale] and not stale.exists()


# ---- the writing task -------------------------------------------------------------------------


def fake_result(t: np.ndarray, x_ref: np.ndarray | None = None, tip_error: float = 1e-4,
                wall_time: float = 0.01) -> CosimResult:
    n = t.shape[0]
    x = np.zeros((n, 3)) if x_ref is None else x_ref
    z = np.zeros((n, 3))
    return CosimResult(t=t, q_ref=z, qd_ref=z, x_ref=x, q=z, qd=z, qdd=z, tip=x + tip_error,
                       u=z, u_n=z + 0.5, u_c=z + 0.1, wall_time=wall_time)


def fake_cosim(monkeypatch: pytest.MonkeyPatch, tip_errors: dict[str, float] | None = None,
               wall_times: dict[str, float] | None = None,
               fail_at: int | None = None) -> list[str]:
    """run_cosim replaced by a fast fake (scenario recognised by the call order); fail_at: the
    call that raises KeyboardInterrupt (Ctrl-C in the middle of the run)."""
    calls: list[str] = []

    def run(t: Any, q: Any, qd: Any, qdd: Any, x: Any, options: Any) -> CosimResult:
        name = ["pd", "ctc", "mismatch"][len(calls)]
        calls.append(name)
        if fail_at is not None and len(calls) == fail_at:
            raise KeyboardInterrupt
        return fake_result(t, x, (tip_errors or {}).get(name, 1e-4),
                           (wall_times or {}).get(name, 0.01))

    monkeypatch.setattr(job_module, "run_cosim", run)
    return calls


def writing_job(out: Path, figures: bool = False) -> WritingJob:
    return WritingJob(out=out, text="a", scenarios=["pd", "ctc", "mismatch"], figures=figures)


def skip_numeric_figures(monkeypatch: pytest.MonkeyPatch) -> None:
    """Figs 5 and 6 need the numeric IK and Pinocchio: slow, and not what is tested here."""
    from rrr_robot.writing import plots

    monkeypatch.setattr(plots, "fig_differences", lambda *args: None)


@pytest.mark.parametrize("where", ["cosim", "csv", "figure", "summary"])
def test_an_interrupted_writing_run_leaves_the_previous_results(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str) -> None:
    """Ctrl-C after the first scenario's CSV (or in the figures, or while writing summary.json):
    the folder keeps the previous run's files exactly, with no file of the new run. Before,
    run_writing wrote into the folder as it went, so pd.csv was new and summary.json old."""
    out = tmp_path / "out"
    skip_numeric_figures(monkeypatch)
    fake_cosim(monkeypatch, tip_errors={"pd": 0.02})
    run_writing(writing_job(out, figures=True))
    before = snapshot(out)
    assert "fig8_letters_ctc.png" in before and "pd.csv" in before

    fake_cosim(monkeypatch, tip_errors={"pd": 0.03}, fail_at=2 if where == "cosim" else None)
    if where == "csv":
        real_write = CosimResult.write
        written: list[Path] = []

        def write(self: CosimResult, path: Path, fmt: str = "csv") -> None:
            if written:
                raise KeyboardInterrupt
            real_write(self, path, fmt)
            written.append(path)

        monkeypatch.setattr(CosimResult, "write", write)
    if where == "figure":
        from rrr_robot.writing import plots

        def fail(*args: Any) -> None:
            raise KeyboardInterrupt

        monkeypatch.setattr(plots, "fig_controls", fail)
    if where == "summary":
        def fail_json(*args: Any, **kwargs: Any) -> str:
            raise KeyboardInterrupt

        from rrr_robot.core import summary as summary_module  # the one summary.json builder

        monkeypatch.setattr(summary_module, "strict_json", fail_json)
    with pytest.raises(KeyboardInterrupt):
        run_writing(writing_job(out, figures=True))
    assert snapshot(out) == before
    assert leftovers(out) == []


def test_a_writing_run_replaces_every_file_of_the_previous_one(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch,
                                                               ) -> None:
    out = tmp_path / "out"
    fake_cosim(monkeypatch)
    run_writing(writing_job(out))
    fake_cosim(monkeypatch)
    summary = run_writing(WritingJob(out=out, text="a", scenarios=["pd"], figures=False))
    assert summary["files"] == ["pd.csv", "summary.json"]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == \
        summary["files"]
    assert strict_loads((out / "summary.json").read_text()) == summary


def test_summary_json_is_strict_with_null_and_a_status(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """A diverged scenario (NaN tip) and an untimeable loop (wall time 0: infinite real-time
    factor). Before: json.dumps wrote NaN and Infinity, which strict parsers refuse."""
    out = tmp_path / "out"
    fake_cosim(monkeypatch, tip_errors={"ctc": np.nan}, wall_times={"mismatch": 0.0})
    summary = run_writing(writing_job(out))
    text = (out / "summary.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    data = strict_loads(text)
    assert data == summary
    pd, ctc, mismatch = (data["scenarios"][n] for n in ("pd", "ctc", "mismatch"))
    assert pd["status"] == "ok" and pd["non_finite"] == []
    assert ctc["status"] == "diverged"
    assert ctc["tip_error_max"] is None and ctc["tip_error_rms"] is None
    assert ctc["non_finite"] == ["tip_error_max", "tip_error_rms"]
    assert mismatch["status"] == "timing_unavailable" and mismatch["realtime_factor"] is None
    assert mismatch["non_finite"] == ["realtime_factor"]
    assert isinstance(mismatch["tip_error_max"], float)


def test_the_command_line_reports_a_diverged_scenario(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    fake_cosim(monkeypatch, tip_errors={"ctc": np.inf})
    rc = main(["writing", "--out", str(tmp_path / "out"), "--text", "a", "--no-figures", "-q"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "ctc: DIVERGED: non-finite tip_error_max, tip_error_rms" in out
    assert "pd: tip error max" in out


def test_scenario_summary() -> None:
    s = scenario_summary({"rms_u_n": [0.1, np.nan, 0.2], "rms_u_c": [0.0, 0.0, 0.0],
                          "tip_error_max": 1e-3, "tip_error_rms": 1e-4, "wall_time": 0.1,
                          "realtime_factor": 50.0})
    assert s["status"] == "diverged" and s["rms_u_n"] == [0.1, None, 0.2]
    assert s["non_finite"] == ["rms_u_n"]


# ---- rrr writing interrupted for real ---------------------------------------------------------


def start_writing(out: Path) -> subprocess.Popen[str]:
    """``rrr writing`` into ``out``; its temporary folders (the FMUs it extracts) beside ``out``,
    where pytest removes them: a run killed by SIGKILL cannot remove them itself."""
    tmp = out.parent / "tmp"
    tmp.mkdir(exist_ok=True)
    return subprocess.Popen(
        [sys.executable, "-m", "rrr_robot", "writing", "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_signals,
        env={**os.environ, "TMPDIR": str(tmp)})


def wait_for_first_csv(out: Path, proc: subprocess.Popen[str]) -> None:
    """Until the run has written its first scenario's CSV (into its staging folder)."""
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        if any(out.glob(f"{outputs.STAGING_PREFIX}*/pd.csv")):
            return
        time.sleep(0.01)
    proc.kill()
    pytest.fail("the run wrote no CSV within 300 s")


@pytest.fixture(scope="module")
def previous(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the results of a real earlier run (one scenario, short text)."""
    out = tmp_path_factory.mktemp("previous") / "out"
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--out", str(out),
                           "--text", "a", "--scenario", "ctc", "--no-figures", "--quiet"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize(("sig", "status", "line"), [
    (signal.SIGINT, 130, "rrr: interrupted"),
    (signal.SIGTERM, 143, "rrr: terminated"),
])
def test_rrr_writing_stopped_midway(previous: Path, tmp_path: Path, sig: int, status: int,
                                    line: str) -> None:
    """Ctrl-C (or kill) after the first scenario's CSV: one line, the exit status, no traceback,
    the previous results exactly as they were and nothing of the stopped run."""
    out = tmp_path / "out"
    subprocess.run(["cp", "-a", str(previous), str(out)], check=True)
    before = snapshot(out)
    proc = start_writing(out)
    wait_for_first_csv(out, proc)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status, err
    assert "Traceback" not in err
    assert err.splitlines()[-1] == line and err.count(line) == 1
    assert snapshot(out) == before
    assert leftovers(out) == []


def test_rrr_writing_killed_midway(previous: Path, tmp_path: Path) -> None:
    """SIGKILL cannot be caught: the previous results stay, the run's staging folder is hidden
    and the next run removes it."""
    out = tmp_path / "out"
    subprocess.run(["cp", "-a", str(previous), str(out)], check=True)
    before = snapshot(out)
    proc = start_writing(out)
    wait_for_first_csv(out, proc)
    proc.kill()
    proc.communicate(timeout=60)
    assert {k: v for k, v in snapshot(out).items() if not is_temporary(k.split("/")[0])
            or k.startswith(outputs.MANIFEST_PREFIX)} == before
    assert sorted(p.name for p in out.glob("*.csv")) == ["ctc.csv"]
    assert len(leftovers(out)) == 1
    rerun = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--out", str(out),
                            "--text", "a", "--scenario", "pd", "--no-figures", "--quiet"],
                           capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert leftovers(out) == []
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "pd.csv", "summary.json"]
