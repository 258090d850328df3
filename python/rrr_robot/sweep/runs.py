"""One run of a sweep, on a worker: the base scenario with the run's values, through the writing
job's own pieces, and its row of results.

A run is "a scenario with some fields changed": the base scenario's tables with the run's
``scenario.*``, ``gains.*`` and ``mismatch.*`` values go through the scenario reader
(:func:`~rrr_robot.writing.scenarios.scenario_from_dict`: the same schema and checks as a
file; the controller starting from ``[sweep] controller_robot``'s model when the spec gives
one), its ``writing.*`` values through :func:`~rrr_robot.writing.job.writing_spec` and the
reference planner, then the closed loop (:func:`~rrr_robot.writing.job.run_engine`) and the
writing job's :func:`~rrr_robot.writing.job.metrics`. With no values, a run is exactly
``rrr writing --scenario <base>``.

Status of a run (never an exception: a failing run is a row):

- ``ok``: the closed loop ran, every metric is finite and no voltage reached its limit;
- ``saturated``: as ok, but some u_i reached +-u_max (the controller clips its output at its
  model's u_max and the plant's actuator at the true one: the smaller limit counts) on some
  samples: the metrics are those of the saturated loop (``saturated_fraction``);
- ``diverged``: the loop ran but a motion metric is not finite (those are null);
- ``invalid``: the run's values are refused before it runs (a value out of its range, a
  controller model that is no longer positive definite, a text that leaves the workspace);
- ``failed``: the closed loop raised (an FMU error, a numeric failure of the plant).

``error`` holds the message of a run that is not ok: why it was invalid or failed, which
metrics were not finite, which voltages reached which limit for how long.

The workers keep the robot and the references they built (the same inputs give the same
reference bit for bit), so a reference is planned once per worker and writing setting, not once
per run.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core.model import Model
from ..core.robot import RobotFile, read_robot_file
from ..errors import one_line
from ..writing.job import metrics, run_engine, scenario_options, scenario_summary, writing_spec
from ..writing.scenarios import scenario_from_dict
from ..writing.trajectory import Reference, make_reference
from .sampling import RunInput

log = logging.getLogger(__name__)

__all__ = ["METRICS", "STATUSES", "SweepPlan", "run_batch", "run_one"]

STATUSES = ("ok", "saturated", "diverged", "invalid", "failed")
#: The result columns of a run, after its varied keys (all float64, null when not finite or
#: when the run did not run).
METRICS = (
    "tip_error_max", "tip_error_rms",
    *fv.joint_names("rms_u_n"), *fv.joint_names("rms_u_c"),
    *fv.joint_names("u_peak"), *fv.joint_names("saturated_fraction"),
    "saturated_fraction", "wall_time",
)
_MAX_ERROR = 1000  # characters of an error message kept in a row
_CACHED_REFERENCES = 8


@dataclass(frozen=True)
class SweepPlan:
    """What every run of a sweep shares, sent once to each worker: the base scenario's and the
    robot file's parsed tables (checked on the client; the workers need neither file), the
    engine, ``fingerprint`` (the sweep's identity: the key of the workers' caches) and the
    controller's robot file's tables, if the spec gives one."""

    base: Mapping[str, Any]
    base_source: str
    robot: Mapping[str, Any]
    robot_source: str
    engine: str
    fingerprint: str
    # the controller's robot file (``[sweep] controller_robot``), its tables and name; None: the
    # controller starts from the plant's model
    controller_robot: Mapping[str, Any] | None = None
    controller_robot_source: str = ""


_lock = threading.Lock()
_robots: dict[str, tuple[RobotFile, Model | None]] = {}
_references: OrderedDict[tuple[Any, ...], Reference] = OrderedDict()


def _robot(plan: SweepPlan) -> tuple[RobotFile, Model | None]:
    """The plant's robot file and the controller's model (None: the plant's)."""
    with _lock:
        found = _robots.get(plan.fingerprint)
    if found is None:
        robot = read_robot_file(plan.robot, plan.robot_source)
        robot.require_control()
        believed = None if plan.controller_robot is None else read_robot_file(
            plan.controller_robot, plan.controller_robot_source).model
        found = (robot, believed)
        with _lock:
            _robots.clear()  # one sweep at a time per worker in practice
            _robots[plan.fingerprint] = found
    return found


def _reference(plan: SweepPlan, robot: RobotFile, writing: tuple[tuple[str, Any], ...],
               ) -> Reference:
    key = (plan.fingerprint, writing)
    with _lock:
        ref = _references.get(key)
        if ref is not None:
            _references.move_to_end(key)
            return ref
    changes = dict(writing)
    scale = float(changes.pop("scale", 1.0))
    ref = make_reference(robot.model, writing_spec(robot, scale=scale, changes=changes))
    with _lock:
        _references[key] = ref
        while len(_references) > _CACHED_REFERENCES:
            _references.popitem(last=False)
    return ref


def _scenario_tables(plan: SweepPlan, values: Sequence[tuple[str, Any]]) -> dict[str, Any]:
    tables: dict[str, Any] = {name: dict(t) if isinstance(t, Mapping) else t
                              for name, t in plan.base.items()}
    for key, value in values:
        table, name = key.split(".", 1)
        if table != "writing":
            entries = tables.setdefault(table, {})
            if isinstance(entries, dict):
                entries[name] = value
    return tables


def _one_line(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {one_line(exc)}"
    return text if len(text) <= _MAX_ERROR else text[:_MAX_ERROR - 3] + "..."


def _finite(x: float) -> float | None:
    return x if np.isfinite(x) else None


def _limit_text(controller: float, actuator: float) -> str:
    if controller < actuator:
        return f"+-{controller:g} V (the controller's model's u_max)"
    if actuator < controller:
        return f"+-{actuator:g} V (the actuator's u_max)"
    return f"+-{actuator:g} V (u_max)"


def _outcome(res: Any, limits: tuple[float, float],
             ) -> tuple[str, str | None, dict[str, float | None]]:
    """The status, its message and the metric columns of a run that ran; ``limits``: the
    controller's and the actuator's u_max."""
    m = metrics(res)
    summary = scenario_summary(m)
    u = np.abs(res.u)
    saturated = u >= min(limits)
    row: dict[str, float | None] = {
        "tip_error_max": _finite(m["tip_error_max"]), "tip_error_rms": _finite(m["tip_error_rms"]),
    }
    for name in ("rms_u_n", "rms_u_c"):
        row |= {n: _finite(float(m[name][k])) for k, n in enumerate(fv.joint_names(name))}
    row |= {n: _finite(float(u[:, k].max())) for k, n in enumerate(fv.joint_names("u_peak"))}
    row |= {n: float(saturated[:, k].mean())
            for k, n in enumerate(fv.joint_names("saturated_fraction"))}
    fraction = float(saturated.any(axis=1).mean())
    row["saturated_fraction"] = fraction
    if summary["status"] == "diverged":
        return "diverged", f"not finite: {', '.join(summary['non_finite'])}", row
    if saturated.any():
        joints = ", ".join(n for k, n in enumerate(fv.names("controller", "u"))
                           if saturated[:, k].any())
        return "saturated", (f"{joints} reached {_limit_text(*limits)} on "
                             f"{100 * fraction:.3g} % of the samples"), row
    return "ok", None, row


def run_one(plan: SweepPlan, inp: RunInput) -> dict[str, Any]:
    """The row of one run: ``run``, ``seed``, ``status``, ``error``, the varied keys, METRICS."""
    start = time.perf_counter()
    row: dict[str, Any] = {"run": inp.run, "seed": inp.seed, "status": "ok", "error": None,
                           **dict(inp.values)}
    row |= dict.fromkeys(METRICS)
    try:
        robot, believed = _robot(plan)
        writing = tuple((k.split(".", 1)[1], v) for k, v in inp.values
                        if k.startswith("writing."))
        ref = _reference(plan, robot, writing)
        scenario = scenario_from_dict(_scenario_tables(plan, inp.values),
                                      f"{plan.base_source} (run {inp.run})").believing(believed)
        limits = (scenario.controller_model(robot.model).u_max, robot.model.u_max)
        options = scenario_options(scenario, robot.model, robot, ref)
    except Exception as exc:  # a run's values that the checks refuse: a row, not an error
        log.debug("run %d invalid: %s", inp.run, exc)
        row |= {"status": "invalid", "error": _one_line(exc)}
    else:
        try:
            res = run_engine(plan.engine, ref, options)
        except Exception as exc:  # the closed loop failed: a row, not an error
            log.debug("run %d failed: %s", inp.run, exc)
            row |= {"status": "failed", "error": _one_line(exc)}
        else:
            row["status"], row["error"], values = _outcome(res, limits)
            row |= values
    row["wall_time"] = time.perf_counter() - start
    return row


def run_batch(plan: SweepPlan, inputs: Sequence[RunInput]) -> list[dict[str, Any]]:
    """The rows of a batch of runs (one Dask task), in the batch's order."""
    return [run_one(plan, inp) for inp in inputs]
