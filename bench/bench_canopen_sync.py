"""The SYNC sources of ``rrr hil canopen --realtime`` compared: ``clock`` (the Python master's own
timed loop, sleep then spin) and ``canopen`` (the package's SYNC producer,
``network.sync.start``), and beside them the C master (``--master c``: rrr_hil_rt's clock).

Each run is a fresh ``rrr -q hil canopen --realtime ... --duration D`` process, the sources
interleaved (clock, canopen, c, clock, ...), so that a change of machine load affects
both alike. Read from each run's summary.json (``realtime.drives``: the plant node's frame log,
the SYNC periods as the drives received them): the SYNC period's median and max and the
jitter's p99 and max (us), the deadline misses at the drives (a SYNC before which a drive got no
RPDO), and, for the clocks, the master's wake-up latency p99 and its misses. A run that failed
(a drive's RPDO timeout, 3 SYNC periods without a command) is counted as failed, with its
reason. Prints one row per source: runs, failed, min / median / max over the runs.

Run:  python bench/bench_canopen_sync.py [--runs 5] [--duration 5]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _quick import add_quick, apply_quick
from _timing import logger, mmm

#: The rows: (name, the options of rrr hil canopen --realtime).
SOURCES = {"clock": ["--sync-source", "clock"], "canopen": ["--sync-source", "canopen"],
           "c": ["--master", "c"]}
log = logger("canopen-sync")


def _run(rrr: list[str], source: str, duration: float, out: Path) -> dict[str, Any] | str:
    """One run's realtime section, or the reason it failed."""
    proc = subprocess.run([*rrr, "-q", "hil", "canopen", "--realtime", *SOURCES[source],
                           "--duration", f"{duration:g}", "--no-figures", "--out", str(out)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        return " ".join(proc.stderr.split())[-160:]
    rt: dict[str, Any] = json.loads((out / "summary.json").read_text())["realtime"]
    return rt


def _span(values: list[float]) -> str:
    if not values:
        return "-"
    return mmm(values, ".0f")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=5, help="runs of each source (default 5)")
    p.add_argument("--duration", type=float, default=5.0, help="seconds per run (default 5)")
    p.add_argument("--rrr", default=None, help="the rrr command (default: this Python's)")
    add_quick(p)
    args = apply_quick(p, p.parse_args(), {"runs": 1, "duration": 0.3})
    rrr = [args.rrr] if args.rrr else [sys.executable, "-m", "rrr_robot"]
    results: dict[str, list[dict[str, Any]]] = {s: [] for s in SOURCES}
    failed: dict[str, list[str]] = {s: [] for s in SOURCES}
    tmp = Path(tempfile.mkdtemp(prefix="rrr_canopen_sync_"))
    try:
        for i in range(args.runs):
            for source in SOURCES:
                got = _run(rrr, source, args.duration, tmp / f"{source}{i}")
                if isinstance(got, str):
                    failed[source].append(got)
                    log(f"{source} run {i + 1}: failed: {got}")
                else:
                    results[source].append(got)
                    d = got["drives"]
                    log(f"{source} run {i + 1}: jitter max {d['sync_jitter']['max_us']:.0f} us, "
                        f"{d['deadline_misses']} misses at the drives")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"SYNC sources, {args.runs} runs of {args.duration:g} s each, interleaved; "
          "min / median / max over the runs (us; misses: periods)")
    print(f"{'source':8} {'ok':>3} {'fail':>4}  {'period median':>16}  {'period max':>18}  "
          f"{'jitter p99':>16}  {'jitter max':>18}  {'misses (drives)':>16}  "
          f"{'master wake p99':>16}  {'master misses':>14}")
    for source in SOURCES:
        rs = results[source]
        d = [r["drives"] for r in rs]
        m = [r.get("master", {}) for r in rs]
        wake = [float(x["wake_up"]["p99_us"]) for x in m if "wake_up" in x]
        print(f"{source:8} {len(rs):>3} {len(failed[source]):>4}  "
              f"{_span([x['sync_period']['median_us'] for x in d]):>16}  "
              f"{_span([x['sync_period']['max_us'] for x in d]):>18}  "
              f"{_span([x['sync_jitter']['p99_us'] for x in d]):>16}  "
              f"{_span([x['sync_jitter']['max_us'] for x in d]):>18}  "
              f"{_span([float(x['deadline_misses']) for x in d]):>16}  "
              f"{_span(wake):>16}  "
              f"{_span([float(x['rt_deadline_misses']) for x in m if 'wake_up' in x]):>14}")
        for why in failed[source]:
            print(f"  {source} failed: {why}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
