"""Real-time mode of the CAN bench: jitter and deadline misses of both C nodes over a run.

Runs the C plant node (socketcand server) and the C controller node in real-time mode (1 kHz,
clock_nanosleep TIMER_ABSTIME on CLOCK_MONOTONIC, timer slack 1 ns; --fifo/--mlock add
SCHED_FIFO and mlockall, which need root or CAP_SYS_NICE / CAP_IPC_LOCK) on the writing task
followed by holding its last pose, for --duration seconds (default 60), and prints per node the
wake-up latency p50/p99/max, the deadline misses (a period's work ending after the next release),
plus the controller's stale periods (no fresh joint state for more than 3 periods: it then
commands 0 V) and the plant's fault counters (a silent controller: 0 V and a latched timeout).

    python bench/bench_hil_realtime.py [--duration 60] [--fifo 80] [--mlock] [--json out.json]

Needs the C nodes (pip install . puts them in rrr_robot/bin; or RRR_HIL_BIN_DIR). Not a test: the
numbers depend on the machine (a 2-vCPU VM shows multi-millisecond stalls, see
docs/can.md#lockstep-and-real-time); lockstep mode is what the tests use.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from rrr_robot.hil.nodes import export_reference, start_controller, start_plant
from rrr_robot.writing.job import WritingJob, prepare


def reference(duration: float) -> tuple[np.ndarray, ...]:
    ref = prepare(WritingJob(out=Path("."), scenarios=["ctc"]))[3]
    n = round(duration / 1e-3)
    t = np.arange(n) * 1e-3
    idx = np.minimum(np.arange(n), ref.t.size - 1)
    q = ref.q[idx]
    qd = np.where((np.arange(n) < ref.t.size)[:, None], ref.qd[idx], 0.0)
    qdd = np.where((np.arange(n) < ref.t.size)[:, None], ref.qdd[idx], 0.0)
    return t, q, qd, qdd


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds (default 60)")
    ap.add_argument("--fifo", type=int, default=0, help="SCHED_FIFO priority (0: off)")
    ap.add_argument("--mlock", action="store_true", help="mlockall in both nodes")
    ap.add_argument("--json", type=Path, help="also write the figures to this file")
    args = ap.parse_args()
    t, q, qd, qdd = reference(args.duration)
    rt = ["--realtime"] + (["--fifo", str(args.fifo)] if args.fifo else []) + \
        (["--mlock"] if args.mlock else [])
    with tempfile.TemporaryDirectory(prefix="rrr_hil_rt_") as tmp:
        ref_csv = export_reference(t, q, qd, qdd, Path(tmp) / "reference.csv")
        with start_plant(q0=q[0], qd0=qd[0],
                         extra=[*rt, "--duration", f"{args.duration + 5:.3f}"]) as plant, \
                start_controller(ref_csv, connect=f"127.0.0.1:{plant.port}",
                                 extra=rt) as ctrl:
            cs = ctrl.wait(args.duration + 60)
            ps = plant.wait(args.duration + 60)
    print(f"CAN bench, real-time mode, {args.duration:.0f} s at 1 kHz (socketcand over TCP "
          f"loopback); {cs.get('rt', {}).get('rt_setup', '')}")
    print(f"{'node':>10} {'periods':>8} {'p50 us':>8} {'p99 us':>8} {'max us':>9} "
          f"{'misses':>7} {'work max us':>12}")
    for name, s in (("controller", cs), ("plant", ps)):
        r = s.get("rt", {})
        print(f"{name:>10} {r.get('rt_periods', 0):>8} {r.get('rt_latency_p50_us', 0):8.1f} "
              f"{r.get('rt_latency_p99_us', 0):8.1f} {r.get('rt_latency_max_us', 0):9.1f} "
              f"{r.get('rt_deadline_misses', 0):>7} {r.get('rt_work_max_us', 0):12.1f}")
    print(f"controller: {cs.get('states')} joint states received, {cs.get('stale')} stale periods"
          f" (0 V commanded), exit {cs['exit']}")
    print(f"plant: {ps.get('periods')} periods, {ps.get('cmd_missed')} without a command, "
          f"faults latched {ps.get('faults')} (fault events {ps.get('fault_events')}, "
          f"timeouts {ps.get('timeout')}), exit {ps['exit']}")
    if args.json:
        args.json.write_text(json.dumps({"controller": cs, "plant": ps}, indent=2) + "\n")
    return 0 if cs["exit"] == 0 and ps["exit"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
