"""The commands' progress bars (rrr_robot.cli._progress): shown only on a terminal, off with -q."""

from __future__ import annotations

import fcntl
import io
import os
import pty
import re
import shlex
import struct
import subprocess
import sys
import termios
from pathlib import Path
from typing import Any

import pytest
from rrr_robot.cli import _progress


def test_disabled_bars_write_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    with _progress.Bars(False) as bars:
        bars("ctc", 5, 10)
        bars.callback("pd")(10, 10)
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == ""


def test_bars_follow_names_and_counts(monkeypatch: pytest.MonkeyPatch) -> None:
    err = io.StringIO()
    monkeypatch.setattr(_progress.sys, "stderr", err)
    with _progress.Bars(True, unit="run") as bars:
        bars("pd", 3, 4)
        bars("pd", 4, 4)
        bars.callback("ctc")(2, 8)
    text = err.getvalue()
    assert "pd" in text and "4/4" in text
    assert "ctc" in text and "2/8" in text
    assert bars._bar is None  # closed on exit


def test_shown_only_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(_progress.sys, "stderr", io.StringIO())
    assert not _progress.shown(quiet=False)
    monkeypatch.setattr(_progress.sys, "stderr", Tty())
    assert _progress.shown(quiet=False)
    assert not _progress.shown(quiet=True)


# ---- the library callbacks behind the commands' bars -------------------------------------------

def test_an_experiment_reports_its_samples() -> None:
    import numpy as np
    import rrr_robot as rr
    from rrr_robot.identify import experiments as ex

    t = np.arange(2500) * 1e-3
    q = np.tile([0.0, 0.3, 1.0], (t.size, 1))
    calls: list[tuple[int, int]] = []
    ex.simulate(rr.Model.default(), t, q, np.zeros_like(q), progress=lambda k, n: calls.append(
        (k, n)))
    assert calls == [(1000, 2500), (2000, 2500), (2500, 2500)]


def test_friction_fits_report_each_joint(monkeypatch: pytest.MonkeyPatch) -> None:
    import rrr_robot as rr
    from rrr_robot.identify import pipeline

    monkeypatch.setattr(pipeline, "curve_points", lambda *args: None)
    monkeypatch.setattr(pipeline, "fit_nls", lambda pts: _Fit())
    calls: list[tuple[int, int]] = []
    pipeline.identify_friction(None, rr.Model.default(),  # type: ignore[arg-type]
                               progress=lambda k, n: calls.append((k, n)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


class _Fit:
    import numpy as np

    f = w = np.zeros(3)
    b = 0.0
    method = "nls"
    residual_rms = 0.0


def test_identify_experiment_shows_bars_and_q_hides_them(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Any,
        capsys: pytest.CaptureFixture[str]) -> None:
    """rrr identify-experiment on a terminal: a bar for the friction sweep and one for the
    excitation (the sweep made short here); with -q none."""
    from rrr_robot.cli import build_parser, main
    from rrr_robot.identify import experiments as ex

    short = ex.SweepDesign(speeds=(0.5,), cruise=0.2, settle=0.1, ramp=0.1, hold=0.1)
    original = ex.friction_experiment
    monkeypatch.setattr(ex, "friction_experiment",
                        lambda model, design=None, **kw: original(model, short, **kw))

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    for quiet in (False, True):
        err = Tty()
        monkeypatch.setattr(_progress.sys, "stderr", err)
        argv = ["identify-experiment", "--out", str(tmp_path / f"o{quiet}"), "--noise-free"]
        assert main([*argv, "-q"] if quiet else argv) == 0
        text = err.getvalue()
        # its last line is the rrr identify command for its logs, and that command runs
        last = capsys.readouterr().out.splitlines()[-1]
        prefix = "identify from them with: rrr identify "
        assert last.startswith(prefix), last
        words = shlex.split(last.removeprefix("identify from them with: "))
        args = build_parser().parse_args(words[1:])  # a valid command line of rrr identify
        assert args.func.__name__ == "_cmd_identify"
        assert Path(args.log) == tmp_path / f"o{quiet}" / "excitation.csv"
        assert Path(args.friction_log) == tmp_path / f"o{quiet}" / "friction.csv"
        assert Path(args.log).is_file() and Path(args.friction_log).is_file()
        if quiet:
            assert "friction sweep" not in text and "excitation" not in text
        else:
            assert "friction sweep" in text and "excitation" in text and "10000/10000" in text


# ---- on a terminal: log lines above the bars, never on a bar's line ---------------------------

_CSI = re.compile(r"\x1b\[([0-9;?]*)([A-Za-z])")


def screen(data: bytes) -> list[str]:
    """The lines a terminal shows after ``data``: carriage returns overwrite from column 0,
    ``ESC [ n A`` moves up (tqdm's multi-bar moves), other escapes change nothing here."""
    rows: list[list[str]] = [[]]
    row = col = 0
    i = 0
    text = data.decode("utf-8", "replace")
    while i < len(text):
        m = _CSI.match(text, i)
        if m:
            if m.group(2) == "A":
                row = max(0, row - int(m.group(1) or "1"))
            i = m.end()
            continue
        char = text[i]
        i += 1
        if char == "\r":
            col = 0
        elif char == "\n":
            row += 1
            col = 0
            while len(rows) <= row:
                rows.append([])
        else:
            line = rows[row]
            if col < len(line):
                line[col] = char
            else:
                line.extend(" " * (col - len(line)))
                line.append(char)
            col += 1
    return ["".join(r).rstrip() for r in rows]


def run_on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, bytes]:
    """``python -m rrr_robot ARGV`` with stdout and stderr on a pseudo-terminal of 100 x 30:
    its exit status and everything the terminal received."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "rrr_robot", *argv], cwd=cwd,
                            stdin=subprocess.DEVNULL, stdout=slave, stderr=slave,
                            env={**os.environ, "COLUMNS": "100"})
    os.close(slave)
    chunks = []
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # EIO: the process closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    return proc.wait(timeout=600), b"".join(chunks)


BAR = re.compile(r"\d+%\||\d+/\d+ \[")  # tqdm's "37%|" and "5/12 ["


def test_log_lines_never_share_a_line_with_a_bar(tmp_path: Path) -> None:
    """rrr writing on a terminal (native engine, two scenarios, figures): the INFO lines of
    the figures phase are logged while its bar is open, and each gets a line of its own."""
    rc, data = run_on_a_terminal(["writing", "--engine", "native", "--scenario", "pd",
                                  "--scenario", "ctc", "--out", str(tmp_path / "out")], tmp_path)
    assert rc == 0, data.decode("utf-8", "replace")[-3000:]
    lines = screen(data)
    logs = [line for line in lines if re.search(r"\b(INFO|WARNING) rrr_robot", line)]
    bars = [line for line in lines if BAR.search(line)]
    assert len(logs) >= 10 and bars, "\n".join(lines)  # both were shown
    shared = [line for line in logs if BAR.search(line)]
    assert not shared, "\n".join(shared)
    # the figures' bar was open while they were logged (the case tqdm.write is there for)
    assert b"drew fig" in data and b"figures" in data


def test_quiet_prints_only_the_results(tmp_path: Path) -> None:
    """rrr writing -q on a terminal: no INFO line, no bar; only the result lines."""
    rc, data = run_on_a_terminal(["writing", "--engine", "native", "--scenario", "ctc", "-q",
                                  "--text", "a", "--out", str(tmp_path / "out")], tmp_path)
    lines = [line for line in screen(data) if line]
    assert rc == 0, lines
    assert len(lines) == 2, lines
    assert lines[0].lstrip().startswith("ctc: tip error max"), lines
    assert lines[1].startswith("results in "), lines


@pytest.mark.parametrize("verbose", [False, True])
def test_a_library_traceback_is_one_line_unless_verbose(verbose: bool) -> None:
    """python-can writes a traceback into its message when a peer resets the connection; the
    command's log keeps one line of it (the cause) unless -v asks for the detail."""
    import logging

    from rrr_robot.cli.app import _LineFormatter

    try:
        raise ConnectionResetError(104, "Connection reset by peer")
    except ConnectionResetError as exc:
        import traceback
        message = f"Failed to receive: {exc}  {traceback.format_exc()}"
        inside = logging.LogRecord("can.x", logging.ERROR, __file__, 1, message, None, None)
        import sys as _sys
        attached = logging.LogRecord("can.y", logging.ERROR, __file__, 1, "lost", None,
                                     _sys.exc_info())
    fmt = _LineFormatter(tracebacks=verbose)
    one, two = fmt.format(inside), fmt.format(attached)
    if verbose:
        assert "Traceback" in one and "Traceback" in two
    else:
        assert one == "ERROR can.x: Failed to receive: [Errno 104] Connection reset by peer"
        assert two == "ERROR can.y: lost ([Errno 104] Connection reset by peer)"
