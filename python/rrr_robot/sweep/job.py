"""A sweep end to end (``rrr sweep``): check everything, run what is missing on Dask, record each
batch as it finishes, then the summary and the figures.

Output folder ``DIR``:

- ``spec.toml``: the spec file, copied byte for byte; ``sweep.json``: what defines the runs
  (the checked spec, the engine, the base scenario's and the robot file's tables) and its
  SHA-256 ``fingerprint``; both written before the first run;
- ``results.parquet/``: the rows, one part file per finished batch (rrr_robot.sweep.results);
- ``summary.json`` (runs by status, tip error statistics, the sensitivity ranking) and the
  figures (rrr_robot.sweep.figures): written together (a result set) once every run is
  recorded; without summary.json a sweep is not complete.

The folder is claimed before anything else is looked at in it (an exclusive lock,
``.rrr-lock-sweep``, held until the sweep ends: rrr_robot.core.outputs.folder_lock), so a second
sweep into it, started at the same moment or later, is refused at once.

``resume``: the runs already in results.parquet are skipped and the others run; the folder's
sweep.json must have the same fingerprint (another spec, engine, base scenario or robot file is
refused, naming what differs), and every part must be this sweep's exactly (its columns and
their types, runs within 0 to samples - 1 with this sweep's seeds and as the part's name says,
statuses one of the five; anything else in results.parquet is refused, naming it:
rrr_robot.sweep.results). Without ``resume`` a folder that holds a sweep is refused.
Everything that can be checked is checked before anything is written or submitted: the spec,
the base scenario and robot file, the base run's reference, the folder and the options.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core.checked import load_toml
from ..core.model import DEFAULT_ROBOT_TOML
from ..core.outputs import (
    ResultSet,
    atomic_write_bytes,
    atomic_write_text,
    check_folder,
    folder_lock,
    make_folders,
    strict_json,
)
from ..core.robot import read_robot_file
from ..errors import BadInputError, RobotFileError, RrrError
from ..writing.job import ENGINES, read_controller_robot, writing_spec
from ..writing.scenarios import BUILTIN, read_scenario_file, scenario_from_dict
from ..writing.trajectory import make_reference
from .results import RESULTS, finished_runs, read_results, schema, write_part
from .runs import STATUSES, SweepPlan
from .sampling import RunInput, design
from .sensitivity import inputs, rank
from .spec import SweepSpec, read_spec

log = logging.getLogger(__name__)

__all__ = ["SPEC_COPY", "SWEEP_META", "SweepJob", "require_dependencies", "run_sweep"]

#: The copy of the spec file in the output folder (byte for byte).
SPEC_COPY = "spec.toml"
#: What defines the runs, and its SHA-256 fingerprint, in the output folder.
SWEEP_META = "sweep.json"
#: The packages a sweep needs beyond the base install (the ``sweep`` extra).
DEPENDENCIES = ("dask", "distributed", "pyarrow")


@dataclass(frozen=True)
class SweepJob:
    """What to run: the spec file, the output folder, where (``workers`` of a local cluster, or
    the ``scheduler`` address of a running one), the engine, resume, runs per batch (None:
    chosen from the cluster's size), figures."""

    spec: Path
    out: Path
    workers: int | None = None
    scheduler: str | None = None
    engine: str = "fmpy"
    resume: bool = False
    batch: int | None = None
    figures: bool = True


def require_dependencies() -> None:
    """RrrError naming the missing packages of the ``sweep`` extra."""
    missing = [m for m in DEPENDENCIES if importlib.util.find_spec(m) is None]
    if missing:
        raise RrrError(f"rrr sweep needs {', '.join(DEPENDENCIES)} (missing: "
                       f"{', '.join(missing)}): pip install 'rrr_robot[sweep]'")


def _check_job(job: SweepJob) -> None:
    if job.engine not in ENGINES:
        raise BadInputError(f"unknown engine {job.engine!r}: one of {', '.join(ENGINES)}")
    if job.workers is not None and job.scheduler is not None:
        raise BadInputError("--workers sets the size of a local cluster; with --scheduler the "
                            "cluster's own workers run the sweep: give one of the two")
    for name, value in (("workers", job.workers), ("batch", job.batch)):
        if value is not None and value < 1:
            raise BadInputError(f"{name} must be at least 1, got {value}")


def make_plan(spec: SweepSpec, engine: str) -> SweepPlan:
    """Read the base scenario and the robot file and check the base run (its scenario, the
    controller's model, its reference): what every run shares."""
    base_name = spec.base if spec.base in BUILTIN else spec.resolve(spec.base)
    base, base_source = read_scenario_file(base_name)
    if spec.base in BUILTIN:  # messages name the built-in scenario, not the installed file
        base_source = f"scenario {spec.base}"
    scenario = scenario_from_dict(base, base_source)
    robot_path = spec.resolve(spec.robot) if spec.robot else str(DEFAULT_ROBOT_TOML)
    robot_data = load_toml(robot_path, "robot file", RobotFileError)
    robot = read_robot_file(robot_data, robot_path)
    robot.require_control()
    ctrl_data: dict[str, Any] | None = None
    ctrl_path = ""
    if spec.controller_robot is not None:
        ctrl_path = spec.resolve(spec.controller_robot)
        ctrl_data = load_toml(ctrl_path, "robot file", RobotFileError)
        believed = read_controller_robot(ctrl_data, robot, ctrl_path)
        scenario = scenario.believing(believed.model)
    scenario.controller_model(robot.model)
    make_reference(robot.model, writing_spec(robot))
    plan = SweepPlan(base=base, base_source=base_source, robot=robot_data,
                     robot_source=robot_path, engine=engine, fingerprint="",
                     controller_robot=ctrl_data, controller_robot_source=ctrl_path)
    return replace(plan, fingerprint=_fingerprint(_identity(plan, spec)))


def _identity(plan: SweepPlan, spec: SweepSpec) -> dict[str, Any]:
    """What defines the runs: the spec, the engine, the base scenario's and the robot files'
    tables (the controller's only when the spec gives one: the fingerprints of sweeps without
    it stay as they were)."""
    values: dict[str, Any] = {"spec": spec.identity(), "engine": plan.engine,
                              "base_scenario": plan.base, "robot_file": plan.robot}
    if plan.controller_robot is not None:
        values["controller_robot_file"] = plan.controller_robot
    identity: dict[str, Any] = json.loads(strict_json(values))
    return identity


def _fingerprint(identity: Mapping[str, Any]) -> str:
    text = json.dumps(json.loads(strict_json(identity)), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _check_folder_state(out: Path, plan: SweepPlan, spec: SweepSpec, resume: bool) -> bool:
    """Whether ``out`` already holds this sweep (resume); errors for a folder holding another
    sweep or results without a sweep.json."""
    meta_path = out / SWEEP_META
    if meta_path.exists() and not meta_path.is_file():
        raise BadInputError(f"{meta_path} is not a file: not a sweep of rrr sweep; choose "
                            "another --out")
    if not meta_path.exists():
        if (out / RESULTS).exists():
            raise BadInputError(f"{out / RESULTS} exists but {meta_path} does not: not a sweep "
                                "of rrr sweep; choose another --out")
        return False
    if not resume:
        raise BadInputError(f"{out} already holds a sweep ({SWEEP_META}): complete it with "
                            "--resume, or choose another --out")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
        old = meta["identity"]
        fingerprint = meta["fingerprint"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise BadInputError(f"{meta_path} cannot be read as a sweep's description: {exc}"
                            ) from None
    if fingerprint != plan.fingerprint:
        new = _identity(plan, spec)
        differ = [f"the spec's {k}" for k in new["spec"] if new["spec"].get(k) !=
                  (old.get("spec") or {}).get(k)] if isinstance(old, dict) else []
        differ += [k.replace("_", " ") for k in ("engine", "base_scenario", "robot_file",
                                                 "controller_robot_file")
                   if isinstance(old, dict) and new.get(k) != old.get(k)]
        raise BadInputError(f"cannot resume the sweep in {out}: it ran another sweep ("
                            f"{', '.join(differ) or 'its description'} differ"
                            f"{'s' if len(differ) == 1 else ''}); use its own spec or another "
                            "--out")
    return True


def _write_description(out: Path, job: SweepJob, plan: SweepPlan, spec: SweepSpec) -> None:
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out / SPEC_COPY, Path(job.spec).read_bytes())
    meta = {"kind": "rrr sweep", "fingerprint": plan.fingerprint, "runs": spec.samples,
            "identity": _identity(plan, spec)}
    atomic_write_text(out / SWEEP_META, strict_json(meta) + "\n")


def _stats(values: np.ndarray) -> dict[str, Any]:
    v = values[np.isfinite(values)]
    if not v.size:
        return {"runs": 0}
    return {"runs": int(v.size), "min": float(v.min()), "median": float(np.median(v)),
            "mean": float(v.mean()), "p95": float(np.percentile(v, 95)), "max": float(v.max())}


def _column(table: Any, name: str) -> np.ndarray:
    return np.array([np.nan if x is None else x for x in table.column(name).to_pylist()],
                    dtype=float)


def _finish(job: SweepJob, spec: SweepSpec, table: Any, timing: dict[str, Any]) -> dict[str, Any]:
    """summary.json and the figures, as one result set."""
    status = table.column("status").to_pylist()
    tip_max, tip_rms = _column(table, "tip_error_max"), _column(table, "tip_error_rms")
    columns = {v.key: table.column(v.key).to_pylist() for v in spec.vary}
    inps = inputs(spec.vary, columns)
    ranking = rank(inps, tip_max)
    summary: dict[str, Any] = {
        "runs": table.num_rows,
        "status": {s: status.count(s) for s in STATUSES},
        "engine": job.engine, "method": spec.method, "samples": spec.samples,
        "seed": spec.seed, "varied": [v.key for v in spec.vary],
        "tip_error_max": _stats(tip_max), "tip_error_rms": _stats(tip_rms),
        "sensitivity": {"output": "tip_error_max", "index": "S1 (first-order, from the runs)",
                        "ranking": [{"input": s.input, "s1": s.s1, "spearman": s.spearman,
                                     "runs": s.runs, "groups": s.groups,
                                     "noise_floor": s.noise_floor} for s in ranking]},
        **timing,
    }
    with ResultSet(job.out, kind="sweep") as rs:
        names: list[str] = []
        if job.figures:
            from .figures import write_figures

            names = write_figures(rs.staging, inps, ranking, tip_max, tip_rms, status)
        summary["files"] = sorted([*names, "summary.json"])
        rs.write_text("summary.json", strict_json(summary) + "\n")
    return summary


def _run_missing(job: SweepJob, spec: SweepSpec, plan: SweepPlan, todo: list[RunInput],
                 recorded: int, fresh: bool, progress: Callable[[int, int], None] | None,
                 ) -> dict[str, Any]:
    """Run ``todo`` on the cluster, recording each batch as it finishes; the sweep's
    description is written (``fresh``) once the cluster is there, so a cluster that cannot be
    reached leaves nothing behind. Returns the invocation's timing; RrrError when batches were
    lost (after every finished batch was recorded)."""
    from .execution import batch_size, batches, dask_client, execute, worker_threads

    arrow_schema = schema(spec.vary)
    start = time.perf_counter()
    with dask_client(job.workers, job.scheduler) as client:
        connect = time.perf_counter() - start
        if fresh:
            _write_description(job.out, job, plan, spec)
        start = time.perf_counter()
        threads = worker_threads(client)
        size = job.batch or batch_size(len(todo), threads, job.engine)

        def record(rows: list[dict[str, Any]]) -> None:
            nonlocal recorded
            write_part(job.out / RESULTS, rows, arrow_schema)
            recorded += len(rows)
            if progress is not None:
                progress(recorded, spec.samples)

        lost = execute(client, plan, batches(todo, size), record)
        elapsed = time.perf_counter() - start
    if lost:
        n = sum(len(r) for r, _ in lost)
        batches_lost = f"{len(lost)} batch{'es' if len(lost) != 1 else ''} lost"
        raise RrrError(f"{n} of {len(todo)} runs were not recorded: {batches_lost} "
                       f"(first: {lost[0][1]}); the {recorded} recorded runs are in "
                       f"{job.out / RESULTS}: rerun with --resume to run the others")
    return {"runs": len(todo), "cluster_start": connect, "wall_time": elapsed,
            "runs_per_second": len(todo) / elapsed if elapsed > 0 else None,
            "worker_threads": threads}


def run_sweep(job: SweepJob, progress: Callable[[int, int], None] | None = None,
              ) -> dict[str, Any]:
    """Run the sweep (the runs not yet recorded, with ``resume``) and write its outputs;
    returns the summary written to summary.json. ``progress(done, total)`` reports the runs
    recorded. RrrError (after recording every finished batch) when batches were lost."""
    _check_job(job)
    require_dependencies()
    check_folder(job.out)
    spec = read_spec(job.spec)
    plan = make_plan(spec, job.engine)
    created = make_folders(job.out)
    try:
        # the folder is this sweep's from here on: a second sweep into it is refused at once
        with folder_lock(job.out, "sweep", what="another rrr sweep"):
            return _claimed(job, spec, plan, progress)
    finally:  # a sweep that wrote nothing leaves no folder behind
        for d in reversed(created):
            try:
                d.rmdir()
            except OSError:
                break


def _claimed(job: SweepJob, spec: SweepSpec, plan: SweepPlan,
             progress: Callable[[int, int], None] | None) -> dict[str, Any]:
    arrow_schema = schema(spec.vary)
    resumed = _check_folder_state(job.out, plan, spec, job.resume)
    inputs = design(spec)
    seeds = [r.seed for r in inputs]
    done = finished_runs(job.out / RESULTS, arrow_schema, seeds) if resumed else set()
    todo = [r for r in inputs if r.run not in done]
    log.info("%d runs (%s), %d recorded, %d to run on the %s engine", spec.samples,
             spec.method, len(done), len(todo), job.engine)
    if progress is not None:
        progress(len(done), spec.samples)
    timing: dict[str, Any] = {"runs": 0, "cluster_start": 0.0, "wall_time": 0.0,
                              "runs_per_second": None, "worker_threads": 0}
    if todo:
        timing = _run_missing(job, spec, plan, todo, len(done), not resumed, progress)
    table = read_results(job.out / RESULTS, arrow_schema, seeds)
    return _finish(job, spec, table, {"this_invocation": timing})
