"""The two identification jobs, one library call each (as ``rrr writing`` is
:func:`rrr_robot.writing.run_writing`): :func:`run_identify` (logs -> identified robot file and
report) and :func:`run_experiment` (a simulated friction sweep and excitation on the plant FMU ->
the logs). ``rrr identify`` and ``rrr identify-experiment`` parse their options into an
:class:`IdentifyJob` / :class:`ExperimentJob`, call these and print; scripts and notebooks call
them the same way."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core.model import DEFAULT_ROBOT_TOML, Model
from ..core.outputs import ResultSet, atomic_path, check_folder, strict_json
from ..core.robot import DEFAULT_SAMPLE_TIME, read_robot_file
from ..errors import BadInputError
from . import experiments as ex
from .excitation import design_excitation
from .logs import read_log
from .pipeline import Identified, Settings, identify, write_robot

#: ``progress(phase, done, total)``: what a job reports as it goes (the CLI draws bars).
Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class IdentifyJob:
    """What ``rrr identify`` does: the logs, the prior robot file, the outputs, the settings."""

    log: Path                             # excitation log CSV (identify.logs)
    out: Path                             # identified robot TOML to write
    friction_log: Path | None = None      # friction sweep CSV; None: the prior's friction
    robot: Path = DEFAULT_ROBOT_TOML      # the prior: kinematics, k_t, u_max, [control]
    settings: Settings = field(default_factory=Settings)
    report: Path | None = None            # the figures of merit as JSON
    validate: bool = False                # the writing task with the prior and the estimate
    # the true robot file of a simulated experiment: each estimate beside its true value, and
    # the plant of --validate
    truth: Path | None = None


@dataclass(frozen=True)
class IdentifyOutcome:
    """What :func:`run_identify` estimated, and the report it wrote (or would have)."""

    result: Identified
    report: dict[str, Any]                # what --report writes (with "writing" if validated)


def check_outputs(job: IdentifyJob) -> None:
    """The files the job will write, checked before it reads or estimates anything: each in an
    existing, writable folder, not a folder itself, not one of the input logs or the truth, and
    not the same file twice (:class:`~rrr_robot.errors.BadInputError` otherwise)."""
    inputs = {Path(f).resolve(): f"input log {f}" for f in (job.log, job.friction_log) if f}
    if job.truth is not None:
        inputs[Path(job.truth).resolve()] = f"truth {job.truth}"
    seen: dict[Path, str] = {}
    for option, path in (("--out", job.out), ("--report", job.report)):
        if path is None:
            continue
        target = Path(path).resolve()
        if target.is_dir():
            raise BadInputError(f"cannot write {path} ({option}): it is a folder")
        if not target.parent.is_dir():
            raise BadInputError(f"cannot write {path}: the folder {target.parent} does not exist")
        if not os.access(target.parent, os.W_OK | os.X_OK):
            raise BadInputError(f"cannot write {path}: the folder {target.parent} is not "
                                "writable")
        if target in inputs:
            raise BadInputError(f"{option} {path} is the {inputs[target]}: it would be "
                                "overwritten")
        if target in seen:
            raise BadInputError(f"{option} {path} is also {seen[target]}: give two files")
        seen[target] = option


def run_identify(job: IdentifyJob, progress: Progress | None = None,
                 estimated: Callable[[Identified], None] | None = None) -> IdentifyOutcome:
    """Estimate friction and the base parameters from the job's logs, compare them with the
    truth (``job.truth``), validate on the writing task if asked (the plant: the truth, else
    the prior), and write the robot file and the report: together at the end, each complete
    or not at all (an interrupted run, also during validation, leaves the previous files as
    they were). ``estimated(result)`` is called between estimation and validation (the CLI
    prints the estimate there)."""
    prior_robot = read_robot_file(job.robot)
    prior = prior_robot.model
    truth = read_robot_file(job.truth) if job.truth is not None else None
    if job.validate:
        prior_robot.require_control()
    check_outputs(job)  # fail before the estimation, not after it
    friction = read_log(job.friction_log, friction=True) if job.friction_log else None
    result = identify(read_log(job.log), prior, friction, job.settings, progress=progress)
    if truth is not None:
        result = result.compared_with(truth, prior)
    if estimated is not None:
        estimated(result)
    report: dict[str, Any] = result.report()
    if job.validate:
        from .validation import validate_writing  # the writing task: only when asked

        # the plant: the truth when it is known, else the prior
        report["writing"] = validate_writing(
            prior if truth is None else truth.model, result.model, prior_robot,
            progress=None if progress is None else lambda name, k, n: progress(name, k + 1, n))
        report["writing"]["plant"] = "prior" if truth is None else "truth"
    with contextlib.ExitStack() as outputs:
        write_robot(result, outputs.enter_context(atomic_path(job.out)), prior_robot)
        if job.report is not None:
            outputs.enter_context(atomic_path(job.report)).write_text(
                strict_json(report) + "\n", encoding="utf-8")
    return IdentifyOutcome(result, report)


@dataclass(frozen=True)
class ExperimentJob:
    """What ``rrr identify-experiment`` does: the true robot, the sensors, the experiments."""

    out: Path                   # output folder: friction.csv, excitation.csv, excitation.json
    robot: Path | None = None   # the true robot TOML; None: the packaged robot
    noise_free: bool = False    # ideal sensors (the logs carry qd, qdd)
    seed: int = 1               # of the sensor noise and of the excitation design
    speeds: int = 14            # constant speeds of the friction sweep, 0.002 to 4 rad/s
    periods: int = 1            # excitation periods of 10 s


@dataclass(frozen=True)
class ExperimentOutcome:
    """Where :func:`run_experiment` wrote its logs, and the excitation's condition number."""

    out: Path                   # the folder the three logs are in
    cond: float                 # cond(W) of the designed excitation


def run_experiment(job: ExperimentJob, progress: Progress | None = None) -> ExperimentOutcome:
    """Design an excitation, run the friction sweep and the excitation on the plant FMU with
    the job's sensors and write the three logs; they appear together when every experiment
    succeeded (:class:`rrr_robot.core.outputs.ResultSet`). The bounds are checked before
    anything is read or run."""
    out = check_folder(job.out)
    robot = read_robot_file(job.robot) if job.robot is not None else None
    model = robot.model if robot is not None else Model.default()
    step = robot.sample_time if robot is not None else DEFAULT_SAMPLE_TIME
    ex.check_experiments(job.periods, step)
    sensors = ex.IDEAL if job.noise_free else replace(ex.NOISY, seed=job.seed)

    def phase(name: str) -> Callable[[int, int], None] | None:
        return None if progress is None else lambda done, total: progress(name, done, total)

    with ResultSet(out, kind="identify-experiment") as rs:
        traj, cond = design_excitation(model, np.array(ex.SweepDesign().pose), seed=job.seed)
        traj.to_json(rs.path("excitation.json"))
        note = f"simulated, sensors: {sensors}"
        design = ex.SweepDesign(speeds=tuple(np.geomspace(0.002, 4.0, job.speeds)))
        ex.friction_experiment(model, design, step=step, sensors=sensors,
                               progress=phase("friction sweep")).to_csv(
            rs.path("friction.csv"), note)
        ex.excitation_experiment(model, traj, job.periods, step=step, sensors=sensors,
                                 progress=phase("excitation")).to_csv(
            rs.path("excitation.csv"), f"{note}; cond(W) = {cond:.2f}")
    return ExperimentOutcome(out, float(cond))
