"""Where a default ``rrr writing`` run spends its time after the co-simulation: the signal tables
(CSV, Parquet) and the figures, and the whole run; optionally against another copy of the
package (before/after), interleaved.

The co-simulation of the default job (pd, ctc, mismatch) runs once; its results are pickled.
Each repeat then starts, for each copy of the package, one fresh process that times

- ``csv``: writing the three ``<scenario>.csv`` (CosimResult.to_csv, atomic);
- ``parquet``: the same as Parquet (only where the copy can: CosimResult.write, pyarrow);
- ``figures``: the figures phase as ``run_writing`` runs it (import of the plotting module and
  the figure libraries, the numeric references of Figs 5 and 6, every figure), all in that
  process (wall and CPU time);

and with ``--whole``, a complete ``rrr writing --out DIR -q`` of each copy (wall time), with
the figures phase as the run logs it (copies that log it: there a forked worker has drawn
Figs 2-6 during the co-simulations, writing.figure_worker). The copies run one
after the other within a repeat (A, B, A, B, ...), so a change of machine load affects both;
min / median / max over the repeats.

Run:  python bench/bench_writing_outputs.py [--repeats 5] [--whole] [--baseline DIR]
(DIR: the folder that holds another ``rrr_robot`` package, e.g. a copy of an older install's
``site-packages/rrr_robot`` made with ``cp -a``; it is put first on PYTHONPATH.)
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import add_quick, apply_quick, mmm

PHASES = r"""
import json, pickle, sys, tempfile, time
from pathlib import Path
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.core.robot import read_robot_file
import rrr_robot.writing.job  # what a run has imported before its outputs
ref, results = pickle.load(open(sys.argv[1], "rb"))
robot = read_robot_file(DEFAULT_ROBOT_TOML)
out = {}
with tempfile.TemporaryDirectory() as tmp:
    d = Path(tmp)
    t0 = time.perf_counter()
    for name, res in results.items():
        res.to_csv(d / f"{name}.csv")
    out["csv"] = time.perf_counter() - t0
    if hasattr(res, "write"):
        try:
            import pyarrow.parquet  # noqa: F401 (imported before the timer: a run's import)
        except ImportError:
            pass
        else:
            t0 = time.perf_counter()
            for name, res in results.items():
                res.write(d / f"{name}.parquet", "parquet")
            out["parquet"] = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    from rrr_robot.writing.plots import write_figures
    write_figures(d, robot.model, robot, ref, results)
    out["figures"] = time.perf_counter() - t0
    out["figures, CPU time"] = time.process_time() - c0
    out["pngs"] = len(list(d.glob("*.png")))
print("PHASES:" + json.dumps(out))
"""


def _cosim_results(path: Path) -> None:
    from rrr_robot.core.param_names import model_fmu_values
    from rrr_robot.sim.cosim import CosimOptions, run_cosim
    from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, scenarios, ref = prepare(WritingJob(out=path.parent))
    results = {}
    for scn in scenarios:
        options = CosimOptions(step=float(ref.t[1] - ref.t[0]),
                               plant_values=model_fmu_values(model),
                               controller_values=controller_fmu_values(
                                   scn, model, robot.require_control()))
        results[scn.name] = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)
    with open(path, "wb") as fh:
        pickle.dump((ref, results), fh)


def _env(pythonpath: str | None) -> dict[str, str]:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _phases(pickled: Path, pythonpath: str | None) -> dict[str, float]:
    out = subprocess.run([sys.executable, "-c", PHASES, str(pickled)], env=_env(pythonpath),
                         check=True, capture_output=True, text=True).stdout
    line = [x for x in out.splitlines() if x.startswith("PHASES:")][-1]
    return dict(json.loads(line.removeprefix("PHASES:")))


def _whole(pythonpath: str | None, folder: Path) -> tuple[float, float | None]:
    """Wall time of a run, and its figures phase as it logs it (copies that log it)."""
    start = time.perf_counter()
    err = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--out", str(folder),
                          "-q"], env=_env(pythonpath), check=True, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True).stderr
    wall = time.perf_counter() - start
    logged = [line.rsplit(" ", 2)[-2] for line in err.splitlines()
              if "rrr_robot.writing.job: figures: " in line]
    return wall, float(logged[-1]) if logged else None


def _row(name: str, values: list[float]) -> str:
    return f"| {name} | {mmm(values, '.3f', ' | ')} |"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--baseline", help="folder holding another rrr_robot (before)")
    ap.add_argument("--whole", action="store_true", help="also time whole rrr writing runs")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 1})
    copies: dict[str, str | None] = {"this": None}
    if args.baseline:
        copies = {"baseline": args.baseline, "this": None}
    times: dict[tuple[str, str], list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        pickled = Path(tmp) / "results.pkl"
        _cosim_results(pickled)
        for _ in range(args.repeats):
            for copy, pythonpath in copies.items():
                phases = _phases(pickled, pythonpath)
                pngs = phases.pop("pngs")
                for phase, value in phases.items():
                    times.setdefault((copy, phase), []).append(value)
                if args.whole:
                    wall, figures = _whole(pythonpath, Path(tmp) / f"out-{copy}")
                    times.setdefault((copy, "whole run"), []).append(wall)
                    if figures is not None:
                        times.setdefault((copy, "figures phase within the run"), []).append(
                            figures)
        print(f"{args.repeats} repeats, interleaved; {pngs} figures; load average "
              f"{os.getloadavg()[0]:.2f} at the end")
    print("| copy: phase | min [s] | median [s] | max [s] |")
    print("|---|---:|---:|---:|")
    for (copy, phase), values in sorted(times.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        print(_row(f"{copy}: {phase}", values))
    return 0


if __name__ == "__main__":
    sys.exit(main())
