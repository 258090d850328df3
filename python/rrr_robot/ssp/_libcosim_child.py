"""The libcosim run of ``rrr run-ssp --tool libcosim`` in a child process
(``python -m rrr_robot.ssp._libcosim_child JOB.json``; :func:`rrr_robot.ssp.run.run_ssp` starts
it). libcosim runs the FMUs in its own threads and aborts the whole process when one of them
throws, and it acts on no signal during a call: in a child, an abort is a clear error of the
parent, Ctrl-C and SIGTERM end it at once (the parent stops it), and its temporary folders (it
is given ``TMPDIR`` inside the parent's scratch folder) go with the parent's scratch folder.

The job (JSON): ``ssp`` (an extracted, checked SSP folder), ``start``, ``step``, ``steps``,
``real_time``, ``recorded`` (component -> Real variables), ``debug`` (libcosim's INFO log),
``out`` (the .npz file of the results). Progress goes to stdout as ``@rrr-child progress DONE
TOTAL`` lines, then ``@rrr-child done`` (libcosim's own log also goes to stdout: the parent
passes its lines on). Imports only numpy and libcosimpy (a quick start).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

_NS = 1_000_000_000  # libcosim counts time in integer nanoseconds
#: The start of a line of this module to the parent (the other lines are libcosim's log).
TAG = "@rrr-child "


def _say(line: str) -> None:
    """One line to the parent (stdout)."""
    sys.stdout.write(f"{TAG}{line}\n")
    sys.stdout.flush()


def _fail(message: str) -> int:
    _say(f"error {' '.join(message.split())}")
    return 2


def run(job: dict[str, Any]) -> int:
    """Run the job; 0 when the results are written, 2 with an ``error ...`` line."""
    try:
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:
        return _fail(f"--tool libcosim needs libcosimpy: pip install 'rrr_robot[ssp]' ({exc})")
    log_output_level(CosimLogLevel.INFO if job["debug"] else CosimLogLevel.WARNING)
    try:
        ex = CosimExecution.from_ssp_file(job["ssp"])
    except AssertionError:
        return _fail("libcosim could not load the archive (its log above says why)")
    n, start_time, step = int(job["steps"]), float(job["start"]), float(job["step"])
    real_time = bool(job["real_time"])
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    index = {s.name.decode(): s.index for s in ex.slave_infos()}
    vrs = {name: {v.name.decode(): v.reference for v in ex.slave_variables(i)}
           for name, i in index.items()}
    recorded: dict[str, list[str]] = job["recorded"]
    for comp, names in recorded.items():
        for v in names:
            obs.start_time_series(index[comp], vrs[comp][v], CosimVariableType.REAL)
    if real_time and not ex.real_time_simulation_enabled(True):
        return _fail("libcosim refused the real-time mode")
    # as fast as it goes: in 100 calls of simulate_until, for the progress bar; real time: in
    # one call, since libcosim's real-time clock starts anew with every call
    start = time.perf_counter()
    chunk = n if real_time else max(1, n // 100)
    done = 0
    while done < n:
        done = min(n, done + chunk)
        if not ex.simulate_until(round((start_time + done * step) * _NS)):
            return _fail(f"libcosim stopped at t = {ex.status().current_time / _NS:.6f} s (its "
                         "log above says why)")
        _say(f"progress {done} {n}")
    wall = time.perf_counter() - start
    arrays: dict[str, Any] = {}
    t_ns: list[int] = []
    for comp, names in recorded.items():
        for v in names:
            # from step 1: libcosimpy drops as many samples as it finds step numbers 0 (it
            # takes them for unfilled entries), which would cut the last one
            tp, steps, vals = obs.time_series_real_samples(index[comp], vrs[comp][v],
                                                           from_step=1, sample_count=n)
            if len(vals) != n or list(steps) != list(range(1, n + 1)):
                return _fail(f"libcosim recorded {len(vals)} samples of {comp}.{v}, expected "
                             f"{n} (steps 1 to {n})")
            arrays[f"{comp}.{v}"] = np.asarray(vals, dtype=np.float64)
            t_ns = list(tp)
    arrays["t"] = np.asarray(t_ns, dtype=np.float64) / _NS
    arrays["wall_time"] = np.array(wall)
    if real_time:  # libcosim's own figure: the factor over its last monitored steps
        arrays["real_time_factor"] = np.array(float(ex.status().real_time_factor))
    np.savez(job["out"], **arrays)
    _say("done")
    return 0


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        sys.stderr.write("usage: python -m rrr_robot.ssp._libcosim_child JOB.json\n")
        return 2
    job = json.loads(Path(argv[0]).read_text(encoding="utf-8"))
    return run(job)


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
