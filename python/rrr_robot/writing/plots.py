"""Figures of the writing task, like the paper's Figs 2-9 (PNG files in the output folder)."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.outputs import atomic_path
from ..core.robot import RobotFile
from ..sim.cosim import CosimResult
from .references import inertial_from_robot, pinocchio_inverse_dynamics
from .trajectory import Reference, numeric_ik_path

log = logging.getLogger(__name__)
JOINTS = ("q1", "q2", "q3")


def _pen_down_xz(xyz: FloatArray, pen_down: np.ndarray) -> tuple[FloatArray, FloatArray]:
    """x and z with NaN where the pen is up, so strokes are drawn apart."""
    x = np.where(pen_down, xyz[:, 0], np.nan)
    z = np.where(pen_down, xyz[:, 2], np.nan)
    return x, z


def _save(fig: Figure, path: Path) -> None:
    """Save atomically (core.outputs): the PNG appears complete or not at all."""
    fig.tight_layout()
    with atomic_path(path) as tmp:  # tmp ends in .part: the format is given
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=120, bbox_inches="tight")
    log.info("drew %s", path.name)


def fig_reference(out: Path, ref: Reference) -> None:
    fig = Figure(figsize=(12, 4))
    ax1, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2, 1]})
    ax1.plot(*_pen_down_xz(ref.x, ref.pen_down), "k-", lw=1.5)
    ax1.set(xlabel="x [m]", ylabel="z [m]", title=f"Reference tip path in y = {ref.x[0, 1]:.3f} m")
    ax1.set_aspect("equal")
    ax2.plot(ref.t, ref.speed, "b-", lw=1)
    ax2.set(xlabel="t [s]", ylabel="v = sqrt(xd^2 + zd^2) [m/s]", title="Tip speed (eq 14)")
    ax2.grid(True)
    _save(fig, out / "fig2_reference.png")


def fig_joints(out: Path, ref: Reference) -> None:
    for data, unit, name, title in ((ref.q, "rad", "fig3_joint_positions.png", "positions"),
                                    (ref.qd, "rad/s", "fig4_joint_velocities.png", "velocities")):
        fig = Figure(figsize=(9, 4))
        ax = fig.subplots()
        for i in range(3):
            ax.plot(ref.t, data[:, i], label=JOINTS[i])
        ax.set(xlabel="t [s]", ylabel=unit, title=f"Reference joint {title}")
        ax.grid(True)
        ax.legend()
        _save(fig, out / name)


def fig_differences(out: Path, model: Model, robot: RobotFile, ref: Reference) -> None:
    """Figs 5 and 6: closed form against the Robotics Toolbox IK and Pinocchio's rnea."""
    try:
        numeric = numeric_ik_path(model, ref.x, ref.q[0])
    except ImportError:
        log.warning("Fig 5 skipped: roboticstoolbox-python is not installed (pip install "
                    "'rrr_robot[verify]')")
    else:
        _diff_plot(out / "fig5_ik_difference.png", ref.t, ref.q - numeric, "rad",
                   "Closed-form minus numeric (Robotics Toolbox ik_LM) inverse kinematics")
    inertial = inertial_from_robot(robot)
    if inertial is None:
        log.warning("Fig 6 skipped: the robot file gives base parameters, not link inertias")
        return
    try:
        tau_ref = pinocchio_inverse_dynamics(model.dh, model.g, inertial, ref.q, ref.qd, ref.qdd)
    except ImportError:
        log.warning("Fig 6 skipped: Pinocchio is not installed (pip install 'rrr_robot[verify]')")
        return
    tau = model.inverse_dynamics(ref.q, ref.qd, ref.qdd)
    _diff_plot(out / "fig6_torque_difference.png", ref.t, tau - tau_ref, "N m",
               "Closed-form R p minus Pinocchio rnea inverse dynamics")


def _diff_plot(path: Path, t: FloatArray, diff: FloatArray, unit: str, title: str) -> None:
    fig = Figure(figsize=(9, 4))
    ax = fig.subplots()
    for i in range(3):
        ax.plot(t, diff[:, i], label=f"joint {i + 1}", lw=0.8)
    ax.set(xlabel="t [s]", ylabel=unit, title=f"{title}\nmax |difference| = "
           f"{np.abs(diff).max():.2e} {unit}")
    ax.grid(True)
    ax.legend()
    _save(fig, path)


def fig_letters(out: Path, ref: Reference, results: Mapping[str, CosimResult]) -> None:
    """Figs 7 and 8: the letters written by each scenario against the reference."""
    for name, res in results.items():
        fig = Figure(figsize=(10, 4))
        ax = fig.subplots()
        ax.plot(*_pen_down_xz(ref.x, ref.pen_down), "k--", lw=1.2, label="reference")
        ax.plot(*_pen_down_xz(res.tip, ref.pen_down), "r-", lw=1.2, label=f"executed ({name})")
        err = np.linalg.norm(res.tip - res.x_ref, axis=1)
        ax.set(xlabel="x [m]", ylabel="z [m]",
               title=f"Scenario {name}: max tip error {1e3 * err.max():.2f} mm")
        ax.set_aspect("equal")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2, frameon=False)
        _save(fig, out / f"fig_letters_{name}.png")


def fig_controls(out: Path, results: Mapping[str, CosimResult]) -> None:
    """Fig 9: model (u_n) and PD (u_c) parts of the joint-2 input, per scenario."""
    for name, res in results.items():
        fig = Figure(figsize=(9, 4))
        ax = fig.subplots()
        ax.plot(res.t, res.u_n[:, 1], "b-", lw=1, label="u_n,2 (model)")
        ax.plot(res.t, res.u_c[:, 1], "r-", lw=1, label="u_c,2 (PD)")
        ax.set(xlabel="t [s]", ylabel="V", title=f"Joint 2 input components, scenario {name}")
        ax.grid(True)
        ax.legend()
        _save(fig, out / f"fig9_u2_{name}.png")


def fig_tip_error(out: Path, results: Mapping[str, CosimResult]) -> None:
    fig = Figure(figsize=(9, 4))
    ax = fig.subplots()
    for name, res in results.items():
        ax.semilogy(res.t, 1e3 * np.linalg.norm(res.tip - res.x_ref, axis=1), lw=0.8, label=name)
    ax.set(xlabel="t [s]", ylabel="|tip - reference| [mm]", title="Cartesian tip error")
    ax.grid(True, which="both")
    ax.legend()
    _save(fig, out / "fig_tip_error.png")


def write_figures(out: Path, model: Model, robot: RobotFile, ref: Reference,
                  results: Mapping[str, CosimResult]) -> None:
    """Every figure of one writing-task run."""
    fig_reference(out, ref)
    fig_joints(out, ref)
    fig_differences(out, model, robot, ref)
    fig_letters(out, ref, results)
    fig_controls(out, results)
    fig_tip_error(out, results)
