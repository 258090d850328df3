"""The writing task end to end (paper section V): reference, co-simulations, metrics, outputs.

``run_writing`` checks everything it can before the first simulation (scenarios, robot file,
workspace), co-simulates each scenario with the FMUs, and writes ``summary.json``, one CSV per
scenario and the figures into the output folder.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..core.model import DEFAULT_ROBOT_TOML, Model
from ..core.param_names import model_fmu_values
from ..core.robot import RobotFile, read_robot_file
from ..core.robot_file import ControlGains
from ..errors import BadInputError
from ..sim.cosim import CosimOptions, CosimResult, run_cosim
from .scenarios import BUILTIN, Scenario, check_run, load_scenario
from .trajectory import Reference, WritingSpec, make_reference

log = logging.getLogger(__name__)

#: RMS voltages of the paper's eq 16 (real robot, PD + feedforward), V.
PAPER_RMS_U_N = (0.25, 1.98, 0.78)
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


def controller_fmu_values(scenario: Scenario, true_model: Model,
                          control: ControlGains) -> dict[str, float | bool]:
    """Controller start values: its own (possibly perturbed) model, gains, feedforward switch."""
    values: dict[str, float | bool] = dict(model_fmu_values(scenario.controller_model(true_model)))
    kp = scenario.kp or control.kp
    kd = scenario.kd or control.kd
    values |= {f"kp[{i + 1}]": float(kp[i]) for i in range(3)}
    values |= {f"kd[{i + 1}]": float(kd[i]) for i in range(3)}
    values["feedforward"] = scenario.feedforward
    return values


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


class Prepared(NamedTuple):
    """What :func:`prepare` checked and built: the true model, the robot file it came from, the
    scenarios and the reference (sampled at the robot file's [control] sample_time)."""

    model: Model
    robot: RobotFile
    scenarios: list[Scenario]
    reference: Reference


def prepare(job: WritingJob) -> Prepared:
    """Everything that can fail before a simulation: scenarios (each file checked, names unique),
    the robot file (read and checked once, [control] required), the reference (its bounds) and
    the workspace."""
    scenarios = [load_scenario(s) for s in job.scenarios]
    check_run(scenarios)
    robot = read_robot_file(job.robot)
    robot.require_control()
    spec = WritingSpec.from_robot(robot)
    if job.text is not None:
        spec = replace(spec, text=job.text)
    if job.scale != 1.0:
        spec = replace(spec, letter_height=spec.letter_height * job.scale)
    reference = make_reference(robot.model, spec)
    for s in scenarios:
        s.controller_model(robot.model)  # a perturbed model that is invalid fails here
    return Prepared(robot.model, robot, scenarios, reference)


def run_writing(job: WritingJob,
                progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Run the job and write its outputs; returns the summary written to summary.json."""
    model, robot, scenarios, ref = prepare(job)
    try:
        job.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BadInputError(f"cannot create the output folder {job.out}: {exc}") from exc
    log.info("reference: %.2f s, %d samples, least workspace margin %.3f m, least |sin q3| %.3f",
             ref.t[-1] - ref.t[0], ref.t.size, ref.min_margin_m, ref.min_elbow_margin)
    results: dict[str, CosimResult] = {}
    summary: dict[str, Any] = {"scenarios": {}}
    for scn in scenarios:
        def report(k: int, n: int, name: str = scn.name) -> None:
            if progress is not None:
                progress(name, k, n)
        options = CosimOptions(
            step=float(ref.t[1] - ref.t[0]),
            plant_values=model_fmu_values(model),
            controller_values=controller_fmu_values(scn, model, robot.require_control()),
            progress=report,
            fmi_version=job.fmi_version,
        )
        res = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)
        results[scn.name] = res
        res.to_csv(job.out / f"{scn.name}.csv")
        summary["scenarios"][scn.name] = metrics(res)
        log.info("%s: tip error max %.2f mm, rms %.2f mm, %.0fx real time", scn.name,
                 1e3 * summary["scenarios"][scn.name]["tip_error_max"],
                 1e3 * summary["scenarios"][scn.name]["tip_error_rms"], res.realtime_factor)
    summary["reference"] = {
        "text": ref.spec.text, "duration": float(ref.t[-1] - ref.t[0]),
        "step": float(ref.t[1] - ref.t[0]),
        "min_workspace_margin_m": ref.min_margin_m, "min_elbow_margin": ref.min_elbow_margin,
        "min_shoulder_margin_m": ref.min_shoulder_margin_m,
    }
    summary["fmi_version"] = f"{job.fmi_version}.0"
    summary["paper_eq16"] = {"rms_u_n": list(PAPER_RMS_U_N), "rms_u_c": list(PAPER_RMS_U_C)}
    (job.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if job.figures:
        from .plots import write_figures

        write_figures(job.out, model, robot, ref, results)
    return summary
