"""``rrr run-ssp``: run an archive of ``rrr ssp`` in libcosim or in FMPy's SSP support, as each
tool runs it, and write ``summary.json`` and ``<scenario>.csv`` in the format of ``rrr writing``
(the same metrics and columns: :func:`~rrr_robot.writing.job.metrics`,
:func:`~rrr_robot.writing.job.scenario_summary`, :class:`~rrr_robot.sim.cosim.CosimResult`).

Both tools step every FMU, then pass the outputs on (a Jacobi data flow):

- libcosim (``CosimExecution.from_ssp_file``; parameter bindings, connections and the fixed step
  from the archive) propagates the connections during initialization, records step 0, and its
  time series observer gives every variable after each step;
- FMPy (``fmpy.ssp.simulation.simulate_ssp``) does not apply the SSD's parameter bindings itself:
  it takes a parameter set, which is built here from the bindings (names prefixed with the
  component, Booleans as Python bools: FMPy sets a Boolean to ``value != 0.0``, true for the
  text "false"); its connectors start at 0.0 and it records each step's outputs under the
  step's start time, which is corrected here to the end time.

The rows of the table are the tool's samples at the end of each step (t_1 ... t_N);
the reference columns are the table's samples at the row times (the reference FMU plays them
``lookahead`` ahead), so the tip error compares the plant's tip with the reference at the same
time, as in ``rrr writing``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.outputs import ResultSet, check_folder, strict_json, to_strict_json_value
from ..errors import BadInputError, RrrError
from ..sim.cosim import CosimResult
from ..writing.job import PAPER_RMS_U_C, PAPER_RMS_U_N, metrics, scenario_summary
from .archive import SspArchive, read_ssp
from .export import CTRL_OUT, PLANT_OUT

log = logging.getLogger(__name__)

__all__ = ["TOOLS", "SspRun", "run_ssp"]

TOOLS = ("libcosim", "fmpy")
_NS = 1_000_000_000  # libcosim counts time in integer nanoseconds
#: what is recorded of each component (the columns of rrr writing that come from the FMUs)
RECORDED = {"plant": list(PLANT_OUT), "controller": list(CTRL_OUT)}


@dataclass(frozen=True)
class SspRun:
    """What to run: the archive, the tool, the output folder, libcosim's real-time mode, the
    figures (those of ``rrr writing``) and the robot file the archive was written from (for
    them; None: the packaged default robot when the archive names it)."""

    ssp: Path
    tool: str
    out: Path
    real_time: bool = False
    figures: bool = True
    robot: Path | None = None


def _figures(job: SspRun, arch: SspArchive, res: CosimResult, folder: Path) -> None:
    """The figures of ``rrr writing`` for this run: the writing reference rebuilt from the
    archive's text and scale with its robot file (checked against the archive's table), then
    Figs 2-9 and the tip error."""
    from ..core.model import DEFAULT_ROBOT_TOML
    from ..writing.job import WritingJob, prepare
    from ..writing.plots import write_figures

    robot = job.robot
    if robot is None:
        if arch.info.get("robot", DEFAULT_ROBOT_TOML.name) != DEFAULT_ROBOT_TOML.name:
            raise BadInputError(f"{arch.path} was written from the robot file "
                                f"{arch.info.get('robot')}: give it with --robot for the "
                                "figures (or --no-figures)")
        robot = DEFAULT_ROBOT_TOML
    scale = float(arch.info.get("scale", "1.0"))
    model, robot_file, _, ref = prepare(WritingJob(out=folder, text=arch.info.get("text"),
                                                   scenarios=["ctc"], robot=robot, scale=scale,
                                                   figures=True))
    table = arch.table
    if (ref.t.size != table["t"].size or
            not np.allclose(ref.q, np.column_stack([table[f"q_ref[{i}]"] for i in (1, 2, 3)]),
                            rtol=0.0, atol=1e-9)):
        raise BadInputError(f"the writing reference rebuilt from {robot} is not the table of "
                            f"{arch.path}: give the robot file it was written from with --robot "
                            "(or --no-figures)")
    write_figures(folder, model, robot_file, ref, {arch.scenario: res})


@dataclass(frozen=True)
class Signals:
    """What a tool recorded: row times and, per component, variable -> values."""

    t: FloatArray
    values: dict[str, dict[str, FloatArray]]
    wall_time: float
    details: dict[str, Any]


Progress = Callable[[int, int], None] | None


def _libcosim(arch: SspArchive, real_time: bool, progress: Progress) -> Signals:
    try:
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:
        raise BadInputError("--tool libcosim needs libcosimpy: pip install 'rrr_robot[ssp]' "
                            f"({exc})") from exc
    # libcosim's and the FMI Library's warnings and errors; with rrr -v also their progress
    log_output_level(CosimLogLevel.INFO if log.isEnabledFor(logging.DEBUG)
                     else CosimLogLevel.WARNING)
    try:
        ex = CosimExecution.from_ssp_file(str(arch.path))
    except AssertionError as exc:
        raise RrrError(f"{arch.path}: libcosim could not load the archive (its log above says "
                       "why)") from exc
    n = arch.n_steps
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    index = {s.name.decode(): s.index for s in ex.slave_infos()}
    vrs = {name: {v.name.decode(): v.reference for v in ex.slave_variables(i)}
           for name, i in index.items()}
    for comp, names in RECORDED.items():
        for v in names:
            obs.start_time_series(index[comp], vrs[comp][v], CosimVariableType.REAL)
    if real_time and not ex.real_time_simulation_enabled(True):
        raise RrrError("libcosim refused the real-time mode")
    # as fast as it goes: in 100 calls of simulate_until, for the progress bar; real time: in
    # one call, since libcosim's real-time clock starts anew with every call
    start = time.perf_counter()
    chunk = n if real_time else max(1, n // 100)
    done = 0
    while done < n:
        done = min(n, done + chunk)
        target = round((arch.start_time + done * arch.step) * _NS)
        if not ex.simulate_until(target):
            raise RrrError(f"{arch.path}: libcosim stopped at t = "
                           f"{ex.status().current_time / _NS:.6f} s (its log above says why)")
        if progress is not None:
            progress(done, n)
    wall = time.perf_counter() - start
    values: dict[str, dict[str, FloatArray]] = {}
    t_ns: list[int] = []
    for comp, names in RECORDED.items():
        values[comp] = {}
        for v in names:
            # from step 1: libcosimpy drops as many samples as it finds step numbers 0 (it
            # takes them for unfilled entries), which would cut the last one
            tp, steps, vals = obs.time_series_real_samples(index[comp], vrs[comp][v],
                                                           from_step=1, sample_count=n)
            if len(vals) != n or list(steps) != list(range(1, n + 1)):
                raise RrrError(f"libcosim recorded {len(vals)} samples of {comp}.{v}, expected "
                               f"{n} (steps 1 to {n})")
            values[comp][v] = np.asarray(vals, dtype=np.float64)
            t_ns = list(tp)
    details: dict[str, Any] = {"real_time": real_time}
    if real_time:  # libcosim's own figure: the factor over its last monitored steps
        details["libcosim_real_time_factor"] = float(ex.status().real_time_factor)
    return Signals(np.asarray(t_ns, dtype=np.float64) / _NS, values, wall, details)


def _fmpy(arch: SspArchive, progress: Progress) -> Signals:
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    pset = ParameterSet(name="bindings")
    for comp, params in arch.parameters.items():
        for name, value in params.items():
            p = Parameter(name=f"{comp}.{name}")
            p.type = "Boolean" if isinstance(value, bool) else "Real"
            p.value = value
            pset.parameters.append(p)
    start = time.perf_counter()
    if progress is not None:
        progress(0, arch.n_steps)
    try:
        res = simulate_ssp(str(arch.path), start_time=arch.start_time, stop_time=arch.stop_time,
                           step_size=arch.step, parameter_set=pset)
    except Exception as exc:  # FMPy raises FMICallException or bare exceptions
        raise RrrError(f"{arch.path}: FMPy's simulate_ssp failed: {exc}") from exc
    wall = time.perf_counter() - start
    if progress is not None:
        progress(arch.n_steps, arch.n_steps)
    t_end = np.asarray(res["time"], dtype=np.float64) + arch.step  # the step's end
    keep = t_end <= arch.stop_time + 1e-9 * max(1.0, abs(arch.stop_time))
    values = {comp: {v: np.asarray(res[f"{comp}.{v}"], dtype=np.float64)[keep] for v in names}
              for comp, names in RECORDED.items()}
    return Signals(t_end[keep], values, wall, {"real_time": False})


def _reference_at(arch: SspArchive, t: FloatArray) -> dict[str, FloatArray]:
    """The table's samples at the times t (which must be sample times)."""
    tt = arch.table["t"]
    k = np.clip(np.searchsorted(tt, t - 1e-9 * arch.step), 0, tt.size - 1)
    if not np.all(np.abs(tt[k] - t) <= 1e-6 * arch.step):
        raise BadInputError(f"{arch.path}: the step {arch.step} s does not fall on the "
                            "reference table's samples")
    return {name: col[k] for name, col in arch.table.items()}


def _result(arch: SspArchive, sig: Signals) -> CosimResult:
    ref = _reference_at(arch, sig.t)
    p, c = sig.values["plant"], sig.values["controller"]

    def stack(d: dict[str, FloatArray], names: list[str]) -> FloatArray:
        return np.column_stack([d[n] for n in names])

    j = (1, 2, 3)
    return CosimResult(
        t=sig.t,
        q_ref=stack(ref, [f"q_ref[{i}]" for i in j]),
        qd_ref=stack(ref, [f"qd_ref[{i}]" for i in j]),
        x_ref=stack(ref, ["x_ref.x", "x_ref.y", "x_ref.z"]),
        q=stack(p, [f"q[{i}]" for i in j]), qd=stack(p, [f"qd[{i}]" for i in j]),
        qdd=stack(p, [f"qdd[{i}]" for i in j]), tip=stack(p, ["tip.x", "tip.y", "tip.z"]),
        u=stack(c, [f"u[{i}]" for i in j]), u_n=stack(c, [f"u_n[{i}]" for i in j]),
        u_c=stack(c, [f"u_c[{i}]" for i in j]), wall_time=sig.wall_time,
    )


def run_ssp(job: SspRun, progress: Progress = None) -> dict[str, Any]:
    """Run the archive in the tool and write the results; returns the summary (summary.json)."""
    check_folder(job.out)
    if job.tool not in TOOLS:
        raise BadInputError(f"unknown tool {job.tool!r}: one of {', '.join(TOOLS)}")
    if job.real_time and job.tool != "libcosim":
        raise BadInputError("--real-time needs --tool libcosim (FMPy has no real-time mode)")
    arch = read_ssp(job.ssp)
    name = arch.scenario
    with ResultSet(job.out, kind="run-ssp") as rs:
        sig = (_libcosim(arch, job.real_time, progress) if job.tool == "libcosim"
               else _fmpy(arch, progress))
        res = _result(arch, sig)
        res.write(rs.path(f"{name}.csv"), "csv")
        s = scenario_summary(metrics(res))
        simulated = float(sig.t[-1] - arch.start_time)
        summary: dict[str, Any] = {
            "scenarios": {name: s},
            "reference": {"text": arch.info.get("text"), "duration": arch.stop_time -
                          arch.start_time, "step": arch.step},
            "engine": f"ssp:{job.tool}",
            "fmi_version": "2.0",
            "ssp": {"file": str(job.ssp), "tool": job.tool, "rows": int(sig.t.size),
                    "first_row_time": float(sig.t[0]), "simulated_time": simulated,
                    "wall_time": sig.wall_time,
                    "real_time_factor": simulated / sig.wall_time if sig.wall_time > 0 else None,
                    "lookahead_steps": arch.info.get("lookahead_steps"), **sig.details},
            "paper_eq16": {"rms_u_n": list(PAPER_RMS_U_N), "rms_u_c": list(PAPER_RMS_U_C)},
        }
        if job.figures:
            _figures(job, arch, res, rs.staging)
        log.info("%s in %s: tip error max %.3f mm, %.1fx real time", name, job.tool,
                 1e3 * _tip_error_max(res),
                 simulated / sig.wall_time if sig.wall_time > 0 else np.inf)
        summary["files"] = sorted([*rs.names(), "summary.json"])
        summary = to_strict_json_value(summary)
        rs.write_text("summary.json", strict_json(summary) + "\n")
    return summary


def _tip_error_max(res: CosimResult) -> float:
    """The maximum tip error of a result, m."""
    return float(np.max(np.linalg.norm(res.tip - res.x_ref, axis=1)))
