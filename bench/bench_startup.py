"""Start-up time of the ``rrr`` command line against ``python -c "import numpy"``.

Runs each command as a fresh process, interleaved (numpy, rrr --help, rrr fmus, numpy, ...) so
that a change of machine load affects all of them alike, and prints min / median / max and the
ratio of the medians. Also lists the heavy modules each rrr command imported (none expected).

Run:  python bench/bench_startup.py [--repeats 15] [--rrr PATH]
(``PYTHONPATH=<another rrr_robot's parent> python bench/bench_startup.py`` times another copy
of the package: the rrr script imports rrr_robot from PYTHONPATH first.)
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys

from _timing import Series, add_quick, apply_quick, timed

HEAVY = ("numpy", "scipy", "matplotlib", "fmpy", "cantools", "can", "pandas", "pyarrow")


def _time(cmd: list[str]) -> float:
    return timed(lambda: subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL))[1]


def _heavy_imports(args: list[str]) -> list[str]:
    """The heavy top-level packages loaded by ``rrr ARGS`` (run in-process in a child)."""
    code = ("import sys\nfrom rrr_robot.cli import main\ntry:\n    main(sys.argv[1:])\n"
            "except SystemExit:\n    pass\n"
            f"print('HEAVY:' + ','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code, *args], check=True, text=True,
                         capture_output=True).stdout
    line = [x for x in out.splitlines() if x.startswith("HEAVY:")][-1]
    return [m for m in line.removeprefix("HEAVY:").split(",") if m]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--rrr", default=shutil.which("rrr") or "rrr", help="the rrr script")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"repeats": 2})
    cmds = {
        'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
        "rrr --help": [args.rrr, "--help"],
        "rrr fmus": [args.rrr, "fmus"],
    }
    for cmd in cmds.values():  # warm the file cache
        _time(cmd)
    times: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(args.repeats):
        for name, cmd in cmds.items():
            times[name].append(_time(cmd))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{args.repeats} interleaved runs each, load average {load:.2f}")
    print("| command | min [ms] | median [ms] | max [ms] | median / numpy's |")
    print("|---|---:|---:|---:|---:|")
    base = Series.of(times['python -c "import numpy"']).median
    for name, ts in times.items():
        med = Series.of(ts).median
        print(f"| `{name}` | {1e3 * min(ts):.0f} | {1e3 * med:.0f} | {1e3 * max(ts):.0f} | "
              f"{med / base:.2f} |")
    for argv in (["--help"], ["fmus"]):
        print(f"heavy modules imported by rrr {' '.join(argv)}: "
              f"{', '.join(_heavy_imports(argv)) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
