"""The writing task's figures (rrr_robot.writing.plots): every figure is still written, under
its name (the paper's number where it reproduces one: Figs 2-9), at its size; long series are
drawn as their envelope (extremes kept); log-axis labels are plain text (no mathtext); Figs 2-6
drawn by the forked worker of a run are those drawn in-process, and its failures surface as
without it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from rrr_robot.errors import NumericError
from rrr_robot.sim.cosim import CosimResult
from rrr_robot.writing import job as job_module
from rrr_robot.writing import references as references_module
from rrr_robot.writing.figure_worker import ReferenceFigures
from rrr_robot.writing.job import WritingJob, prepare, run_writing
from rrr_robot.writing.plots import (
    DPI,
    REFERENCE_FIGURES,
    PowerOfTenFormatter,
    envelope,
    write_figures,
    write_reference_figures,
)

SCENARIOS = ("pd", "ctc", "mismatch")
#: Every figure of a default run with its size in inches (the names of the README).
FIGURES = {
    "fig2_reference.png": (12, 4),
    "fig3_joint_positions.png": (9, 4),
    "fig4_joint_velocities.png": (9, 4),
    "fig5_ik_difference.png": (9, 4),
    "fig6_torque_difference.png": (9, 4),
    "fig7_letters_pd.png": (10, 4), "fig8_letters_ctc.png": (10, 4),
    "fig_letters_mismatch.png": (10, 4),
    "fig_u2_pd.png": (9, 4), "fig9_u2_ctc.png": (9, 4), "fig_u2_mismatch.png": (9, 4),
    "fig_tip_error.png": (9, 4),
}


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """A short reference (one letter) and made-up results of the three scenarios."""
    model, robot, scenarios, ref = prepare(WritingJob(out=tmp_path_factory.mktemp("unused"),
                                                      text="a"))
    results = {}
    for k, scn in enumerate(scenarios):
        wobble = 1e-4 * (k + 1) * np.sin(np.outer(ref.t, [3.0, 5.0, 7.0]))
        results[scn.name] = CosimResult(
            t=ref.t, q_ref=ref.q, qd_ref=ref.qd, x_ref=ref.x, q=ref.q + wobble, qd=ref.qd,
            qdd=ref.qdd, tip=ref.x + wobble, u=np.cos(np.outer(ref.t, [1.0, 2.0, 3.0])),
            u_n=np.sin(np.outer(ref.t, [1.0, 2.0, 3.0])), u_c=wobble, wall_time=0.01)
    return model, robot, ref, results


def test_every_figure_is_written_with_its_name_and_size(short_run: Any, tmp_path: Path) -> None:
    model, robot, ref, results = short_run
    write_figures(tmp_path, model, robot, ref, results)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(FIGURES)
    for name, (w, h) in FIGURES.items():
        with Image.open(tmp_path / name) as img:
            assert img.format == "PNG" and img.size == (w * DPI, h * DPI), name
            colours = img.convert("L").getextrema()
        assert colours[0] < 100 < colours[1], name  # something drawn on the white background


def test_run_writing_lists_every_figure(short_run: Any, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Through run_writing (co-simulation replaced by the made-up results): the figures, the
    tables and summary.json are the run's files."""
    results = short_run[3]
    calls: list[str] = []

    def fake_cosim(*args: Any, **kwargs: Any) -> CosimResult:
        calls.append(SCENARIOS[len(calls)])
        return results[calls[-1]]

    monkeypatch.setattr(job_module, "run_cosim", fake_cosim)
    summary = run_writing(WritingJob(out=tmp_path, text="a"))
    expected = sorted([*FIGURES, *(f"{s}.csv" for s in SCENARIOS), "summary.json"])
    assert summary["files"] == expected
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == expected


def test_envelope_keeps_short_series_and_the_extremes_of_long_ones() -> None:
    t = np.arange(10.0)
    assert np.array_equal(envelope(t, t**2)[1], t**2)
    rng = np.random.default_rng(0)
    n = 100_003
    t = np.arange(n) * 1e-3
    y = np.cumsum(rng.standard_normal(n))
    y[12345] = 1e3  # a spike must survive
    y[777] = np.nan  # NaN is ignored, not propagated
    tt, yy = envelope(t, y, max_points=1000)
    assert tt.size <= 1000 and np.all(np.diff(tt) >= 0)
    assert np.nanmax(yy) == 1e3 and np.nanmin(yy) == np.nanmin(y)
    assert (tt[0], yy[0], tt[-1], yy[-1]) == (t[0], y[0], t[-1], y[-1])  # the same extent
    # every output point is a sample of the series
    idx = np.searchsorted(t, tt)
    assert np.array_equal(t[idx], tt) and np.array_equal(y[idx], yy)


def test_log_axis_labels_are_plain_text() -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.plot([0, 1], [1e-4, 1e2])
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(PowerOfTenFormatter())
    ax.set_ylim(1e-4, 1e2)
    fig.canvas.draw()
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert {"10\u207b\u2074", "10\u2070", "10\u00b2"} <= set(labels), labels
    assert not any("$" in s for s in labels)
    fmt = PowerOfTenFormatter()
    assert fmt._num_to_string(2e-3, 1e-4, 1e2) == "2\u00d710\u207b\u00b3"
    assert fmt._num_to_string(1e5, 1e-4, 1e2) == "10\u2075"



def test_the_worker_draws_the_reference_figures_as_this_process_does(short_run: Any,
                                                                      tmp_path: Path) -> None:
    """Figs 2-6 drawn by the forked worker are byte for byte those drawn here."""
    model, robot, ref, _ = short_run
    (tmp_path / "worker").mkdir()
    (tmp_path / "here").mkdir()
    with ReferenceFigures(tmp_path / "worker", model, robot, ref) as worker:
        worker.finish()
    write_reference_figures(tmp_path / "here", model, robot, ref)
    names = sorted(p.name for p in (tmp_path / "here").iterdir())
    assert names == sorted(REFERENCE_FIGURES)
    assert sorted(p.name for p in (tmp_path / "worker").iterdir()) == names
    for name in names:
        assert (tmp_path / "worker" / name).read_bytes() == (tmp_path / "here" / name).read_bytes()


def test_a_failing_worker_gives_way_to_this_process(short_run: Any, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker that fails: finish() draws here, so the error is the one of a run without
    the worker (here the numeric IK's)."""
    model, robot, ref, _ = short_run

    def broken(*args: Any) -> Any:
        raise NumericError("MuJoCo's IK did not converge at row 3", "mujoco ik")

    monkeypatch.setattr(references_module, "numeric_ik_path", broken)  # the fork inherits it
    with ReferenceFigures(tmp_path, model, robot, ref) as worker, \
            pytest.raises(NumericError, match="row 3"):
        worker.finish()


def test_close_stops_the_worker(short_run: Any, tmp_path: Path) -> None:
    model, robot, ref, _ = short_run
    worker = ReferenceFigures(tmp_path, model, robot, ref)
    proc = worker._proc
    worker.close()
    worker.close()  # idempotent
    if proc is not None:  # Linux
        assert not proc.is_alive() and proc.exitcode is not None
    assert not ReferenceFigures(tmp_path, model, robot, ref, start=False).running
