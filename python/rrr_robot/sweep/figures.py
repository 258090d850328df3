"""Figures of a sweep (PNG, drawn like the writing task's: rrr_robot.writing.plots):

- ``fig_sweep_tip_error.png``: the distribution of the maximum and RMS tip error over the runs
  (histogram and empirical distribution function), with the runs of each status;
- ``fig_sweep_dependence.png``: the maximum tip error against the inputs of the ranking (every
  varied key's most sensitive input, then the next ones, at most :data:`MAX_PANELS`, in ranking
  order), saturated runs marked;
- ``fig_sweep_sensitivity.png``: the ranking (S1 of each input, with its noise floor).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..writing.plots import new_figure, save_figure
from .sensitivity import Input, Sensitivity

log = logging.getLogger(__name__)

__all__ = ["FIGURES", "write_figures"]

FIGURES = ("fig_sweep_tip_error.png", "fig_sweep_dependence.png", "fig_sweep_sensitivity.png")
MAX_PANELS = 12
MAX_BARS = 30
_COLORS = {"ok": "tab:blue", "saturated": "tab:orange"}
#: Points of the dependence figure: filled circles this large (pt), a little transparent so
#: that overlapping runs show as darker.
MARKER_SIZE = 5.0


def _counts(status: Sequence[str]) -> str:
    names, counts = np.unique(np.asarray(status, dtype=object), return_counts=True)
    return ", ".join(f"{n} {c}" for n, c in zip(names, counts, strict=True))


def fig_tip_error(out: Path, tip_max: np.ndarray, tip_rms: np.ndarray,
                  status: Sequence[str]) -> None:
    fig = new_figure((11, 4))
    ax1, ax2 = fig.subplots(1, 2)
    finite = np.isfinite(tip_max)
    mm = 1e3 * tip_max[finite]
    if mm.size:
        lo, hi = float(mm.min()), float(mm.max())
        log_x = lo > 0 and hi / lo > 20
        edges = (np.geomspace(lo, hi, 31) if log_x else
                 np.linspace(lo, hi if hi > lo else lo + 1e-9, 31))
        ax1.hist(mm, bins=edges, color="tab:blue", alpha=0.8)
        if log_x:
            ax1.set_xscale("log")
        for values, label in ((tip_max, "max"), (tip_rms, "RMS")):
            v = np.sort(1e3 * values[np.isfinite(values)])
            ax2.step(v, np.arange(1, v.size + 1) / v.size, where="post", label=label)
        if log_x:
            ax2.set_xscale("log")
        ax2.legend()
    ax1.set(xlabel="maximum tip error [mm]", ylabel="runs",
            title=f"{len(status)} runs ({_counts(status)})")
    ax2.set(xlabel="tip error [mm]", ylabel="fraction of runs with finite error",
            title="Empirical distribution")
    ax1.grid(True)
    ax2.grid(True)
    save_figure(fig, out / FIGURES[0])


def _panels(ranking: Sequence[Sensitivity]) -> list[Sensitivity]:
    """The inputs drawn: each varied key's most sensitive input first (so every key has its
    panel), then the next most sensitive ones, at most MAX_PANELS, in ranking order."""
    firsts: dict[str, Sensitivity] = {}
    for s in ranking:
        firsts.setdefault(s.input.split("[", 1)[0], s)
    chosen = {s.input for s in list(firsts.values())[:MAX_PANELS]}
    for s in ranking:
        if len(chosen) >= MAX_PANELS:
            break
        chosen.add(s.input)
    return [s for s in ranking if s.input in chosen]


def fig_dependence(out: Path, inputs: Mapping[str, Input], ranking: Sequence[Sensitivity],
                   tip_max: np.ndarray, status: Sequence[str]) -> None:
    ranking = _panels(ranking)
    shown = [inputs[s.input] for s in ranking]
    cols = min(3, len(shown))
    rows = math.ceil(len(shown) / cols)
    fig = new_figure((4.2 * cols, 3.2 * rows))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    st = np.asarray(status, dtype=object)
    y = 1e3 * tip_max
    jitter = np.random.default_rng(0).uniform(-0.15, 0.15, size=y.size)  # drawing only
    for ax, inp, sens in zip(axes, shown, ranking, strict=False):
        for name, color in _COLORS.items():
            sel = (st == name) & np.isfinite(y)
            x = inp.values[sel] + (0.0 if inp.numeric else jitter[sel])
            ax.plot(x, y[sel], "o", ms=MARKER_SIZE, alpha=0.7, mec="none", color=color,
                    label=name if sel.any() else None)
        if not inp.numeric:
            ax.set_xticks(range(len(inp.categories)))
            ax.set_xticklabels([c if len(c) <= 14 else c[:12] + ".." for c in inp.categories],
                               rotation=20, fontsize=8)
        ax.set(xlabel=inp.name, ylabel="max tip error [mm]", title=f"S1 {sens.s1:.2f}")
        ax.grid(True)
    for ax in axes[len(shown):]:
        ax.set_visible(False)
    axes[0].legend(fontsize=8, markerscale=1.5)
    save_figure(fig, out / FIGURES[1])


def fig_sensitivity(out: Path, ranking: Sequence[Sensitivity]) -> None:
    shown = list(ranking[:MAX_BARS])[::-1]
    fig = new_figure((8, 1.0 + 0.3 * len(shown)))
    ax = fig.subplots()
    pos = np.arange(len(shown))
    ax.barh(pos, [s.s1 for s in shown], color="tab:blue")
    ax.plot([s.noise_floor for s in shown], pos, "k|", ms=10, label="noise floor")
    ax.set_yticks(pos)
    ax.set_yticklabels([s.input if s.spearman is None else f"{s.input} (rho {s.spearman:+.2f})"
                        for s in shown], fontsize=8)
    ax.set(xlim=(0, 1), xlabel="S1: share of the variance of the maximum tip error",
           title="Sensitivity ranking (first-order index, from the runs)")
    ax.grid(True, axis="x")
    ax.legend(fontsize=8, loc="lower right")
    save_figure(fig, out / FIGURES[2])


def write_figures(out: Path, inputs: Sequence[Input], ranking: Sequence[Sensitivity],
                  tip_max: np.ndarray, tip_rms: np.ndarray, status: Sequence[str]) -> list[str]:
    """Draw the figures into ``out``; returns their names (the dependence and ranking figures
    need a ranked input)."""
    fig_tip_error(out, tip_max, tip_rms, status)
    if not ranking:
        log.info("no input varied the tip error: no dependence or sensitivity figure")
        return [FIGURES[0]]
    fig_dependence(out, {i.name: i for i in inputs}, ranking, tip_max, status)
    fig_sensitivity(out, ranking)
    return list(FIGURES)
