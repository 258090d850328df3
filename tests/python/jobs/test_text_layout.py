"""The text layout of the writing task (rrr_robot.writing.trajectory, ``rrr writing --text``):
newlines start new lines; a text too large for the writing area is scaled down to fit, down to
min_letter_height, below which it is refused with the numbers; --scale applies to the fitted
height; ``rrr writing --help`` states the writing area and the glyphs (checked against the default
robot); the figures' legends never cover the axis labels or the letters."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from matplotlib.transforms import Bbox
from rrr_robot.cli import writing as cli_writing
from rrr_robot.core.robot import MAX_TEXT
from rrr_robot.sim.cosim import CosimResult
from rrr_robot.writing import plots
from rrr_robot.writing import trajectory as tr
from rrr_robot.writing.job import WritingJob, prepare

MODEL = rr.Model.default()


def pen_down_extent(ref: tr.Reference) -> tuple[np.ndarray, np.ndarray]:
    xz = ref.x[ref.pen_down][:, [0, 2]]
    return xz.min(axis=0), xz.max(axis=0)


def test_hello_world_is_scaled_down_to_fill_the_area() -> None:
    spec = tr.WritingSpec(text="Hello, world")
    with pytest.raises(rr.BadInputError, match=r"0\.54\d m wide"):   # as it was: too wide
        tr.writing_path(spec)
    assert spec.fit_to_area and spec.letter_height == 0.07
    height = tr.fit_letter_height(spec)
    assert spec.min_letter_height <= height < 0.07
    ref = tr.make_reference(MODEL, spec)
    assert ref.spec.letter_height == height
    lo, hi = pen_down_extent(ref)
    room = np.array([spec.x_range[1] - spec.x_range[0], spec.z_range[1] - spec.z_range[0]])
    # the width fills the area (the fitted curve differs from the polyline by the smoothing)
    assert hi[0] - lo[0] == pytest.approx(room[0], abs=2e-3)
    assert lo[0] >= spec.x_range[0] - 1e-3 and hi[0] <= spec.x_range[1] + 1e-3


def test_a_text_that_fits_keeps_its_height() -> None:
    spec = tr.WritingSpec()
    assert tr.fit_letter_height(spec) == spec.letter_height
    assert tr.fitted_spec(spec) is spec


def test_newlines_start_new_lines() -> None:
    spec = tr.WritingSpec(text="Hello\nworld")
    ref = tr.make_reference(MODEL, spec)
    assert ref.spec.letter_height == 0.07        # two lines fit at the default height
    one = tr.make_reference(MODEL, tr.WritingSpec(text="Hello"))
    lo, hi = pen_down_extent(ref)
    lo1, hi1 = pen_down_extent(one)
    # two lines: about one line spacing (1.6 letter heights) higher than the first line alone,
    # and narrower than "Hello world" on one line
    assert (hi[1] - lo[1]) - (hi1[1] - lo1[1]) == pytest.approx(1.6 * 0.07, abs=0.03)
    wide = tr.WritingSpec(text="Hello world", fit_to_area=False)
    with pytest.raises(rr.BadInputError, match="wide"):
        tr.writing_path(wide)


def test_too_long_a_text_is_refused_with_the_numbers() -> None:
    spec = tr.WritingSpec(text="The quick brown fox jumps over the lazy dog")
    with pytest.raises(rr.BadInputError) as err:
        tr.make_reference(MODEL, spec)
    message = str(err.value)
    for part in ("m wide", "0.300 m x 0.250 m", "would fit only at letter_height 0.01",
                 "below min_letter_height 0.02 m", "newlines"):
        assert part in message, message
    # the minimum is a spec field (a robot file's [writing] min_letter_height)
    smaller = replace(spec, min_letter_height=0.01)
    assert tr.fit_letter_height(smaller) < 0.02


def test_no_fit_keeps_the_old_refusal() -> None:
    with pytest.raises(rr.BadInputError, match="high"):
        tr.make_reference(MODEL, tr.WritingSpec(text="a\nb\nc", fit_to_area=False))


def test_scale_applies_to_the_fitted_height(tmp_path: Path) -> None:
    fitted = tr.fit_letter_height(tr.WritingSpec(text="Hello, world"))
    _, _, _, ref = prepare(WritingJob(out=tmp_path / "o", text="Hello, world", scale=0.5))
    assert ref.spec.letter_height == pytest.approx(0.5 * fitted, rel=1e-12)
    with pytest.raises(rr.BadInputError, match="writing area"):
        prepare(WritingJob(out=tmp_path / "o", text="Hello, world", scale=1.5))


def test_cli_text_backslash_n_is_a_newline() -> None:
    assert cli_writing._text("Hello\\nworld") == "Hello\nworld"
    assert cli_writing._text("Hello\nworld") == "Hello\nworld"
    assert cli_writing._text(None) is None


def test_help_states_the_writing_area_and_the_glyphs() -> None:
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--help"],
                          capture_output=True, text=True, timeout=60, check=True)
    text = " ".join(proc.stdout.split())
    spec = tr.WritingSpec.from_robot(rr.read_robot_file())
    (x0, x1), (z0, z1) = spec.x_range, spec.z_range
    for part in (f"x from {x0:.2f} to {x1:.2f} m and z from {z0:.2f} to {z1:.2f} m",
                 f"({x1 - x0:.2f} m x {z1 - z0:.2f} m)",
                 f"vertical plane y = {spec.plane_y:.2f} m",
                 f"capital letters {spec.letter_height:.2f} m high",
                 f"lines {spec.line_spacing:g} letter heights apart",
                 f"down to letters {spec.min_letter_height:.2f} m high",
                 f"Hershey font '{spec.latin_font}'", f"Hershey font '{spec.greek_font}'",
                 f"at most {MAX_TEXT} characters", "printable ASCII", "Greek alphabet"):
        assert part in text, part


@pytest.mark.parametrize(("text", "written", "fitted"), [
    ("Hello, world", "Hello, world", True), ("Hello\\nworld", "Hello\nworld", False)])
def test_runs_with_default_options(tmp_path: Path, text: str, written: str,
                                   fitted: bool) -> None:
    """The issue's examples through the command line with every default but the figures (three
    scenarios through the FMUs; the README's first command draws the figures with every default,
    test_figures.py checks them)."""
    import json

    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--out", str(out),
                           "-q", "--text", text, "--no-figures"], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reference"]["text"] == written
    height = summary["reference"]["letter_height"]
    assert (0.02 <= height < 0.07) if fitted else height == 0.07
    assert set(summary["scenarios"]) == {"pd", "ctc", "mismatch"}
    assert all(s["status"] == "ok" for s in summary["scenarios"].values())
    assert summary["scenarios"]["ctc"]["tip_error_max"] < 1e-3


# ---- legends ----------------------------------------------------------------------------------

def _fake_results(ref: tr.Reference) -> dict[str, CosimResult]:
    out = {}
    for k, name in enumerate(("pd", "ctc")):
        wobble = 1e-4 * (k + 1) * np.sin(np.outer(ref.t, [3.0, 5.0, 7.0]))
        out[name] = CosimResult(
            t=ref.t, q_ref=ref.q, qd_ref=ref.qd, x_ref=ref.x, q=ref.q + wobble, qd=ref.qd,
            qdd=ref.qdd, tip=ref.x + wobble, u=np.cos(np.outer(ref.t, [1.0, 2.0, 3.0])),
            u_n=np.sin(np.outer(ref.t, [1.0, 2.0, 3.0])), u_c=wobble, wall_time=0.01)
    return out


def _labels(fig: Any) -> list[Bbox]:
    renderer = fig.canvas.get_renderer()
    boxes = []
    for ax in fig.axes:
        texts = [ax.xaxis.label, ax.yaxis.label, ax.title,
                 *ax.get_xticklabels(), *ax.get_yticklabels()]
        boxes += [t.get_window_extent(renderer) for t in texts if t.get_visible() and t.get_text()]
    return boxes


@pytest.mark.parametrize("text", ["Hello, world", "Hi\nyou\nall", "a\u03c9m\u03b3"])
def test_legends_cover_no_axis_label_and_no_letter(text: str, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    ref = tr.make_reference(MODEL, tr.WritingSpec(text=text))
    figures: dict[str, Any] = {}
    save = plots._save

    def keep(fig: Any, path: Path, *args: Any, **kwargs: Any) -> None:
        save(fig, path, *args, **kwargs)
        figures[path.name] = fig

    monkeypatch.setattr(plots, "_save", keep)
    plots.fig_reference(tmp_path, ref)
    plots.fig_joints(tmp_path, ref)
    plots.write_result_figures(tmp_path, ref, _fake_results(ref))
    assert {"fig7_letters_pd.png", "fig8_letters_ctc.png", "fig_tip_error.png"} <= set(figures)
    checked = 0
    for name, fig in figures.items():
        renderer = fig.canvas.get_renderer()
        legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
        for legend in legends:
            box = legend.get_window_extent(renderer)
            assert fig.bbox.contains(box.x0, box.y0) and fig.bbox.contains(box.x1, box.y1), name
            for label in _labels(fig):
                assert not box.overlaps(label), f"{name}: the legend covers an axis label"
            if "_letters_" in name:
                for ax in fig.axes:  # the letters are drawn inside the axes
                    assert not box.overlaps(ax.get_window_extent(renderer)), name
            checked += 1
    assert checked >= 6


def _kept_figures(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Every figure the plotting modules save, by file name (each saved as usual too)."""
    from rrr_robot.hil import figures as hil_figures

    figures: dict[str, Any] = {}
    save = plots._save

    def keep(fig: Any, path: Path, *args: Any, **kwargs: Any) -> None:
        save(fig, path, *args, **kwargs)
        figures[path.name] = fig

    monkeypatch.setattr(plots, "_save", keep)
    monkeypatch.setattr(hil_figures, "save_figure", keep)
    return figures


def test_titles_stay_inside_and_legends_off_the_traces(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Every figure of a run (the writing task's Figs 2-4 and 7-9, a Fig 5/6-style difference,
    the tip error, the CAN bench's): titles and axis labels inside the figure (none clipped),
    legends inside the figure and off every trace (no drawn point of a line inside a legend's
    box, in display coordinates), log axes starting at a meaningful floor; the default scenarios'
    letters are Figs 7 and 8 by name and title, the CAN bench's titles name the scenario."""
    from rrr_robot.hil.figures import write_bench_figures

    ref = tr.make_reference(MODEL, tr.WritingSpec(text="a\u03c9m\u03b3"))
    figures = _kept_figures(monkeypatch)
    results = _fake_results(ref)
    plots.fig_reference(tmp_path, ref)
    plots.fig_joints(tmp_path, ref)
    plots._diff_plot(tmp_path / "fig5_ik_difference.png", ref.t,
                     1e-13 * np.sin(np.outer(ref.t, [1.0, 2.0, 3.0])), "rad", "Fig. 5: test")
    plots.write_result_figures(tmp_path, ref, results)
    bench_out = tmp_path / "bench"
    bench_out.mkdir()
    write_bench_figures(bench_out, ref, results["ctc"], results["pd"], scenario="ctc")
    assert {"fig7_letters_pd.png", "fig8_letters_ctc.png", "fig9_u2_ctc.png", "fig_u2_pd.png",
            "fig_letters_bench.png", "fig_voltages.png"} <= set(figures)
    titles = {name: " ".join(ax.get_title() for ax in fig.axes) for name, fig in figures.items()}
    assert titles["fig7_letters_pd.png"].startswith("Fig. 7: ") and "PD control only" in \
        titles["fig7_letters_pd.png"]
    assert titles["fig8_letters_ctc.png"].startswith("Fig. 8: ") and "feedforward" in \
        titles["fig8_letters_ctc.png"]
    assert titles["fig9_u2_ctc.png"].startswith("Fig. 9: ")
    for n in (2, 3, 4, 5):
        assert any(t.startswith(f"Fig. {n}: ") for t in titles.values()), n
    for name in ("fig_letters_bench.png", "fig_bench_vs_cosim.png", "fig_joint_errors.png",
                 "fig_voltages.png"):
        assert "scenario ctc" in titles[name], (name, titles[name])
    for name, fig in figures.items():
        renderer = fig.canvas.get_renderer()
        inside = fig.bbox
        for ax in fig.axes:
            for text in (ax.title, ax.xaxis.label, ax.yaxis.label):
                if text.get_text():
                    box = text.get_window_extent(renderer)
                    assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and \
                        inside.y0 <= box.y0 and box.y1 <= inside.y1, \
                        f"{name}: {text.get_text()!r} is clipped"
            if ax.get_yscale() == "log":
                # from a meaningful floor (plots.tip_error_floor: two decades below the
                # smallest RMS error, not the round-off at the start), never below the data
                ys = np.concatenate([line.get_ydata() for line in ax.get_lines()])
                ys = ys[np.isfinite(ys) & (ys > 0)]
                low, high = ax.get_ylim()
                rms = min(float(np.sqrt(np.mean(
                    (1e3 * np.linalg.norm(r.tip - r.x_ref, axis=1)) ** 2)))
                    for r in results.values())
                assert ys.min() / 1.5 <= low and ys.max() <= high, name
                assert low == pytest.approx(max(rms / 100, ys.min()) / 1.25, rel=1e-9), name
        legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
        assert legends or name == "fig2_reference.png", name  # one trace per axes
        for legend in legends:
            box = legend.get_window_extent(renderer)
            assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 \
                and box.y1 <= inside.y1, f"{name}: the legend leaves the figure"
            for ax in fig.axes:
                for line in ax.get_lines():
                    xy = np.column_stack([line.get_xdata(), line.get_ydata()]).astype(float)
                    xy = xy[np.all(np.isfinite(xy), axis=1)]
                    if xy.size == 0:
                        continue
                    pts = ax.transData.transform(xy)
                    hit = ((pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1)
                           & (pts[:, 1] >= box.y0) & (pts[:, 1] <= box.y1))
                    assert not hit.any(), f"{name}: the legend covers {line.get_label()!r}"
