"""What an ``rrr`` command costs beyond its own work: each command a fresh process, the commands
interleaved run by run, so that a change of machine load affects all of them alike.

- ``cli``: the start of the command line, ``rrr --help`` and ``rrr fmus``, against ``python -c
  "import numpy"``; and the heavy modules each of the two imported (none expected).
- ``writing``: the fixed cost of one ``rrr writing --no-figures --scenario ctc``: its wall time
  beyond its co-simulation (summary.json's ``wall_time``), with its caches filled (the tip plan,
  rrr_robot.writing.plan_cache) and with none (``RRR_NO_CACHE=1``), against ``python -c pass``.

Every command runs as ``python -m rrr_robot ...``. With ``--baseline DIR`` (a folder holding
another ``rrr_robot`` package, e.g. a copy of an older install's ``site-packages/rrr_robot`` made
with ``cp -a``; it is put first on PYTHONPATH) every command also runs on that copy, right after
this one's, and the ratio this / baseline is taken run by run. Prints min / median / max in ms
of the wall time and of the process's CPU time (user + system: the steadier measure on a loaded
machine), and each ratio as min / median / max over the repeats.

Run:  python bench/bench_startup.py [--part cli|writing] [--repeats 15] [--baseline DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from _timing import Series, add_quick, apply_quick, timed

HEAVY = ("numpy", "scipy", "matplotlib", "fmpy", "cantools", "can", "pandas", "pyarrow")
PARTS = ("cli", "writing")
PYTHON = "`python -c pass`"


def _env(pythonpath: str | None, **extra: str) -> dict[str, str]:
    env = {**os.environ, **extra}
    env.pop("PYTHONPATH", None)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    return env


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _time(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """The wall time and the CPU time (user + system) of the command's process."""
    cpu = _cpu()
    wall = timed(lambda: subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL))[1]
    return wall, _cpu() - cpu


def _rrr(*args: str) -> list[str]:
    return [sys.executable, "-m", "rrr_robot", *args]


def _heavy_imports(args: list[str], env: dict[str, str]) -> list[str]:
    """The heavy top-level packages loaded by ``rrr ARGS`` (run in-process in a child)."""
    code = ("import sys\nfrom rrr_robot.cli import main\ntry:\n    main(sys.argv[1:])\n"
            "except SystemExit:\n    pass\n"
            f"print('HEAVY:' + ','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code, *args], check=True, text=True, env=env,
                         capture_output=True).stdout
    line = [x for x in out.splitlines() if x.startswith("HEAVY:")][-1]
    return [m for m in line.removeprefix("HEAVY:").split(",") if m]


def _ms(values: list[float]) -> str:
    return Series.of(values).format(lambda v: f"{1e3 * v:.0f}")


def _table(title: str, walls: dict[str, list[float]], cpus: dict[str, list[float]],
           wall_title: str = "wall") -> None:
    """One row per command and copy (ms); with a baseline, per command this / baseline run by
    run."""
    print(f"| {title} | {wall_title}, min / median / max [ms] | CPU time [ms] |")
    print("|---|---:|---:|")
    for name, values in walls.items():
        print(f"| {name} | {_ms(values)} | {_ms(cpus[name])} |")
    for name in walls:
        base = name.replace("this: ", "baseline: ", 1)
        if name.startswith("this: ") and base in walls:
            wall = Series.of(walls[name]).over(Series.of(walls[base]))
            cpu = Series.of(cpus[name]).over(Series.of(cpus[base]))
            print(f"| {name.removeprefix('this: ')}: this / baseline, run by run | "
                  f"{wall.format('.3f')} | {cpu.format('.3f')} |")


def _interleave(runs: dict[str, Callable[[], tuple[float, float]]], repeats: int
                ) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """Each run once per repeat, in order, after one warm-up each: walls and CPU times."""
    for run in runs.values():  # warms the file cache (and fills the caches)
        run()
    walls: dict[str, list[float]] = {k: [] for k in runs}
    cpus: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            wall, cpu = run()
            walls[name].append(wall)
            cpus[name].append(cpu)
    return walls, cpus


def cli(repeats: int, copies: dict[str, str | None]) -> None:
    runs: dict[str, Callable[[], tuple[float, float]]] = {
        '`python -c "import numpy"`': lambda: _time([sys.executable, "-c", "import numpy"],
                                                    _env(None))}
    for copy, path in copies.items():
        env = _env(path)
        for args in ("--help", "fmus"):
            runs[f"{copy}: `rrr {args}`"] = lambda args=args, env=env: _time(_rrr(args), env)
    walls, cpus = _interleave(runs, repeats)
    print(f"\n## The command line's start: {repeats} interleaved runs each, load average "
          f"{os.getloadavg()[0]:.2f}\n")
    _table("command", walls, cpus)
    numpy = Series.of(walls['`python -c "import numpy"`'])
    for name, values in walls.items():
        if "rrr " in name:
            print(f"| {name}: / numpy's, run by run | "
                  f"{Series.of(values).over(numpy).format('.2f')} | |")
    for copy, path in copies.items():
        for args in ("--help", "fmus"):
            print(f"{copy}: heavy modules imported by rrr {args}: "
                  f"{', '.join(_heavy_imports([args], _env(path))) or 'none'}")


def writing(repeats: int, copies: dict[str, str | None]) -> None:
    cosim: list[float] = []
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as tmp:
        root = Path(tmp)

        def run(env: dict[str, str]) -> tuple[float, float]:
            """Wall time beyond the co-simulation, and the process's CPU time."""
            out = root / "out"
            wall, cpu = _time(_rrr("writing", "--no-figures", "--scenario", "ctc", "--out",
                                   str(out)), env)
            sim = float(json.loads((out / "summary.json").read_text())
                        ["scenarios"]["ctc"]["wall_time"])
            shutil.rmtree(out)
            cosim.append(sim)
            return wall - sim, cpu

        runs: dict[str, Callable[[], tuple[float, float]]] = {}
        for copy, path in copies.items():
            cache = _env(path, RRR_CACHE_DIR=str(root / f"cache-{copy}"))
            cache.pop("RRR_NO_CACHE", None)
            runs[f"{copy}: caches filled"] = lambda env=cache: run(env)
            runs[f"{copy}: no cache (RRR_NO_CACHE=1)"] = (
                lambda env={**cache, "RRR_NO_CACHE": "1"}: run(env))
        runs[PYTHON] = lambda: _time([sys.executable, "-c", "pass"], _env(None))
        beyond, cpus = _interleave(runs, repeats)
    print(f"\n## `rrr writing --no-figures --scenario ctc` beyond its co-simulation: {repeats} "
          f"interleaved runs each, load average {os.getloadavg()[0]:.2f}; the co-simulation "
          f"(summary.json wall_time) {1e3 * Series.of(cosim).median:.0f} ms median\n")
    _table("run", beyond, cpus, f"wall beyond the co-simulation ({PYTHON}: wall)")
    for copy in copies:
        uncached = Series.of(beyond[f"{copy}: no cache (RRR_NO_CACHE=1)"])
        print(f"| {copy}: no cache / caches filled, run by run | "
              f"{uncached.over(Series.of(beyond[f'{copy}: caches filled'])).format('.2f')} | |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", action="append", choices=PARTS,
                    help="what to measure (repeatable; default: both)")
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--baseline", help="folder holding another rrr_robot package")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 1})
    copies: dict[str, str | None] = {"this": None}
    if args.baseline:
        copies = {"this": None, "baseline": str(Path(args.baseline).resolve())}
    for part in args.part or PARTS:
        {"cli": cli, "writing": writing}[part](args.repeats, copies)
    return 0


if __name__ == "__main__":
    sys.exit(main())
