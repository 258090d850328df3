"""Real-time mode of the CAN bench: wake-up latency and deadline misses of both C nodes, with and
without SCHED_FIFO, in alternating blocks.

Each block runs the writing task (held at its last pose after 5.9 s) for --duration seconds on both
C nodes in real time at 1 kHz over the socketcand transport (rrr_robot.hil.dbc.bench.run_c_bench
with RealTime), twice: once plain (the default scheduler, clock_nanosleep only: the nodes' old
mode) and once tuned (SCHED_FIFO 80, mlockall, one CPU per node, sleep-then-spin --spin-us). It
prints per configuration and node the wake-up latency p50 / p99 / p99.9 / max (us) and the deadline
misses as min / median / max over the blocks, and the plant's latched faults (a stall longer than 3
periods makes the plant's supervisor apply 0 V and latch a timeout, as it should).

    python bench/bench_hil_realtime.py [--blocks 3] [--duration 20] [--spin-us 100] [--json F]

Needs the C nodes (pip install . puts them in rrr_robot/bin; or RRR_HIL_BIN_DIR) and, for the
tuned runs, root or CAP_SYS_NICE (without it the nodes warn and run plain). Not a test: the
numbers are this machine's.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

from _timing import add_quick, apply_quick, mmm
from rrr_robot.hil.dbc.bench import RealTime, run_c_bench
from rrr_robot.hil.results import extend_reference
from rrr_robot.writing.job import WritingJob, prepare

KEYS = ("rt_latency_p50_us", "rt_latency_p99_us", "rt_latency_p999_us", "rt_latency_max_us",
        "rt_deadline_misses")


def one_run(ref: Any, realtime: RealTime) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="rrr_hil_rt_") as tmp:
        try:
            run = run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=Path(tmp),
                              realtime=realtime)
        except Exception as exc:  # a node that failed: report it, keep benchmarking
            return {"error": " ".join(str(exc).split())[:300]}
    return {"controller": run.controller_summary.get("rt", {}),
            "plant": run.plant_summary.get("rt", {}),
            "plant_faults": run.plant_summary.get("faults"),
            "stale": run.controller_summary.get("stale")}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=3, help="alternating blocks (default 3)")
    ap.add_argument("--duration", type=float, default=20.0, help="seconds per run (default 20)")
    ap.add_argument("--spin-us", type=int, default=100, help="tuned runs' spin (default 100)")
    ap.add_argument("--json", type=Path, help="also write every run's figures to this file")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"blocks": 1, "duration": 0.5})
    ref = extend_reference(prepare(WritingJob(out=Path("."), scenarios=["ctc"]))[3],
                           args.duration)
    configs = {
        "plain": RealTime(duration=args.duration + 5, fifo=0, mlock=False, cpus=None, spin_us=0),
        "tuned": RealTime(duration=args.duration + 5, fifo=80, mlock=True, cpus=(1, 0),
                          spin_us=args.spin_us),
    }
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in configs}
    for block in range(args.blocks):
        for name, cfg in configs.items():
            r = one_run(ref, cfg)
            runs[name].append(r)
            print(f"block {block + 1} {name}: " + (r["error"] if "error" in r else
                  f"controller p99 {r['controller'].get('rt_latency_p99_us', 0):.1f} us, plant "
                  f"p99 {r['plant'].get('rt_latency_p99_us', 0):.1f} us, plant faults "
                  f"{r['plant_faults']}"), flush=True)
    print(f"\nCAN bench real time, {args.blocks} alternating blocks of {args.duration:g} s per "
          "configuration (min / median / max over the blocks)")
    print(f"{'config':>6} {'node':>10} {'p50 us':>20} {'p99 us':>22} {'p99.9 us':>24} "
          f"{'max us':>26} {'misses':>14}")
    for name, rs in runs.items():
        ok = [r for r in rs if "error" not in r]
        for node in ("controller", "plant"):
            cells = []
            for key in KEYS:
                v = [float(r[node].get(key, float("nan"))) for r in ok]
                cells.append(mmm(v, ".1f") if v else "n/a")
            print(f"{name:>6} {node:>10} {cells[0]:>20} {cells[1]:>22} {cells[2]:>24} "
                  f"{cells[3]:>26} {cells[4]:>14}")
        faults = [r["plant_faults"] for r in ok]
        print(f"{name:>6} plant faults latched per run: {faults}; failed runs "
              f"{len(rs) - len(ok)}")
        if ok:
            print(f"{name:>6} setup: {ok[0]['controller'].get('rt_setup', '')}")
    if args.json:
        args.json.write_text(json.dumps(runs, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
