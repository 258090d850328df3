"""The commands' progress bars (rrr_robot.cli._progress): shown only on a terminal, off with -q."""

from __future__ import annotations

import io

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
