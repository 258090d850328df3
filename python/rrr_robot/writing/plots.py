"""Figures of the writing task, like the paper's Figs 2-9 (PNG files in the output folder).

Drawn with the Agg canvas directly (no pyplot, no GUI backend), at the dpi they are saved with,
so the one layout pass (``tight_layout``) and the drawing share one renderer and its text
metrics. Time series longer than :data:`MAX_PLOT_POINTS` are decimated to their per-bucket
minimum and maximum (:func:`envelope`: the drawn curve covers the same pixels); tick labels of
log axes are plain text (10⁻³, no mathtext parser).
"""

from __future__ import annotations

import functools
import logging
import math
import textwrap
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter

from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.outputs import atomic_path
from ..core.robot import RobotFile
from ..sim.cosim import CosimResult
from .references import NumericReferences, numeric_references
from .trajectory import Reference

log = logging.getLogger(__name__)
JOINTS = ("q1", "q2", "q3")
DPI = 120
#: Time series with more samples are drawn as their envelope of MAX_PLOT_POINTS // 2 buckets
#: (a figure is at most 12 in = 1440 px wide at DPI: a bucket is well under a pixel column).
MAX_PLOT_POINTS = 4000


def envelope(t: FloatArray, y: FloatArray,
             max_points: int = MAX_PLOT_POINTS) -> tuple[FloatArray, FloatArray]:
    """``(t, y)`` unchanged when short; otherwise the first sample, then for each of
    ``(max_points - 2) // 2`` consecutive buckets of samples its minimum and its maximum in time
    order (NaN ignored), then the last sample: a line through them covers the same pixels as
    the full series, extremes and end points exact."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    n = t.shape[0]
    if n <= max_points:
        return t, y
    buckets = max(1, (max_points - 2) // 2)
    k = math.ceil(n / buckets)
    buckets = math.ceil(n / k)
    pad = buckets * k - n
    tp = np.pad(t, (0, pad), mode="edge").reshape(buckets, k)
    yp = np.pad(y, (0, pad), mode="edge").reshape(buckets, k)
    finite = np.isfinite(yp)
    lo = np.argmin(np.where(finite, yp, np.inf), axis=1)
    hi = np.argmax(np.where(finite, yp, -np.inf), axis=1)
    first, second = np.minimum(lo, hi), np.maximum(lo, hi)
    rows = np.arange(buckets)
    tt = np.column_stack([tp[rows, first], tp[rows, second]]).ravel()
    yy = np.column_stack([yp[rows, first], yp[rows, second]]).ravel()
    return np.concatenate([t[:1], tt, t[-1:]]), np.concatenate([y[:1], yy, y[-1:]])


_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075"
                             "\u2076\u2077\u2078\u2079")


class PowerOfTenFormatter(LogFormatter):
    """Log-axis tick labels as plain text with superscript digits (10⁻³; 2 times 10⁻³ between
    decades) instead of mathtext: the same labels, without building matplotlib's mathtext
    parser (about a quarter of a second per process)."""

    def _num_to_string(self, x: float, vmin: float, vmax: float) -> str:
        exponent = math.floor(math.log10(x) + 1e-9)
        coeff = round(x / 10.0**exponent)
        if coeff == 10:
            coeff, exponent = 1, exponent + 1
        power = "10" + str(exponent).translate(_SUPERSCRIPT)
        return power if coeff == 1 else f"{coeff}\u00d7{power}"


def _figure(figsize: tuple[float, float]) -> Figure:
    """A figure on an Agg canvas at the dpi it is saved with."""
    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


#: The figure helpers for the figures of other jobs (rrr_robot.sweep.figures): the same canvas,
#: dpi, layout pass and atomic save.
new_figure = _figure


def _plot_series(ax: Any, t: FloatArray, y: FloatArray, *args: Any, **kwargs: Any) -> None:
    ax.plot(*envelope(t, y), *args, **kwargs)


def _pen_down_xz(xyz: FloatArray, pen_down: np.ndarray) -> tuple[FloatArray, FloatArray]:
    """x and z with NaN where the pen is up, so strokes are drawn apart."""
    x = np.where(pen_down, xyz[:, 0], np.nan)
    z = np.where(pen_down, xyz[:, 2], np.nan)
    return x, z


def _save(fig: Figure, path: Path,
          rect: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0)) -> None:
    """Lay out once (the axes and their labels within ``rect``, in figure fractions) and save
    atomically (core.outputs): the PNG appears complete or not at all. One layout pass: no
    ``bbox_inches="tight"``, which laid the figure out a second time."""
    fig.tight_layout(rect=rect)
    with atomic_path(path) as tmp:  # tmp ends in .part: the format is given
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=DPI)
    log.info("drew %s", path.name)


def _bottom_legend(fig: Figure, pad_points: float = 4.0) -> float:
    """A legend of the figure's labelled lines centred at its bottom edge; returns its height
    with ``pad_points`` above it, as a fraction of the figure's height (the band the layout
    must leave to it)."""
    legend = fig.legend(loc="lower center", ncol=2, frameon=False)
    box = legend.get_window_extent(fig.canvas.get_renderer())  # type: ignore[attr-defined]
    return float((box.y1 + pad_points * fig.dpi / 72.0) / fig.bbox.height)


save_figure = _save


#: The default scenarios whose letters reproduce a figure of the paper: Fig. 7 (PD only) and
#: Fig. 8 (PD + feedforward); the joint-2 components of the second are its Fig. 9.
PAPER_LETTERS = {"pd": 7, "ctc": 8}
PAPER_CONTROLS = {"ctc": 9}
#: Where a legend goes: outside the axes, right of them, so that it never covers a trace (the
#: layout makes room for it).
OUTSIDE: dict[str, Any] = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}


def letters_file(name: str) -> str:
    """``fig7_letters_pd.png``, ``fig8_letters_ctc.png``, ``fig_letters_<name>.png``."""
    number = PAPER_LETTERS.get(name)
    return f"fig{number}_letters_{name}.png" if number else f"fig_letters_{name}.png"


def controls_file(name: str) -> str:
    """``fig9_u2_ctc.png``, ``fig_u2_<name>.png``."""
    return "fig9_u2_ctc.png" if name in PAPER_CONTROLS else f"fig_u2_{name}.png"


#: The letters' axes: at most this wide and this high (in), and never flatter than MIN_HEIGHT;
#: the figure around them is sized so that the letters, drawn at equal aspect, fill them.
LETTERS_WIDTH = 8.6
LETTERS_MAX_HEIGHT = 6.0
LETTERS_MIN_HEIGHT = 1.2
#: Inches around the letters' axes: the y label and ticks (left), the right margin, the two-line
#: title (top), the x label and ticks (bottom) and the legend's band below them.
_LEFT, _RIGHT, _TOP, _BOTTOM, _LEGEND, _PANEL_TITLE = 1.0, 0.4, 0.75, 0.6, 0.4, 0.3
#: The letters figure is at least this wide (in), so that its title and error panel have room
#: beside a high text, and its title is wrapped at about this many characters per inch.
MIN_LETTERS_FIGURE_WIDTH = 5.5
TITLE_CHARS_PER_INCH = 10.5


def xz_ratio(*paths: FloatArray) -> float:
    """Height over width of the x-z extent of ``paths`` ((n, 3) tip positions, NaN rows
    ignored)."""
    pts = np.vstack([p[np.all(np.isfinite(p), axis=1)] for p in paths])
    if not pts.size:
        return 1.0
    return max(float(np.ptp(pts[:, 2])), 1e-9) / max(float(np.ptp(pts[:, 0])), 1e-9)


def letters_box(ratio: float) -> tuple[float, float]:
    """Width and height (in) of axes that show letters of height/width ``ratio`` at equal
    aspect: LETTERS_WIDTH wide, unless the text is so high that LETTERS_MAX_HEIGHT bounds it
    (then narrower); at least LETTERS_MIN_HEIGHT high."""
    width, height = LETTERS_WIDTH, LETTERS_WIDTH * ratio
    if height > LETTERS_MAX_HEIGHT:
        width, height = LETTERS_MAX_HEIGHT / ratio, LETTERS_MAX_HEIGHT
    return width, min(max(height, LETTERS_MIN_HEIGHT), LETTERS_MAX_HEIGHT)


def _letters_figure(ratio: float, below: float, title_lines: int = 1) -> tuple[Figure, float]:
    """A figure for letters of height/width ``ratio`` above ``below`` inches of further axes
    (a panel and its labels): as wide as :func:`letters_box` (at least
    MIN_LETTERS_FIGURE_WIDTH), about as high as it needs (:func:`_fit_letters` makes it
    exact). Returns the figure and the letters' axes height (in) it was planned for."""
    width, height = letters_box(ratio)
    fig = _figure((max(width + _LEFT + _RIGHT, MIN_LETTERS_FIGURE_WIDTH),
                   height + _TOP + 0.25 * (title_lines - 1) + _BOTTOM + below))
    return fig, height


def _fit_letters(fig: Figure, ax: Any, ratio: float,
                 rect: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0)) -> None:
    """Lay out, then change the figure's height so that the letters' axes ``ax`` get the
    height their width asks for at equal aspect (``ratio``: height over width of the letters,
    bounded as :func:`letters_box` bounds it); ``rect``: the layout's rectangle (the legend's
    band at the present height). The axes keep their slot (``adjustable="datalim"``): equal
    aspect, the box filled, the letters filling it in the direction that bounds them."""
    ax.set_aspect("equal", adjustable="datalim")
    fig.tight_layout(rect=rect)
    w_in, h_in = fig.get_size_inches()
    slot = ax.get_position(original=True)
    want = min(max(slot.width * w_in * ratio, LETTERS_MIN_HEIGHT), LETTERS_MAX_HEIGHT)
    fig.set_size_inches(w_in, max(h_in + want - slot.height * h_in, 1.0))


def fig_reference(out: Path, ref: Reference) -> None:
    """Fig 2: the reference path at equal aspect, in axes sized to the text, and the tip speed
    below it."""
    ratio = xz_ratio(np.where(ref.pen_down[:, None], ref.x, np.nan))
    panel = 1.8
    fig, height = _letters_figure(ratio, panel + _TOP + _BOTTOM)
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw={"height_ratios": [height, panel]})
    ax1.plot(*_pen_down_xz(ref.x, ref.pen_down), "k-", lw=1.5)
    ax1.set(xlabel="x [m]", ylabel="z [m]",
            title=f"Fig. 2: reference tip path in y = {ref.x[0, 1]:.3f} m")
    _plot_series(ax2, ref.t, ref.speed, "b-", lw=1)
    ax2.set(xlabel="t [s]", ylabel="tip speed [m/s]",
            title="Fig. 2: tip speed v = sqrt(xd^2 + zd^2) (eq 14)")
    ax2.grid(True)
    _fit_letters(fig, ax1, ratio)
    _save(fig, out / "fig2_reference.png")


def fig_joints(out: Path, ref: Reference) -> None:
    for data, unit, name, title in ((ref.q, "q_ref [rad]", "fig3_joint_positions.png",
                                     "Fig. 3: reference joint positions"),
                                    (ref.qd, "qd_ref [rad/s]", "fig4_joint_velocities.png",
                                     "Fig. 4: reference joint velocities")):
        fig = _figure((9, 4))
        ax = fig.subplots()
        for i in range(3):
            _plot_series(ax, ref.t, data[:, i], label=JOINTS[i])
        ax.set(xlabel="t [s]", ylabel=unit, title=title)
        ax.grid(True)
        ax.legend(**OUTSIDE)
        _save(fig, out / name)


def fig_differences(out: Path, model: Model, robot: RobotFile, ref: Reference,
                    references: NumericReferences | None = None) -> None:
    """Figs 5 and 6: closed form against MuJoCo's numeric IK and its mj_inverse
    (``references``: computed beforehand; without them they are computed here)."""
    refs = references if references is not None else numeric_references(model, robot, ref)
    _diff_plot(out / "fig5_ik_difference.png", ref.t, ref.q - refs.ik, "rad",
               "Fig. 5: closed-form minus numeric (MuJoCo least squares) inverse kinematics",
               quantity="q closed form - q numeric")
    if refs.tau is None:
        log.warning("Fig 6 skipped: %s", refs.tau_skipped)
        return
    tau = model.inverse_dynamics(ref.q, ref.qd, ref.qdd)
    _diff_plot(out / "fig6_torque_difference.png", ref.t, tau - refs.tau, "N m",
               "Fig. 6: closed-form R p minus MuJoCo mj_inverse inverse dynamics",
               quantity="tau R p - tau mj_inverse")


def _diff_plot(path: Path, t: FloatArray, diff: FloatArray, unit: str, title: str,
               quantity: str = "difference") -> None:
    fig = _figure((9, 4))
    ax = fig.subplots()
    for i in range(3):
        _plot_series(ax, t, diff[:, i], label=f"joint {i + 1}", lw=0.8)
    ax.set(xlabel="t [s]", ylabel=f"{quantity} [{unit}]", title=f"{title}\nmax |difference| = "
           f"{np.abs(diff).max():.2e} {unit}")
    ax.grid(True)
    ax.legend(**OUTSIDE)
    _save(fig, path)


_LETTERS_TITLE = {7: "Fig. 7: reference letters and the letters written with PD control only",
                  8: "Fig. 8: reference letters and the letters written with PD + feedforward"}


#: The executed path's largest deviation from the reference is drawn magnified to about this
#: share of the letter height when it is smaller (the factor a round 2, 5 or 10 times a power
#: of ten): at the scale of the letters a 0.1 mm error is no wider than the line.
VISIBLE_ERROR = 0.04


def error_magnification(err_max: float, letter_height: float) -> float:
    """The factor the letters figure magnifies the tip error by: 1 when the largest error is
    already VISIBLE_ERROR of the letter height or more (or not finite), otherwise the largest
    of 2, 5, 10, 20, 50, ... that keeps it at most that."""
    target = VISIBLE_ERROR * letter_height
    if not (math.isfinite(err_max) and err_max > 0.0) or err_max * 2.0 > target:
        return 1.0
    limit = target / err_max
    exponent = math.floor(math.log10(limit))
    return float(max(m * 10.0**exponent for m in (1.0, 2.0, 5.0) if m * 10.0**exponent <= limit))


def fig_letters(out: Path, ref: Reference, results: Mapping[str, CosimResult],
                title: str | None = None, file: str | None = None) -> None:
    """The letters written by each scenario against the reference: Figs 7 (pd) and 8 (ctc) of
    the paper, the other scenarios under descriptive names (:func:`letters_file`); ``title``
    and ``file``: another first title line and file name (one result: the CAN bench's).

    The letters are drawn at equal aspect in axes sized to them (:func:`letters_box`), the
    reference dashed over the executed path; an error too small to see at that scale is drawn
    magnified (:func:`error_magnification`: reference + k (tip - reference), the factor in the
    legend), and a panel below gives the tip error along the path in mm (pen down; pen up
    grey)."""
    for name, res in results.items():
        # the pen of each result row (a tool's results may start after the reference's t_0)
        pen = (ref.pen_down if res.t.shape == ref.t.shape else
               ref.pen_down[np.clip(np.searchsorted(ref.t, res.t - 1e-9), 0, ref.t.size - 1)])
        err = np.linalg.norm(res.tip - res.x_ref, axis=1)
        finite = err[np.isfinite(err)]
        err_max = float(finite.max()) if finite.size else float("nan")
        k = error_magnification(err_max, ref.spec.letter_height)
        shown = res.x_ref + k * (res.tip - res.x_ref)
        ratio = xz_ratio(np.where(ref.pen_down[:, None], ref.x, np.nan),
                         np.where(pen[:, None], shown, np.nan))
        width, _ = letters_box(ratio)
        number = PAPER_LETTERS.get(name)
        head = title or (f"{_LETTERS_TITLE[number]} (scenario {name})" if number
                         else f"Letters written in scenario {name}")
        # the title wrapped to the figure's width (a high text makes a narrow figure)
        fig_width = max(width + _LEFT + _RIGHT, MIN_LETTERS_FIGURE_WIDTH)
        lines = [*textwrap.wrap(head, width=int(fig_width * TITLE_CHARS_PER_INCH)),
                 f"max tip error {1e3 * err_max:.2f} mm"
                 + (f" (drawn {k:g} times larger)" if k > 1 else "")]
        panel = 1.4
        fig, height = _letters_figure(ratio, panel + _PANEL_TITLE + _BOTTOM + _LEGEND,
                                      len(lines) - 1)
        ax, ax_err = fig.subplots(2, 1, gridspec_kw={"height_ratios": [height, panel]})
        label = f"executed ({name})" + (f", error magnified {k:g}x" if k > 1 else "")
        ax.plot(*_pen_down_xz(shown, pen), "-", color="tab:red", lw=1.8, alpha=0.85,
                label=label, zorder=2)
        ax.plot(*_pen_down_xz(ref.x, ref.pen_down), "k--", lw=0.9, label="reference", zorder=3)
        ax.set(xlabel="x [m]", ylabel="z [m]", title="\n".join(lines))
        mm = 1e3 * err
        ax_err.plot(res.t, np.where(pen, np.nan, mm), "-", color="0.7", lw=0.8)
        ax_err.plot(res.t, np.where(pen, mm, np.nan), "-", color="tab:red", lw=0.9)
        ax_err.set(xlabel="t [s]", ylabel="tip error [mm]",
                   title="the tip error along the path, true size (grey: pen up)",
                   ylim=(0.0, 1.08 * float(np.nanmax(mm)) if np.any(np.isfinite(mm)) and
                         np.nanmax(mm) > 0 else 1.0))
        ax_err.set_xlim(float(res.t[0]), float(res.t[-1]))
        ax_err.grid(True)
        # below the axes and their labels, never over the letters: in a band at the bottom as
        # high as the legend, which the layout keeps free (it does not see a figure legend)
        _fit_letters(fig, ax, ratio, (0.0, _bottom_legend(fig), 1.0, 1.0))
        fig.legends.clear()
        _save(fig, out / (file or letters_file(name)), rect=(0.0, _bottom_legend(fig), 1.0, 1.0))


def fig_controls(out: Path, results: Mapping[str, CosimResult]) -> None:
    """Fig 9: model (u_n) and PD (u_c) parts of the joint-2 input, per scenario."""
    for name, res in results.items():
        fig = _figure((9, 4))
        ax = fig.subplots()
        _plot_series(ax, res.t, res.u_n[:, 1], "b-", lw=1, label="u_n,2 (model)")
        _plot_series(ax, res.t, res.u_c[:, 1], "r-", lw=1, label="u_c,2 (PD)")
        what = "model (u_n) and PD (u_c) components of the joint-2 input"
        ax.set(xlabel="t [s]", ylabel="u_n,2 and u_c,2 [V]",
               title=f"Fig. 9: {what} (scenario {name})" if name in PAPER_CONTROLS
               else f"The {what}, scenario {name}")
        ax.grid(True)
        ax.legend(**OUTSIDE)
        _save(fig, out / controls_file(name))


#: The tip error figure's log axis starts this far below the smallest RMS tip error of its
#: scenarios (or at the smallest error, if that is higher): the start of a run, where the
#: error rises from exactly 0 through round-off (1e-13 mm), is below it.
TIP_ERROR_DECADES = 2.0


def tip_error_floor(errors: Mapping[str, FloatArray]) -> float | None:
    """The lower end of the tip error figure's log axis (mm): TIP_ERROR_DECADES below the
    smallest RMS error of ``errors`` (per scenario, mm), or the smallest positive error if
    that is higher, divided by 1.25; None without a positive finite error."""
    rms = [float(np.sqrt(np.mean(e[np.isfinite(e)] ** 2))) for e in errors.values()
           if np.any(np.isfinite(e))]
    positive = np.concatenate([e[np.isfinite(e) & (e > 0.0)] for e in errors.values()]) \
        if errors else np.zeros(0)
    if not positive.size:
        return None
    floor = min(rms) * 10.0**-TIP_ERROR_DECADES if rms and min(rms) > 0 else 0.0
    return max(floor, float(positive.min())) / 1.25


def fig_tip_error(out: Path, results: Mapping[str, CosimResult]) -> None:
    fig = _figure((9, 4))
    ax = fig.subplots()
    errors = {name: 1e3 * np.linalg.norm(res.tip - res.x_ref, axis=1)
              for name, res in results.items()}
    for name, res in results.items():
        _plot_series(ax, res.t, errors[name], lw=0.8, label=name)
    ax.set_yscale("log")
    low = tip_error_floor(errors)
    if low is not None:  # where the errors are: not down to the round-off of the first rows
        top = max(float(np.nanmax(e)) for e in errors.values() if np.any(np.isfinite(e)))
        ax.set_ylim(low, top * 1.25)
    ax.yaxis.set_major_formatter(PowerOfTenFormatter())
    ax.yaxis.set_minor_formatter(PowerOfTenFormatter(labelOnlyBase=False))
    ax.set(xlabel="t [s]", ylabel="tip error |tip - x_ref| [mm]",
           title=f"Cartesian tip error ({', '.join(results)})")
    ax.grid(True, which="both")
    ax.legend(**OUTSIDE)
    _save(fig, out / "fig_tip_error.png")


#: The figures that depend on the reference only (figure_worker draws them during the
#: co-simulations), by name.
REFERENCE_FIGURES = ("fig2_reference.png", "fig3_joint_positions.png",
                     "fig4_joint_velocities.png", "fig5_ik_difference.png",
                     "fig6_torque_difference.png")


def write_reference_figures(out: Path, model: Model, robot: RobotFile, ref: Reference) -> None:
    """Figs 2-6: the reference, its joint motion, and the closed form against the numeric
    references (Fig 6 skipped, with a warning, for a robot file without link tables)."""
    fig_reference(out, ref)
    fig_joints(out, ref)
    fig_differences(out, model, robot, ref)


def result_figure_count(results: Mapping[str, CosimResult]) -> int:
    """How many figures :func:`write_result_figures` draws."""
    return 2 * len(results) + 1


def write_result_figures(out: Path, ref: Reference, results: Mapping[str, CosimResult],
                         progress: Callable[[int, int], None] | None = None) -> None:
    """Figs 7-9 and the tip error: the co-simulated scenarios; ``progress(done, total)`` after
    each figure."""
    steps: list[Callable[[], None]] = [
        *(functools.partial(fig_letters, out, ref, {name: res}) for name, res in results.items()),
        *(functools.partial(fig_controls, out, {name: res}) for name, res in results.items()),
        functools.partial(fig_tip_error, out, results),
    ]
    for k, step in enumerate(steps):
        step()
        if progress is not None:
            progress(k + 1, len(steps))


def write_figures(out: Path, model: Model, robot: RobotFile, ref: Reference,
                  results: Mapping[str, CosimResult]) -> None:
    """Every figure of one writing-task run, in this process."""
    write_reference_figures(out, model, robot, ref)
    write_result_figures(out, ref, results)


# the drawing helpers the CAN bench's figures share (rrr_robot.hil.figures)
new_figure = _figure
save_figure = _save
plot_series = _plot_series
