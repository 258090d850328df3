"""Validation on the writing task (paper section V): voltages predicted by the identified model
and the computed-torque controller FMU running with the identified parameters, each compared
with the true (or reference) model."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.model import Model
from ..core.param_names import model_fmu_values
from ..core.robot import RobotFile
from ..sim.cosim import CosimOptions, run_cosim
from ..writing.job import controller_fmu_values, metrics
from ..writing.scenarios import load_scenario
from ..writing.trajectory import WritingSpec, make_reference

log = logging.getLogger(__name__)


def validate_writing(true_model: Model, identified: Model, robot: RobotFile,
                     progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Voltage prediction error and tip errors of CTC with the identified vs the true model, on
    the writing task of the robot file ``robot`` (its [writing], [control] and sample time);
    ``progress(name, sample, samples)`` during the two co-simulations ("writing true",
    "writing identified")."""
    control = robot.require_control()
    ref = make_reference(true_model, WritingSpec.from_robot(robot))
    u_true = true_model.nominal_voltage(ref.q, ref.qd, ref.qdd)
    u_id = identified.nominal_voltage(ref.q, ref.qd, ref.qdd)
    out: dict[str, Any] = {
        "rms_u_n_true": np.sqrt(np.mean(u_true**2, axis=0)).tolist(),
        "rms_u_n_error": np.sqrt(np.mean((u_id - u_true) ** 2, axis=0)).tolist(),
        "max_u_n_error": np.max(np.abs(u_id - u_true), axis=0).tolist(),
    }
    ctc = load_scenario("ctc")
    for name, ctrl_model in (("true", true_model), ("identified", identified)):
        def report(k: int, n: int, name: str = name) -> None:
            if progress is not None:
                progress(f"writing {name}", k, n)
        options = CosimOptions(
            step=robot.sample_time, plant_values=model_fmu_values(true_model),
            controller_values=controller_fmu_values(ctc, ctrl_model, control),
            progress=report)
        res = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)
        out[name] = metrics(res)
    out["tip_error_ratio"] = out["identified"]["tip_error_max"] / out["true"]["tip_error_max"]
    log.info("writing: tip error max %.3f mm (identified) vs %.3f mm (true), ratio %.2f",
             1e3 * out["identified"]["tip_error_max"], 1e3 * out["true"]["tip_error_max"],
             out["tip_error_ratio"])
    return out
