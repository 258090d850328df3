"""Figures of a CAN bench run (PNG, drawn like the writing task's with rrr_robot.writing.plots):
the letters written over CAN against the reference, the difference to the unquantised
co-simulation, the joint errors, the voltages and, in real time, the wake-up latencies."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..core._arrays import FloatArray
from ..sim.cosim import CosimResult
from ..writing.plots import JOINTS, OUTSIDE, fig_letters, new_figure, plot_series, save_figure
from ..writing.trajectory import Reference

__all__ = ["FIGURES", "LATENCY_FIGURE", "write_bench_figures"]

#: The figures of every run, and the one of a real-time run.
FIGURES = ("fig_letters_bench.png", "fig_bench_vs_cosim.png", "fig_joint_errors.png",
           "fig_voltages.png")
LATENCY_FIGURE = "fig_latency.png"


def fig_difference(out: Path, bench: CosimResult, other: CosimResult, scenario: str) -> None:
    """Bench minus the unquantised co-simulation: joint positions and voltages."""
    m = min(bench.t.shape[0], other.t.shape[0])
    fig = new_figure((10, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for i in range(3):
        plot_series(ax1, bench.t[:m], bench.q[:m, i] - other.q[:m, i], lw=0.8, label=JOINTS[i])
        plot_series(ax2, bench.t[:m], bench.u[:m, i] - other.u[:m, i], lw=0.8,
                    label=f"u{i + 1}")
    dq = np.abs(bench.q[:m] - other.q[:m]).max()
    du = np.abs(bench.u[:m] - other.u[:m]).max()
    ax1.set(ylabel="q bench - q co-sim. [rad]",
            title=f"CAN bench minus unquantised co-simulation, scenario "
            f"{scenario}: max |dq| {dq:.2e} rad, max |du| {du:.2e} V")
    ax2.set(xlabel="t [s]", ylabel="u bench - u co-sim. [V]")
    for ax in (ax1, ax2):
        ax.grid(True)
        ax.legend(**OUTSIDE)
    save_figure(fig, out / "fig_bench_vs_cosim.png")


def _against_cosim(out: Path, name: str, t: tuple[FloatArray, FloatArray],
                   y: tuple[FloatArray, FloatArray], labels: tuple[str, str, str],
                   ylabel: str, title: str) -> None:
    """Three channels of the bench (solid) and of the co-simulation (dashed), one colour each."""
    fig = new_figure((10, 4))
    ax = fig.subplots()
    for i in range(3):
        line = ax.plot([], [])[0]
        for (tt, yy), style, who in (((t[0], y[0]), "-", "bench"),
                                     ((t[1], y[1]), "--", "co-simulation")):
            plot_series(ax, tt, yy[:, i], style, lw=0.9, color=line.get_color(),
                        label=f"{labels[i]} {who}")
    ax.set(xlabel="t [s]", ylabel=ylabel, title=title)
    ax.grid(True)
    ax.legend(fontsize="small", **OUTSIDE)
    save_figure(fig, out / name)


def fig_joint_errors(out: Path, bench: CosimResult, other: CosimResult, scenario: str) -> None:
    """q - q_ref of the bench (solid) and of the unquantised co-simulation (dashed)."""
    _against_cosim(out, "fig_joint_errors.png", (bench.t, other.t),
                   (bench.q - bench.q_ref, other.q - other.q_ref), JOINTS, "q - q_ref [rad]",
                   f"Joint errors on the CAN bench and co-simulated, scenario {scenario}")


def fig_voltages(out: Path, bench: CosimResult, other: CosimResult, scenario: str) -> None:
    """Commanded voltages of the bench (solid) and of the co-simulation (dashed)."""
    _against_cosim(out, "fig_voltages.png", (bench.t, other.t), (bench.u, other.u),
                   ("u1", "u2", "u3"), "u [V]",
                   f"Motor voltages commanded over CAN and co-simulated, scenario {scenario}")


def fig_latency(out: Path, latencies_ns: Mapping[str, FloatArray],
                stats: Mapping[str, Mapping[str, float | None]]) -> None:
    """Histogram of each node's wake-up latency (log counts), with p50 / p99 / p99.9 marked."""
    fig = new_figure((10, 4))
    ax = fig.subplots()
    finite = [v for v in latencies_ns.values() if v.size]
    top = max((float(v.max()) for v in finite), default=1.0) * 1e-3
    bins = np.linspace(0.0, max(top, 1.0), 200).tolist()
    for name, lat in latencies_ns.items():
        if lat.size == 0:
            continue
        st = stats.get(name, {})
        label = (f"{name}: p50 {st.get('p50_us') or 0:.1f}, p99 {st.get('p99_us') or 0:.1f}, "
                 f"p99.9 {st.get('p999_us') or 0:.1f}, max {st.get('max_us') or 0:.1f} us")
        ax.hist(lat * 1e-3, bins=bins, histtype="step", lw=1.2, label=label)
    ax.set_yscale("log")
    ax.set(xlabel="wake-up latency [us]", ylabel="periods",
           title="Real-time loops: wake-up latency at 1 kHz")
    ax.grid(True)
    ax.legend(fontsize="small", loc="upper right")
    save_figure(fig, out / LATENCY_FIGURE)


def write_bench_figures(out: Path, ref: Reference, bench: CosimResult, other: CosimResult,
                        latencies_ns: Mapping[str, FloatArray] | None = None,
                        stats: Mapping[str, Mapping[str, float | None]] | None = None,
                        scenario: str = "ctc") -> None:
    """Every figure of a bench run of ``scenario`` into ``out`` (the titles name it)."""
    fig_letters(out, ref, {"bench": bench},
                title=f"Letters written over the CAN bench, scenario {scenario}",
                file="fig_letters_bench.png")
    fig_difference(out, bench, other, scenario)
    fig_joint_errors(out, bench, other, scenario)
    fig_voltages(out, bench, other, scenario)
    if latencies_ns is not None:
        fig_latency(out, latencies_ns, stats or {})
