"""Every malformed file, option or value of every ``rrr`` command stops with one line
``rrr: error: ...`` (or argparse's ``rrr <command>: error: ...`` after its usage) and exit
status 2, with no traceback, BEFORE anything is written or simulated: the output does not exist
afterwards and the working folder is exactly as it was. Library errors become that line in
rrr_robot.cli only; Ctrl-C gives ``rrr: interrupted`` and 130 (tests/python/jobs/test_outputs.py
interrupts real runs)."""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.cli import app, main
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.errors import HilError

OUT = "out"  # the output folder (or file) of every case: must not exist afterwards

#: (command line, text the one error line must contain); files in the fixture `workdir`
CASES: dict[str, tuple[list[str], str]] = {
    # rrr writing
    "writing-unknown-scenario": (["writing", "--scenario", "nonsense"], "unknown scenario"),
    "writing-binary-scenario": (["writing", "--scenario", "binary.toml"], "binary.toml"),
    "writing-malformed-scenario": (["writing", "--scenario", "broken.toml"], "broken.toml"),
    "writing-binary-robot": (["writing", "--robot", "binary.toml"], "binary.toml"),
    "writing-malformed-robot": (["writing", "--robot", "broken.toml"], "broken.toml"),
    "writing-missing-robot": (["writing", "--robot", "missing.toml"], "missing.toml"),
    "writing-robot-is-a-folder": (["writing", "--robot", "folder"], "folder"),
    "writing-robot-not-finite": (["writing", "--robot", "nan_robot.toml"], "nan_robot.toml"),
    "writing-missing-controller-robot": (["writing", "--controller-robot", "missing.toml"],
                                         "missing.toml"),
    "writing-controller-robot-not-finite": (["writing", "--controller-robot",
                                             "nan_robot.toml"], "nan_robot.toml"),
    "ssp-binary-controller-robot": (["ssp", "--out", "x.ssp", "--controller-robot",
                                     "binary.toml"], "binary.toml"),
    "writing-scale-nan": (["writing", "--scale", "nan"], "nan"),
    "writing-scale-too-big": (["writing", "--scale", "6"], "writing area"),
    "writing-scale-not-a-number": (["writing", "--scale", "big"], "--scale"),
    "writing-empty-text": (["writing", "--text", ""], "text"),
    "writing-unknown-glyph": (["writing", "--text", "\u263a"], "\u263a"),
    "writing-fmi-4": (["writing", "--fmi", "4"], "--fmi"),
    "writing-empty-out": (["writing", "--out", ""], "--out"),
    "writing-out-below-a-file": (["writing", "--out", "a_file/out"], "output folder"),
    "writing-animate-unknown-format": (["writing", "--animate", "avi"], "--animate"),
    "writing-text-too-long-for-the-area": (["writing", "--text", "The quick brown fox jumps "
                                            "over the lazy dog"], "below min_letter_height"),
    # rrr identify (OUT is the robot file to write)
    "identify-missing-log": (["identify", "--log", "missing.csv"], "missing.csv"),
    "identify-binary-log": (["identify", "--log", "binary.toml"], "binary.toml"),
    "identify-log-not-csv": (["identify", "--log", "broken.toml"], "broken.toml"),
    "identify-log-is-a-folder": (["identify", "--log", "folder"], "folder"),
    "identify-binary-friction-log": (["identify", "--log", "log.csv", "--friction-log",
                                      "binary.toml"], "binary.toml"),
    "identify-binary-robot": (["identify", "--log", "log.csv", "--robot", "binary.toml"],
                              "binary.toml"),
    "identify-cutoff-nan": (["identify", "--log", "log.csv", "--cutoff", "nan"], "cutoff"),
    "identify-v-min-negative": (["identify", "--log", "log.csv", "--v-min", "-1"], "v_min"),
    "identify-bad-derivatives": (["identify", "--log", "log.csv", "--derivatives", "x"],
                                 "--derivatives"),
    "identify-out-in-missing-folder": (["identify", "--log", "log.csv", "--out",
                                        "nowhere/robot.toml"], "does not exist"),
    "identify-out-is-a-folder": (["identify", "--log", "log.csv", "--out", "folder"],
                                 "is a folder"),
    "identify-out-is-the-log": (["identify", "--log", "log.csv", "--out", "log.csv"],
                                "input log"),
    "identify-report-in-missing-folder": (["identify", "--log", "log.csv", "--report",
                                           "nowhere/r.json"], "does not exist"),
    "identify-report-is-out": (["identify", "--log", "log.csv", "--report", OUT],
                               "give two files"),
    "identify-no-log": (["identify"], "--log"),
    "identify-missing-truth": (["identify", "--log", "log.csv", "--truth", "missing.toml"],
                               "missing.toml"),
    "identify-binary-truth": (["identify", "--log", "log.csv", "--truth", "binary.toml"],
                              "binary.toml"),
    "identify-out-is-the-truth": (["identify", "--log", "log.csv", "--truth", "bp_robot.toml",
                                   "--out", "bp_robot.toml"], "is the truth"),
    # rrr identify-experiment
    "experiment-periods-0": (["identify-experiment", "--periods", "0"], "--periods"),
    "experiment-periods-negative": (["identify-experiment", "--periods", "-3"], "--periods"),
    "experiment-periods-not-a-number": (["identify-experiment", "--periods", "x"], "--periods"),
    "experiment-seed-negative": (["identify-experiment", "--seed", "-1"], "--seed"),
    "experiment-speeds-too-few": (["identify-experiment", "--speeds", "7"], "--speeds"),
    "experiment-speeds-not-a-number": (["identify-experiment", "--speeds", "x"], "--speeds"),
    "experiment-binary-robot": (["identify-experiment", "--robot", "binary.toml"],
                                "binary.toml"),
    "experiment-missing-robot": (["identify-experiment", "--robot", "missing.toml"],
                                 "missing.toml"),
    "experiment-out-below-a-file": (["identify-experiment", "--out", "a_file/out"],
                                    "output folder"),
    # rrr hil
    "hil-unknown-side": (["hil", "both"], "invalid choice: 'both'"),
    "hil-no-action": (["hil"], "ACTION"),
    "ls-bus-zero-bitrate": (["ls-bus", "--bitrate", "0"], "--bitrate"),
    "ls-bus-nan-duration": (["ls-bus", "--duration", "nan"], "--duration"),
    "hil-unknown-scenario": (["hil", "bench", "--scenario", "nonsense"], "unknown scenario"),
    "hil-binary-scenario": (["hil", "export-reference", "--scenario", "binary.toml"],
                            "binary.toml"),
    "hil-unknown-glyph": (["hil", "bench", "--text", "\u263a"], "\u263a"),
    "hil-connect-no-port": (["hil", "controller", "--connect", "localhost"], "--connect"),
    "hil-connect-bad-port": (["hil", "plant", "--connect", "127.0.0.1:99999"], "--connect"),
    "hil-drop-negative": (["hil", "plant", "--drop-commands-from", "-1"],
                          "--drop-commands-from"),
    "hil-bad-interface": (["hil", "bench", "--interface", "vcan"], "--interface"),
    "hil-out-below-a-file": (["hil", "export-reference", "--out", "a_file/out"],
                             "output folder"),
    # rrr urdf (OUT is the URDF file to write)
    "urdf-missing-robot": (["urdf", "--robot", "missing.toml"], "missing.toml"),
    "urdf-binary-robot": (["urdf", "--robot", "binary.toml"], "binary.toml"),
    "urdf-base-parameters-only": (["urdf", "--robot", "bp_robot.toml"], "[base_parameters]"),
    "urdf-out-is-a-folder": (["urdf", "--out", "folder"], "is a folder"),
    "urdf-out-in-missing-folder": (["urdf", "--out", "nowhere/rrr.urdf"], "does not exist"),
    "urdf-no-out": (["urdf", "--out"], "--out"),
    # rrr view (its FOLDER is read; the page would be FOLDER/view.html)
    "view-missing-folder": (["view", "nowhere"], "not a folder"),
    "view-folder-without-tables": (["view", "folder"], "no result table"),
    "view-binary-robot": (["view", "folder", "--robot", "binary.toml"], "binary.toml"),
    "view-unknown-scenario": (["view", "folder", "--scenario", "pd"], "no table pd.csv"),
    "view-empty-out": (["view", "folder", "--out", ""], "--out"),
    "hil-duration-negative": (["hil", "bench", "--duration", "-1"], "--duration"),
    "hil-duration-absurd": (["hil", "bench", "--realtime", "--duration", "1e9"], "--duration"),
    "hil-duration-nan": (["hil", "bench", "--duration", "nan"], "--duration"),
    "hil-duration-zero": (["hil", "bench", "--duration", "0"], "--duration"),
    "hil-can-log-missing-folder": (["hil", "bench", "--can-log", "nowhere/f.blf"],
                                   "does not exist"),
    "hil-can-log-below-a-file": (["hil", "bench", "--can-log", "a_file/f.blf"],
                                 "not a folder"),
    "hil-can-log-is-a-folder": (["hil", "bench", "--can-log", "folder.asc"], "is a folder"),
    "hil-can-log-format": (["hil", "bench", "--can-log", "frames.txt"], ".asc or .blf"),
    "hil-can-log-and-none": (["hil", "bench", "--can-log", "f.blf", "--no-can-log"],
                             "--no-can-log"),
    "hil-realtime-plant": (["hil", "plant", "--realtime"], "--realtime"),
    "hil-spin-too-long": (["hil", "bench", "--realtime", "--spin-us", "1000"], "--spin-us"),
    "hil-bitrate-on-bench": (["hil", "bench", "--bitrate", "500000"], "--bitrate"),
    # each action takes only its own options: another action's is an error, never ignored
    "hil-run-options-on-busload": (["hil", "busload", "--realtime", "--scenario", "nonsense",
                                    "--out", "/nonexistent/x"], "unrecognized arguments"),
    "hil-connect-on-bench": (["hil", "bench", "--connect", "127.0.0.1:29536"], "--connect"),
    "hil-drop-on-controller": (["hil", "controller", "--drop-commands-from", "5"],
                               "--drop-commands-from"),
    "hil-can-log-on-export": (["hil", "export-reference", "--can-log", "f.blf"], "--can-log"),
    "hil-figures-on-export": (["hil", "export-reference", "--no-figures"], "--no-figures"),
    "hil-no-fifo-without-realtime": (["hil", "bench", "--no-fifo"], "--no-fifo"),
    "hil-spin-without-realtime": (["hil", "bench", "--spin-us", "50"], "--spin-us"),
    "hil-fd-on-socketcand": (["hil", "bench", "--fd"], "socketcand protocol carries classical"),
    "hil-fd-on-controller": (["hil", "controller", "--fd"], "unrecognized arguments"),
    "busload-bitrate-0": (["hil", "busload", "--bitrate", "0"], "--bitrate"),
    "busload-bitrate-negative": (["hil", "busload", "--bitrate", "-5"], "--bitrate"),
    "busload-bitrate-too-high": (["hil", "busload", "--bitrate", "2000000"], "--bitrate"),
    "busload-bitrate-not-a-number": (["hil", "busload", "--bitrate", "fast"], "--bitrate"),
    "busload-fd-below-nominal": (["hil", "busload", "--fd", "100000"], "--fd"),
    "busload-binary-dbc": (["hil", "busload", "--dbc", "binary.toml"], "--dbc"),
    "busload-missing-dbc": (["hil", "busload", "--dbc", "missing.dbc"], "missing.dbc"),
    # rrr sweep
    "sweep-missing-spec": (["sweep", "missing.toml"], "missing.toml"),
    "sweep-binary-spec": (["sweep", "binary.toml"], "binary.toml"),
    "sweep-malformed-spec": (["sweep", "broken.toml"], "broken.toml"),
    "sweep-unknown-key": (["sweep", "sweep_unknown_key.toml"], "mismatch.q_rel"),
    "sweep-samples-0": (["sweep", "sweep_samples_0.toml"], "samples"),
    "sweep-workers-0": (["sweep", "sweep_ok.toml", "--workers", "0"], "--workers"),
    "sweep-bad-scheduler": (["sweep", "sweep_ok.toml", "--scheduler", "nowhere"],
                            "--scheduler"),
    "sweep-workers-and-scheduler": (["sweep", "sweep_ok.toml", "--workers", "2",
                                     "--scheduler", "tcp://127.0.0.1:8786"], "--workers"),
    "sweep-bad-engine": (["sweep", "sweep_ok.toml", "--engine", "fast"], "--engine"),
    "sweep-out-below-a-file": (["sweep", "sweep_ok.toml", "--out", "a_file/out"],
                               "output folder"),
    "sweep-no-out": (["sweep", "sweep_ok.toml", "--out", ""], "--out"),
    # rrr, rrr fmus
    "no-command": ([], "command"),
    "unknown-command": (["paint"], "paint"),
    "fmus-extra-argument": (["fmus", "extra"], "extra"),
    # rrr ssp (its --out is a file) and rrr run-ssp (OUT is the results folder)
    "ssp-out-not-ssp": (["ssp", "--out", "out.zip"], "must name an .ssp file"),
    "ssp-unknown-scenario": (["ssp", "--out", "out.ssp", "--scenario", "nope"],
                             "unknown scenario"),
    "ssp-malformed-robot": (["ssp", "--out", "out.ssp", "--robot", "broken.toml"],
                            "broken.toml"),
    "ssp-negative-lookahead": (["ssp", "--out", "out.ssp", "--lookahead", "-1"],
                               "--lookahead"),
    "ssp-lookahead-too-long": (["ssp", "--out", "out.ssp", "--lookahead", "11"],
                               "look-ahead must be 0 to 10 steps"),
    "run-ssp-missing": (["run-ssp", "missing.ssp", "--tool", "fmpy"], "no such SSP file"),
    "run-ssp-not-a-zip": (["run-ssp", "broken.toml", "--tool", "libcosim"],
                          "not an SSP archive"),
    "run-ssp-unknown-tool": (["run-ssp", "broken.toml", "--tool", "omsimulator"], "--tool"),
    "run-ssp-real-time-fmpy": (["run-ssp", "broken.toml", "--tool", "fmpy", "--real-time"],
                               "--real-time needs --tool libcosim"),
}

#: the commands that take an output (appended as --out OUT unless the case gives --out)
TAKES_OUT = ("writing", "identify", "identify-experiment", "hil", "urdf", "run-ssp", "sweep")


def make_workdir(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "binary.toml").write_bytes(b"\xff\xfe\x00\x81binary\x00")
    (folder / "broken.toml").write_text("[scenario\nname = \n")
    (folder / "folder").mkdir(exist_ok=True)
    (folder / "folder.asc").mkdir(exist_ok=True)
    (folder / "a_file").write_text("not a folder")
    robot = DEFAULT_ROBOT_TOML.read_text().replace("g = 9.81", "g = nan", 1)
    assert "g = nan" in robot
    (folder / "nan_robot.toml").write_text(robot)
    rr.Model.default().to_toml(folder / "bp_robot.toml")  # [base_parameters], no link tables
    sweep = ('[sweep]\nbase = "ctc"\nsamples = 2\n'
             '[vary]\n"mismatch.p_rel" = { uniform = [0, 0.1] }\n')
    (folder / "sweep_ok.toml").write_text(sweep)
    (folder / "sweep_unknown_key.toml").write_text(sweep.replace("p_rel", "q_rel"))
    (folder / "sweep_samples_0.toml").write_text(sweep.replace("samples = 2", "samples = 0"))
    t = np.arange(300) * 1e-3
    rows = np.column_stack([t, np.zeros((300, 6))])
    (folder / "log.csv").write_text("t,q[1],q[2],q[3],u[1],u[2],u[3]\n" + "\n".join(
        ",".join(f"{v:g}" for v in r) for r in rows) + "\n")


def command(args: list[str]) -> list[str]:
    if args[:2] == ["hil", "busload"] or args == ["hil"]:  # no --out: writes nothing
        return [sys.executable, "-m", "rrr_robot", *args]
    if args and args[0] in TAKES_OUT and "--out" not in args:
        args = [*args, "--out", OUT]
    return [sys.executable, "-m", "rrr_robot", *args]


def tree(folder: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None)
            for p in sorted(folder.rglob("*"))}


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory,
            ) -> dict[str, tuple[subprocess.CompletedProcess[str], bool]]:
    """Every case run once, in parallel, each in its own copy of the work folder: the process
    and whether the folder was left exactly as it was."""
    base = tmp_path_factory.mktemp("cli_errors")

    def run(name: str) -> tuple[subprocess.CompletedProcess[str], bool]:
        work = base / name
        make_workdir(work)
        before = tree(work)
        proc = subprocess.run(command(CASES[name][0]), cwd=work, capture_output=True,
                              text=True, timeout=600)
        return proc, tree(work) == before

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(zip(CASES, pool.map(run, CASES), strict=True))


@pytest.mark.parametrize("name", list(CASES))
def test_malformed_input_stops_with_one_line_before_anything_is_written(
        results: dict[str, tuple[subprocess.CompletedProcess[str], bool]], name: str) -> None:
    proc, unchanged = results[name]
    needle = CASES[name][1]
    err = proc.stderr
    assert proc.returncode == 2, err
    assert "Traceback" not in err and proc.stdout == ""
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1, err
    line = errors[0]
    if not err.startswith("usage:"):  # the package's error: the only line
        assert err.splitlines() == [line] and line.startswith("rrr: error: "), err
    else:  # argparse: usage, then its one error line, last
        assert err.splitlines()[-1] == line, err
        assert line.startswith("rrr") and ": error: " in line, err
    assert needle in line, err
    assert unchanged, f"{name}: the work folder changed (output: {OUT})"


def test_every_command_is_covered() -> None:
    covered = {args[0] for args, _ in CASES.values() if args}
    sub = next(a for a in app.build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) <= covered


# ---- in the process: the mapping of errors to one line and the exit status ------------------


def run_main(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
             fail: Callable[[], None]) -> tuple[int, str]:
    def command(args: argparse.Namespace) -> int:
        fail()
        return 0

    monkeypatch.setattr(app, "_cmd_fmus", command)  # `rrr fmus` runs `fail`
    try:
        rc = main(["fmus"])
    except KeyboardInterrupt:  # not pytest's own Ctrl-C: it would end the whole session
        pytest.fail("KeyboardInterrupt escaped rrr_robot.cli.main")
    return rc, capsys.readouterr().err


def raiser(exc: BaseException) -> Callable[[], None]:
    def fail() -> None:
        raise exc

    return fail


@pytest.mark.parametrize(("exc", "status", "line"), [
    (KeyboardInterrupt(), 130, "rrr: interrupted"),
    (rr.CosimError("controller: fmi2DoStep returned ERROR\nat t = 1 s:\n  reason"), 2,
     "rrr: error: controller: fmi2DoStep returned ERROR at t = 1 s: reason"),
    (rr.BadInputError("bad"), 2, "rrr: error: bad"),
    # python-can's socketcand bus writes its traceback into its CanError's message: cut off
    (HilError("SYNC 88: the plant node was killed by SIGKILL (Failed to receive: [Errno 104] "
                 "Connection reset by peer  Traceback (most recent call last):\n  File \"x.py\""
                 ", line 285, in _recv_internal\nConnectionResetError: [Errno 104])"), 2,
     "rrr: error: SYNC 88: the plant node was killed by SIGKILL (Failed to receive: [Errno 104] "
     "Connection reset by peer"),
    (PermissionError(13, "Permission denied", "out"), 2,
     "rrr: error: [Errno 13] Permission denied: 'out'"),
    (UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"), 2,
     "rrr: error: 'utf-8' codec can't decode byte 0xff in position 0: invalid start byte"),
])
def test_errors_become_one_line_and_a_status(monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str],
                                             exc: BaseException, status: int, line: str) -> None:
    rc, err = run_main(monkeypatch, capsys, raiser(exc))
    assert rc == status
    assert err == line + "\n"


def test_a_bug_is_not_hidden(monkeypatch: pytest.MonkeyPatch,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """Only the package's, the file system's and decoding errors are input errors; anything
    else is a bug and keeps its traceback."""
    with pytest.raises(ZeroDivisionError):
        run_main(monkeypatch, capsys, raiser(ZeroDivisionError("a bug")))
