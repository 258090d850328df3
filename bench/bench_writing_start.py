"""Fixed cost of one ``rrr writing --no-figures --scenario ctc``: wall time beyond its
co-simulation, with the writing task's tip plan cached and without the cache.

Each command is a fresh process, interleaved (cached, uncached, ``python -c pass``, cached, ...),
so that a change of machine load affects all of them alike. The co-simulation's own wall time is
read from each run's summary.json (``wall_time``); "beyond" is the process's wall time minus it.
Prints min / median / max in ms and the ratio of the medians.

Run:  python bench/bench_writing_start.py [--repeats 15] [--rrr PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _timing import Series, add_quick, apply_quick, timed


def _run(cmd: list[str], env: dict[str, str]) -> float:
    return timed(lambda: subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL))[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--rrr", default=shutil.which("rrr") or "rrr", help="the rrr script")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 1})
    with tempfile.TemporaryDirectory(prefix="bench-writing-start-") as tmp:
        root = Path(tmp)
        base = {**os.environ, "RRR_CACHE_DIR": str(root / "cache")}
        base.pop("RRR_NO_CACHE", None)
        envs = {"cached tip plan": base, "no cache (RRR_NO_CACHE=1)": {**base, "RRR_NO_CACHE": "1"}}
        wall: dict[str, list[float]] = {k: [] for k in envs}
        beyond: dict[str, list[float]] = {k: [] for k in envs}
        cosim: list[float] = []
        python: list[float] = []

        def writing(name: str, k: int, record: bool = True) -> None:
            out = root / f"out{k}"
            cmd = [args.rrr, "writing", "--no-figures", "--scenario", "ctc", "--out", str(out)]
            t = _run(cmd, envs[name])
            summary = json.loads((out / "summary.json").read_text())
            sim = float(summary["scenarios"]["ctc"]["wall_time"])
            shutil.rmtree(out)
            if not record:
                return
            wall[name].append(t)
            beyond[name].append(t - sim)
            cosim.append(sim)

        writing("cached tip plan", -1, record=False)  # warms the file cache, fills the plan cache
        for k in range(args.repeats):
            for name in envs:
                writing(name, k)
            python.append(_run([sys.executable, "-c", "pass"], base))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{args.repeats} interleaved runs each, load average {load:.2f}; co-simulation "
          f"(summary.json wall_time) {1e3 * Series.of(cosim).median:.0f} ms median")
    print("| run | wall min / median / max [ms] | beyond the co-simulation [ms] |")
    print("|---|---:|---:|")
    for name in envs:
        w, b = Series.of(wall[name]), Series.of(beyond[name])
        print(f"| `rrr writing --no-figures --scenario ctc`, {name} | {1e3 * w.min:.0f} / "
              f"{1e3 * w.median:.0f} / {1e3 * w.max:.0f} | {1e3 * b.min:.0f} / "
              f"{1e3 * b.median:.0f} / {1e3 * b.max:.0f} |")
    p = Series.of(python)
    print(f"| `python -c pass` | {1e3 * p.min:.0f} / {1e3 * p.median:.0f} / {1e3 * p.max:.0f} | |")
    names = list(envs)
    print(f"median beyond the co-simulation, uncached / cached: "
          f"{Series.of(beyond[names[1]]).median / Series.of(beyond[names[0]]).median:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
