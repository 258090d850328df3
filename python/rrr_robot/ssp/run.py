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

The archive is checked first (:func:`~rrr_robot.ssp.archive.read_ssp`) and the tools run what
the check extracted (the SSD and the FMUs it references, nothing else) in a fresh scratch
folder that goes when the run ends, however it ends; the tools' own temporary folders are put
inside it. libcosim runs in a child process (:mod:`._libcosim_child`): it aborts the process
when an FMU fails in one of its threads and acts on no signal during a call, so Ctrl-C and
SIGTERM stop the child at once and an abort is a one-line error.

The rows of the table are the tool's samples at the end of each step (t_1 ... t_N);
the reference columns are the table's samples at the row times (the reference FMU plays them
``lookahead`` ahead), so the tip error compares the plant's tip with the reference at the same
time, as in ``rrr writing``.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.archives import scratch_folder
from ..core.outputs import ResultSet, check_folder
from ..core.summary import reference_section, write_summary
from ..errors import BadInputError, RrrError
from ..sim.cosim import CosimResult
from ..writing.job import PAPER_RMS_U_C, PAPER_RMS_U_N, metrics, scenario_summary
from ._libcosim_child import TAG
from .archive import SspArchive, read_ssp, reference_rows
from .export import CTRL_OUT, PLANT_OUT

log = logging.getLogger(__name__)

__all__ = ["TOOLS", "SspRun", "run_ssp"]

#: The tools that run an archive (``rrr run-ssp --tool``).
TOOLS = ("libcosim", "fmpy")
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
    mcap: bool = False   # also <scenario>.mcap: the run as ROS 2 messages (core.mcap_log)


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
            not np.allclose(ref.q, np.column_stack([table[n]
                                                    for n in fv.names("reference", "q_ref")]),
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


def _libcosim(arch: SspArchive, work: Path, real_time: bool, progress: Progress) -> Signals:
    """libcosim on the checked extraction ``work/ssp``, in a child process (see
    :mod:`._libcosim_child`) whose temporary folders are in ``work/tmp``."""
    if importlib.util.find_spec("libcosimpy") is None:
        raise BadInputError("--tool libcosim needs libcosimpy: pip install 'rrr_robot[ssp]'")
    (work / "tmp").mkdir()
    job = {"ssp": str(work / "ssp"), "start": arch.start_time, "step": arch.step,
           "steps": arch.n_steps, "real_time": real_time, "recorded": RECORDED,
           "debug": log.isEnabledFor(logging.DEBUG), "out": str(work / "libcosim.npz")}
    (work / "job.json").write_text(json.dumps(job), encoding="utf-8")
    env = {**os.environ, "TMPDIR": str(work / "tmp"), "TMP": str(work / "tmp"),
           "TEMP": str(work / "tmp")}
    child = subprocess.Popen([sys.executable, "-m", "rrr_robot.ssp._libcosim_child",
                              str(work / "job.json")], stdout=subprocess.PIPE, text=True,
                             env=env)
    error = ""
    try:
        assert child.stdout is not None
        for line in child.stdout:
            if not line.startswith(TAG):  # libcosim's log: passed on
                sys.stdout.write(line)
                continue
            word, _, rest = line[len(TAG):].strip().partition(" ")
            if word == "progress" and progress is not None:
                done, total = (int(x) for x in rest.split())
                progress(done, total)
            elif word == "error":
                error = rest
        rc = child.wait()
    finally:  # Ctrl-C, SIGTERM, an error here: the child ends with the parent, at once
        _stop(child)
    if rc < 0:
        name = signal.Signals(-rc).name if -rc in signal.valid_signals() else str(-rc)
        raise RrrError(f"{arch.path}: libcosim ended by the signal {name} (an FMU's error in "
                       "one of its threads, see its log above)")
    if rc != 0 or not (work / "libcosim.npz").is_file():
        raise RrrError(f"{arch.path}: {error or f'libcosim failed (exit {rc})'}")
    with np.load(work / "libcosim.npz") as res:
        values = {comp: {v: res[f"{comp}.{v}"] for v in names}
                  for comp, names in RECORDED.items()}
        details: dict[str, Any] = {"real_time": real_time}
        if real_time:
            details["libcosim_real_time_factor"] = float(res["real_time_factor"])
        return Signals(res["t"], values, float(res["wall_time"]), details)


#: seconds the libcosim child has to end after SIGTERM before it is killed (libcosim acts on no
#: signal during a call): a run stops within about this long of Ctrl-C or SIGTERM
CHILD_STOP_GRACE = 1.0


def _stop(child: subprocess.Popen[str]) -> None:
    """End the child now if it still runs (SIGTERM, then SIGKILL after CHILD_STOP_GRACE)."""
    if child.poll() is None:
        child.terminate()
        try:
            child.wait(timeout=CHILD_STOP_GRACE)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
    if child.stdout is not None:
        child.stdout.close()


@contextlib.contextmanager
def _temporary_files_in(folder: Path) -> Iterator[None]:
    """Python's temporary files (FMPy's extraction folders) go into ``folder`` in the block."""
    folder.mkdir()
    previous = tempfile.tempdir
    tempfile.tempdir = str(folder)
    try:
        yield
    finally:
        tempfile.tempdir = previous


def _fmpy(arch: SspArchive, work: Path, progress: Progress) -> Signals:
    """FMPy's simulate_ssp on an archive of the checked extraction ``work/ssp`` (FMPy reads a
    zip); its extraction folders go into ``work/tmp``."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    clean = work / "checked.ssp"
    with zipfile.ZipFile(clean, "w", zipfile.ZIP_STORED) as z:
        for path in sorted((work / "ssp").rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(work / "ssp").as_posix())

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
        with _temporary_files_in(work / "tmp"):
            res = simulate_ssp(str(clean), start_time=arch.start_time,
                               stop_time=arch.stop_time, step_size=arch.step,
                               parameter_set=pset)
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


def _result(arch: SspArchive, sig: Signals) -> CosimResult:
    ref = reference_rows(arch.table, sig.t, arch.step, str(arch.path))
    p, c = sig.values["plant"], sig.values["controller"]

    def stack(d: dict[str, FloatArray], fmu: str, vector: str) -> FloatArray:
        return np.column_stack([d[n] for n in fv.names(fmu, vector)])

    return CosimResult(
        t=sig.t,
        q_ref=stack(ref, "reference", "q_ref"), qd_ref=stack(ref, "reference", "qd_ref"),
        x_ref=stack(ref, "reference", "x_ref"),
        q=stack(p, "plant", "q"), qd=stack(p, "plant", "qd"), qdd=stack(p, "plant", "qdd"),
        tip=stack(p, "plant", "tip"),
        u=stack(c, "controller", "u"), u_n=stack(c, "controller", "u_n"),
        u_c=stack(c, "controller", "u_c"), wall_time=sig.wall_time,
    )


def run_ssp(job: SspRun, progress: Progress = None) -> dict[str, Any]:
    """Run the archive in the tool and write the results; returns the summary (summary.json)."""
    check_folder(job.out)
    if job.tool not in TOOLS:
        raise BadInputError(f"unknown tool {job.tool!r}: one of {', '.join(TOOLS)}")
    if job.real_time and job.tool != "libcosim":
        raise BadInputError("--real-time needs --tool libcosim (FMPy has no real-time mode)")
    if job.mcap:
        from ..core.mcap_log import require_mcap

        require_mcap()   # without the mcap package: refused before the run
    # the archive's checked entries, the tools' temporary folders: in one fresh folder that
    # goes when the run ends, however it ends
    with scratch_folder("rrr-run-ssp-") as work:
        (work / "ssp").mkdir()
        arch = read_ssp(job.ssp, workdir=work / "ssp")
        return _run(job, arch, work, progress)


def _run(job: SspRun, arch: SspArchive, work: Path, progress: Progress) -> dict[str, Any]:
    name = arch.scenario
    with ResultSet(job.out, kind="run-ssp") as rs:
        sig = (_libcosim(arch, work, job.real_time, progress) if job.tool == "libcosim"
               else _fmpy(arch, work, progress))
        res = _result(arch, sig)
        res.write(rs.path(f"{name}.csv"), "csv")
        if job.mcap:
            from ..core.mcap_log import write_mcap

            write_mcap(rs.path(f"{name}.mcap"), res.columns(), job.robot,
                       metadata={"scenario": name, "engine": f"ssp:{job.tool}",
                                 "ssp": str(job.ssp)})
        s = scenario_summary(metrics(res))
        simulated = float(sig.t[-1] - arch.start_time)
        summary: dict[str, Any] = {
            "scenarios": {name: s},
            "reference": reference_section(arch.info.get("text"),
                                           arch.stop_time - arch.start_time, arch.step),
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
        summary = write_summary(rs, summary)
    return summary


def _tip_error_max(res: CosimResult) -> float:
    """The maximum tip error of a result, m."""
    return float(np.max(np.linalg.norm(res.tip - res.x_ref, axis=1)))
