"""The commands' progress bars (rrr_robot.cli._progress): shown only on a terminal, off with -q."""

from __future__ import annotations

import io
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
        monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> None:
    """rrr identify-experiment on a terminal: a bar for the friction sweep and one for the
    excitation (the sweep made short here); with -q none."""
    from rrr_robot.cli import main
    from rrr_robot.identify import experiments as ex

    short = ex.SweepDesign(speeds=(0.5,), cruise=0.2, settle=0.1, ramp=0.1, hold=0.1)
    original = ex.friction_experiment
    monkeypatch.setattr(ex, "friction_experiment",
                        lambda model, **kw: original(model, design=short, **kw))

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    for quiet in (False, True):
        err = Tty()
        monkeypatch.setattr(_progress.sys, "stderr", err)
        argv = ["identify-experiment", "--out", str(tmp_path / f"o{quiet}"), "--noise-free"]
        assert main([*argv, "-q"] if quiet else argv) == 0
        text = err.getvalue()
        if quiet:
            assert "friction sweep" not in text and "excitation" not in text
        else:
            assert "friction sweep" in text and "excitation" in text and "10000/10000" in text
