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
#: Every figure of a default run with its size in inches (the names of the README); None: sized
#: to the text it shows (the letters at equal aspect, test_the_letters_fill_their_axes).
FIGURES: dict[str, tuple[int, int] | None] = {
    "fig2_reference.png": None,
    "fig3_joint_positions.png": (9, 4),
    "fig4_joint_velocities.png": (9, 4),
    "fig5_ik_difference.png": (9, 4),
    "fig6_torque_difference.png": (9, 4),
    "fig7_letters_pd.png": None, "fig8_letters_ctc.png": None,
    "fig_letters_mismatch.png": None,
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
    for name, size in FIGURES.items():
        with Image.open(tmp_path / name) as img:
            assert img.format == "PNG", name
            if size is not None:
                assert img.size == (size[0] * DPI, size[1] * DPI), name
            else:  # sized to the text: within the bounds of a page
                assert 6 * DPI <= img.size[0] <= 13 * DPI and 3 * DPI <= img.size[1] <= 12 * DPI
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



def _kept(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Every figure plots saves, by file name (saved as usual too, laid out)."""
    from rrr_robot.writing import plots

    figures: dict[str, Any] = {}
    save = plots._save

    def keep(fig: Any, path: Path, *args: Any, **kwargs: Any) -> None:
        save(fig, path, *args, **kwargs)
        figures[path.name] = fig

    monkeypatch.setattr(plots, "_save", keep)
    return figures


def _results(ref: Any, error: float) -> dict[str, CosimResult]:
    """A made-up ctc result whose tip is off the reference by up to ``error`` m."""
    wobble = error * np.sin(np.outer(ref.t, [3.0, 5.0, 7.0])) / np.sqrt(3.0)
    return {"ctc": CosimResult(
        t=ref.t, q_ref=ref.q, qd_ref=ref.qd, x_ref=ref.x, q=ref.q, qd=ref.qd, qdd=ref.qdd,
        tip=ref.x + wobble, u=np.zeros_like(ref.q), u_n=np.zeros_like(ref.q),
        u_c=np.zeros_like(ref.q), wall_time=0.01)}


@pytest.mark.parametrize("text", ["a\u03c9m\u03b3", "Hi\nyou\nall", "Hello, world"])
def test_the_letters_fill_their_axes_at_equal_aspect(text: str, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Figs 2, 7 and 8: the letters at equal aspect (a metre is as long in x as in z, in
    pixels), and the axes they are drawn in are as large as the layout gave them in both
    directions (the figure is sized to the text: before, a tall text used a third of a wide
    canvas)."""
    from rrr_robot.writing import plots

    ref = prepare(WritingJob(out=tmp_path / "unused", text=text)).reference
    figures = _kept(monkeypatch)
    plots.fig_reference(tmp_path, ref)
    plots.fig_letters(tmp_path, ref, _results(ref, 1e-4))
    for name in ("fig2_reference.png", "fig8_letters_ctc.png"):
        fig = figures[name]
        ax = fig.axes[0]
        assert ax.get_xlabel() == "x [m]" and ax.get_ylabel() == "z [m]", name
        fig.canvas.draw()
        box = ax.get_window_extent()
        (x0, x1), (z0, z1) = ax.get_xlim(), ax.get_ylim()
        per_m_x, per_m_z = box.width / (x1 - x0), box.height / (z1 - z0)
        assert per_m_x == pytest.approx(per_m_z, rel=0.01), name
        slot = ax.get_position(original=True)
        used = ax.get_position()
        assert used.width >= 0.95 * slot.width and used.height >= 0.95 * slot.height, \
            (name, text, used, slot)
        # and the slot is most of the figure's width or height (not the middle of a canvas)
        assert slot.width >= 0.5 or slot.height >= 0.45, (name, text, slot)
        # the letters span the axes in one direction at least (5 % margins either side)
        xz = np.concatenate([np.column_stack([ln.get_xdata(), ln.get_ydata()])
                             for ln in ax.get_lines()]).astype(float)
        xz = xz[np.all(np.isfinite(xz), axis=1)]
        fill = np.ptp(xz, axis=0) / np.array([x1 - x0, z1 - z0])
        assert fill.max() >= 0.85 and fill.min() >= 0.5, (name, text, fill)


def test_a_small_tip_error_is_drawn_magnified_and_along_the_path(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch
                                                                 ) -> None:
    """The ctc letters (0.1 mm off): the executed path drawn 20 times its error away from the
    reference (the factor in the legend and the title), and a panel below with the error in mm
    at true size; a large error (pd's 25 mm) is drawn as it is."""
    from rrr_robot.writing import plots

    assert plots.error_magnification(0.099e-3, 0.07) == 20.0
    assert plots.error_magnification(2.47e-3, 0.07) == 1.0
    assert plots.error_magnification(1e-6, 0.07) == 2000.0
    assert plots.error_magnification(float("nan"), 0.07) == 1.0
    assert plots.error_magnification(0.0, 0.07) == 1.0
    _, _, _, ref = prepare(WritingJob(out=tmp_path / "unused", text="am"))
    for error, k in ((1e-4, 20.0), (25e-3, 1.0)):
        figures = _kept(monkeypatch)
        results = _results(ref, error)
        plots.fig_letters(tmp_path, ref, results)
        ax, panel = figures["fig8_letters_ctc.png"].axes
        executed = next(ln for ln in ax.get_lines() if ln.get_label().startswith("executed"))
        reference = next(ln for ln in ax.get_lines() if ln.get_label() == "reference")
        drawn = np.column_stack([executed.get_xdata(), executed.get_ydata()])
        want = np.column_stack([reference.get_xdata(), reference.get_ydata()])
        ok = np.all(np.isfinite(drawn), axis=1) & np.all(np.isfinite(want), axis=1)
        err = results["ctc"].tip - results["ctc"].x_ref
        np.testing.assert_allclose(drawn[ok] - want[ok], k * err[ok][:, [0, 2]], atol=1e-12)
        magnified = f"error magnified {k:g}x"
        assert (magnified in executed.get_label()) == (k > 1), executed.get_label()
        assert ("times larger" in ax.get_title()) == (k > 1)
        mm = np.concatenate([ln.get_ydata() for ln in panel.get_lines()]).astype(float)
        true_mm = 1e3 * np.linalg.norm(err, axis=1)
        assert np.nanmax(mm) == pytest.approx(true_mm.max(), rel=1e-12)
        assert panel.get_ylabel() == "tip error [mm]" and panel.get_ylim()[0] == 0.0


def test_the_tip_error_axis_starts_at_a_meaningful_floor() -> None:
    """The log axis of fig_tip_error.png starts two decades below the smallest scenario's RMS
    error (the first rows' round-off, 1e-13 mm, below it), or at the data if that is higher."""
    from rrr_robot.writing.plots import tip_error_floor

    ctc = np.concatenate([[0.0, 1e-13, 1e-9], np.full(1000, 0.04)])   # mm
    pd = np.full(1000, 20.0)
    rms = float(np.sqrt(np.mean(ctc**2)))
    assert tip_error_floor({"ctc": ctc, "pd": pd}) == pytest.approx(rms / 100 / 1.25)
    assert tip_error_floor({"pd": pd}) == pytest.approx(20.0 / 1.25)  # the data is higher
    assert tip_error_floor({"x": np.zeros(5)}) is None
    assert tip_error_floor({}) is None


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
