"""The writing task end to end (paper section V): reference, co-simulations, metrics, outputs.

``run_writing`` checks everything it can before the first simulation (scenarios, robot file,
workspace, table format, engine), co-simulates each scenario with the FMUs (or runs the same
closed loop in librrr: ``engine="native"``), and writes ``summary.json``,
one table per scenario (CSV, or Parquet with pyarrow) and the figures into the output folder:
all of them or none (a :class:`~rrr_robot.core.outputs.ResultSet`: an interrupted run leaves the
previous results as they were). summary.json is strict JSON: a non-finite metric is null and the
scenario's ``status`` says why (:func:`scenario_summary`); ``files`` lists the files of the run.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..core import fmu_vars as fv
from ..core.model import DEFAULT_ROBOT_TOML, Model
from ..core.outputs import ResultSet, check_folder, check_name, to_strict_json_value
from ..core.param_names import model_fmu_values
from ..core.robot import ControlGains, RobotFile, read_robot_file
from ..core.summary import reference_section, write_summary
from ..core.tables import check_table_format
from ..errors import BadInputError
from ..sim.cosim import CosimOptions, CosimResult, run_cosim
from ..sim.native import simulate
from .animation import FPS, animate_result, animation_format, frame_indices
from .figure_worker import ReferenceFigures
from .scenarios import BUILTIN, Scenario, check_run, load_scenario
from .trajectory import (
    MIN_HEIGHT_CORNER_RADII,
    Reference,
    WritingSpec,
    fit_letter_height,
    letter_height_range,
    make_reference,
)

log = logging.getLogger(__name__)

__all__ = [
    "ENGINES",
    "PAPER_RMS_U_C",
    "PAPER_RMS_U_N",
    "Prepared",
    "WritingJob",
    "controller_fmu_values",
    "metrics",
    "prepare",
    "read_controller_robot",
    "run_engine",
    "run_writing",
    "scenario_options",
    "scenario_summary",
    "writing_spec",
]

#: The engines of a writing job (WritingJob.engine).
ENGINES = ("fmpy", "native")

#: RMS voltages of the paper's eq 16 (real robot, PD + feedforward), V: the feedforward part
#: u_n of joints 1 to 3.
PAPER_RMS_U_N = (0.25, 1.98, 0.78)
#: The same for the PD part u_c.
PAPER_RMS_U_C = (0.11, 0.24, 0.17)


@dataclass(frozen=True)
class WritingJob:
    """What to run: text (None: the default), scenarios, robot file, output folder."""

    out: Path
    text: str | None = None
    scenarios: Sequence[str] = BUILTIN
    robot: Path = DEFAULT_ROBOT_TOML
    scale: float = 1.0
    figures: bool = True
    fmi_version: int = 2   # of the FMUs the job co-simulates: 2 or 3 (identical results)
    # "fmpy": the FMUs co-simulated through FMPy (run_cosim); "native": the same closed loop in
    # librrr (rr.simulate), bit-identical and several times faster, no FMU involved
    engine: str = "fmpy"
    table_format: str = "csv"  # of the per-scenario signal tables: csv or parquet (core.tables)
    # an animation of the arm per scenario: None (none), "gif", "mp4" or "auto" (writing.animation)
    animate: str | None = None
    fps: float = FPS  # of the animations: frames per simulated second
    # also <scenario>.mcap: the run as ROS 2 messages in MCAP (core.mcap_log; needs mcap)
    mcap: bool = False
    # also view.html: the runs in a browser (writing.view)
    view: bool = False
    # the controller's model from this robot file (None: the plant's, from ``robot``): the
    # identified controller against the true plant (rrr writing --controller-robot)
    controller_robot: Path | None = None


def read_controller_robot(path: str | Path | Mapping[str, Any], robot: RobotFile,
                          source: str | None = None) -> RobotFile:
    """The robot file of ``--controller-robot`` (its path, or its parsed tables named
    ``source``: as :func:`~rrr_robot.core.robot.read_robot_file`), read and checked: only its
    model goes to the controller (the gains, the sample period and the writing task stay those
    of the plant's robot file ``robot``; a warning names what it says otherwise)."""
    believed = read_robot_file(path, source)
    ignored = [name for name, mine, theirs in (
        ("[control]", believed.control, robot.control),
        ("[writing]", dict(believed.writing), dict(robot.writing))) if mine and mine != theirs]
    if ignored:
        log.warning("%s: its %s differ(s) from %s's and are not used: the controller takes only "
                    "the model from it (gains from the scenario or %s)", believed.source,
                    " and ".join(ignored), robot.source, robot.source)
    return believed


def controller_fmu_values(scenario: Scenario, true_model: Model,
                          control: ControlGains) -> dict[str, float | bool]:
    """Controller start values: its own model (the scenario's: the true one, or that of
    ``--controller-robot``, perturbed by [mismatch]), gains, feedforward switch."""
    values: dict[str, float | bool] = dict(model_fmu_values(scenario.controller_model(true_model)))
    kp = scenario.kp or control.kp
    kd = scenario.kd or control.kd
    values |= {n: float(kp[i]) for i, n in enumerate(fv.names("controller", "kp"))}
    values |= {n: float(kd[i]) for i, n in enumerate(fv.names("controller", "kd"))}
    values["feedforward"] = scenario.feedforward
    return values


def scenario_options(scenario: Scenario, model: Model, robot: RobotFile, ref: Reference,
                     **settings: Any) -> CosimOptions:
    """The co-simulation of one scenario along ``ref``: the plant is the true ``model``, the
    controller has the scenario's model, gains (else the robot file's) and feedforward switch;
    ``settings`` are further CosimOptions fields (progress, fmi_version)."""
    return CosimOptions(
        step=float(ref.t[1] - ref.t[0]),
        plant_values=model_fmu_values(model),
        controller_values=controller_fmu_values(scenario, model, robot.require_control()),
        **settings,
    )


def run_engine(engine: str, ref: Reference, options: CosimOptions) -> CosimResult:
    """The closed loop along ``ref`` on one of :data:`ENGINES` (the same numbers on both)."""
    if engine not in ENGINES:
        raise BadInputError(f"unknown engine {engine!r}: one of {', '.join(ENGINES)}")
    run = run_cosim if engine == "fmpy" else simulate
    return run(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)


def metrics(result: CosimResult) -> dict[str, Any]:
    """Per-scenario figures of summary.json (eq 16 RMS values, tip error, timing)."""
    err = np.linalg.norm(result.tip - result.x_ref, axis=1)
    return {
        "rms_u_n": np.sqrt(np.mean(result.u_n**2, axis=0)).tolist(),
        "rms_u_c": np.sqrt(np.mean(result.u_c**2, axis=0)).tolist(),
        "tip_error_max": float(err.max()),
        "tip_error_rms": float(np.sqrt(np.mean(err**2))),
        "wall_time": result.wall_time,
        "realtime_factor": result.realtime_factor,
    }


#: The metrics of a scenario that describe the motion (the others are timing).
MOTION_METRICS = ("rms_u_n", "rms_u_c", "tip_error_max", "tip_error_rms")


def scenario_summary(values: dict[str, Any]) -> dict[str, Any]:
    """A scenario's metrics as written to summary.json (strict JSON): a non-finite number
    becomes null, listed under ``non_finite``, and ``status`` says why: "ok" (all finite),
    "diverged" (a motion metric is NaN or infinite: the simulated motion blew up) or
    "timing_unavailable" (only the timing is not finite, e.g. a loop too short to time)."""
    bad = sorted(k for k, v in values.items()
                 if not np.all(np.isfinite(np.asarray(v, dtype=float))))
    status = "ok"
    if any(k in MOTION_METRICS for k in bad):
        status = "diverged"
    elif bad:
        status = "timing_unavailable"
    return {"status": status, **to_strict_json_value(values), "non_finite": bad}


def _describe(s: dict[str, Any]) -> str:
    if s["status"] == "diverged":
        return f"DIVERGED (non-finite: {', '.join(s['non_finite'])})"
    rtf = s["realtime_factor"]
    return (f"tip error max {1e3 * s['tip_error_max']:.2f} mm, rms "
            f"{1e3 * s['tip_error_rms']:.2f} mm, "
            + (f"{rtf:.0f}x real time" if rtf is not None else "real-time factor unavailable"))


def view_title(text: str) -> str:
    """The title of ``rrr writing --view``'s page: the text in quotes, its lines joined by
    " / " (one line of a title shows a newline as nothing, and repr as a backslash and n)."""
    return "rrr writing: \u201c" + " / ".join(text.split("\n")) + "\u201d"


def writing_spec(robot: RobotFile, text: str | None = None, scale: float = 1.0,
                 changes: Mapping[str, Any] | None = None) -> WritingSpec:
    """What a job writes: the robot file's [writing] values, with ``changes`` (WritingSpec
    fields), the ``text`` (None: as they say) and the letter height it is written at (fitted to
    the writing area) times ``scale`` (the ``--text`` and ``--scale`` of ``rrr writing``).
    BadInputError for a value out of range."""
    spec = WritingSpec.from_robot(robot)
    if changes:
        spec = replace(spec, **changes)
    if text is not None:
        spec = replace(spec, text=text)
    if scale != 1.0:
        # the factor on the height the text is written at (fitted to the writing area), and
        # that height exactly: a scaled text outside the usable heights is refused
        spec = replace(spec, letter_height=_scaled_height(spec, scale), fit_to_area=False)
    return spec


def _scaled_height(spec: WritingSpec, scale: float) -> float:
    """The letter height at ``scale`` (the factor on the fitted height: ``rrr writing
    --scale``); BadInputError with the usable range of the scale when it is outside."""
    if isinstance(scale, bool) or not isinstance(scale, int | float) or \
            not math.isfinite(scale) or scale <= 0:
        raise BadInputError(f"the letter scale (--scale) must be a finite number > 0, got "
                            f"{scale!r}")
    fitted = fit_letter_height(spec)
    low, high = letter_height_range(spec)
    height = fitted * scale
    if not low <= height <= high:
        raise BadInputError(
            f"--scale {scale:g} gives letters {1e3 * height:.3g} mm high: the usable range of "
            f"--scale is {low / fitted:.3g} to {high / fitted:.3g} for this text (letters from "
            f"{1e3 * low:.3g} mm, {MIN_HEIGHT_CORNER_RADII:g} corner radii, to "
            f"{1e3 * high:.3g} mm, the largest that fits the writing area)")
    return height


class Prepared(NamedTuple):
    """What :func:`prepare` checked and built: the true model, the robot file it came from, the
    scenarios and the reference (sampled at the robot file's [control] sample_time)."""

    model: Model
    robot: RobotFile
    scenarios: list[Scenario]
    reference: Reference


def prepare(job: WritingJob) -> Prepared:
    """Everything that can fail before a simulation: scenarios (each file checked, names unique),
    the robot file (read and checked once, [control] required), the controller's robot file
    (``controller_robot``: the scenarios' controllers start from its model), the reference (its
    bounds) and the workspace."""
    scenarios = [load_scenario(s) for s in job.scenarios]
    check_run(scenarios)
    robot = read_robot_file(job.robot)
    robot.require_control()
    if job.controller_robot is not None:
        believed = read_controller_robot(job.controller_robot, robot).model
        scenarios = [s.believing(believed) for s in scenarios]
    reference = make_reference(robot.model, writing_spec(robot, job.text, job.scale))
    for s in scenarios:
        s.controller_model(robot.model)  # a perturbed model that is invalid fails here
    return Prepared(robot.model, robot, scenarios, reference)


def run_writing(job: WritingJob,
                progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Run the job and write its outputs; returns the summary written to summary.json."""
    check_folder(job.out)  # a bad output folder fails before the inputs are even read
    if job.engine not in ENGINES:
        raise BadInputError(f"unknown engine {job.engine!r}: one of {', '.join(ENGINES)}")
    fmt = check_table_format(job.table_format)  # parquet without pyarrow fails here
    anim = None if job.animate is None else animation_format(job.animate)  # mp4: its package
    if job.mcap:
        from ..core.mcap_log import require_mcap

        require_mcap()  # without the mcap package: refused before any run
    model, robot, scenarios, ref = prepare(job)
    if anim is not None:
        frame_indices(ref.t, job.fps)  # at most MAX_FRAMES frames: refused before any run
    for scn in scenarios:  # the output names, before anything runs
        check_name(f"{scn.name}.{fmt}")
        if job.mcap:
            check_name(f"{scn.name}.mcap")
        if anim is not None:
            check_name(f"anim_{scn.name}.{anim}")
    with ResultSet(job.out, kind="writing") as rs, \
            ReferenceFigures(rs.staging, model, robot, ref, start=job.figures) as ref_figures:
        # Figs 2-6 depend on the reference only: a forked worker draws them while the
        # co-simulations run (figure_worker; stopped at the block's end, before the commit)
        log.info("reference: %.2f s, %d samples, least workspace margin %.3f m, least |sin q3| "
                 "%.3f", ref.t[-1] - ref.t[0], ref.t.size, ref.min_margin_m,
                 ref.min_elbow_margin)
        results: dict[str, CosimResult] = {}
        summary: dict[str, Any] = {"scenarios": {}}
        table_time = 0.0
        for scn in scenarios:
            def report(k: int, n: int, name: str = scn.name) -> None:
                if progress is not None:
                    progress(name, k, n)
            options = scenario_options(scn, model, robot, ref, progress=report,
                                       fmi_version=job.fmi_version)
            res = run_engine(job.engine, ref, options)
            results[scn.name] = res
            start = time.perf_counter()
            res.write(rs.path(f"{scn.name}.{fmt}"), fmt)
            table_time += time.perf_counter() - start
            if job.mcap:
                from ..core.mcap_log import write_mcap

                start = time.perf_counter()
                write_mcap(rs.path(f"{scn.name}.mcap"), res.columns(), robot,
                           metadata={"scenario": scn.name, "engine": job.engine})
                log.info("%s.mcap: %.2f s", scn.name, time.perf_counter() - start)
            s = summary["scenarios"][scn.name] = scenario_summary(metrics(res))
            log.info("%s: %s", scn.name, _describe(s))
        log.info("%s tables: %.2f s", fmt, table_time)
        summary["reference"] = reference_section(
            ref.spec.text, ref.t[-1] - ref.t[0], ref.t[1] - ref.t[0],
            letter_height=ref.spec.letter_height, min_workspace_margin_m=ref.min_margin_m,
            min_elbow_margin=ref.min_elbow_margin,
            min_shoulder_margin_m=ref.min_shoulder_margin_m)
        summary["engine"] = job.engine
        summary["controller_robot"] = (None if job.controller_robot is None
                                       else str(job.controller_robot))
        summary["fmi_version"] = f"{job.fmi_version}.0" if job.engine == "fmpy" else None
        summary["paper_eq16"] = {"rms_u_n": list(PAPER_RMS_U_N), "rms_u_c": list(PAPER_RMS_U_C)}
        if job.figures:
            start = time.perf_counter()
            from .plots import result_figure_count, write_result_figures

            total = result_figure_count(results) + 1   # and the reference figures, last

            def drawn(k: int, n: int) -> None:
                if progress is not None:
                    progress("figures", k - 1, total)
            write_result_figures(rs.staging, ref, results, progress=drawn)
            ref_figures.finish()  # Figs 2-6: the worker's, or drawn here
            drawn(total, total)
            log.info("figures: %.2f s", time.perf_counter() - start)
        if anim is not None:
            start = time.perf_counter()
            for name, res in results.items():
                def frames(k: int, n: int, name: str = name) -> None:
                    if progress is not None:
                        progress(f"animation {name}", k - 1, n)
                animate_result(rs.path(f"anim_{name}.{anim}"), model, ref, res, title=name,
                               fps=job.fps, fmt=anim, progress=frames)
            log.info("animations: %.2f s", time.perf_counter() - start)
        if job.view:
            from .view import view_html

            start = time.perf_counter()
            rs.write_text("view.html", view_html(
                {name: res.columns() for name, res in results.items()}, robot,
                view_title(ref.spec.text)))
            log.info("view.html: %.2f s", time.perf_counter() - start)
        summary = write_summary(rs, summary)
    return summary
