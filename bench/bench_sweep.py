"""Throughput of ``rrr sweep`` on Dask: runs per second on one and on two local worker
processes, the scheduling overhead per run against the same runs made directly in one process,
and the wall time of a 1,000-run sweep with the native engine and with the FMUs.

1. Two local clusters (``distributed.LocalCluster``, one worker process of one thread, and two)
   are started once (their start-up time is printed) and warmed up with one block each. Then
   blocks of ``--runs`` runs of the same random spec alternate between them (1, 2, 2, 1, ...),
   each block submitted in batches and recorded as the sweep records them (one Parquet part
   per batch): runs per second of each (and per core: a worker is one process of one
   thread), and their ratio per pair of blocks, for blocks of 10, 100 and 1,000 runs
   (``--sizes``).
2. Overhead: blocks of the same runs alternate between the one-worker cluster (as above) and a
   plain loop over ``rrr_robot.sweep.runs.run_one`` in a process of its own (the reference: a
   direct run, no Dask, no recording); overhead = time through the cluster / direct time - 1,
   per pair, in wall time and in CPU time (this process, where a local cluster's scheduler and
   nannies run, plus the worker processes, against the CPU time of the direct loop: on a
   loaded machine the CPU time is the steadier measure of the work added).
3. ``rrr sweep SPEC --out DIR --engine native|fmpy -q`` (default cluster: one worker per core)
   on a 1,000-run spec, as processes: the command's wall time, and the runs' wall time and the
   cluster's start-up from its summary.json.

Ratios are min / median / max over ``--repeats`` pairs of blocks (the machine is shared).

Run:  python bench/bench_sweep.py [--engine fmpy] [--sizes 10,100,1000] [--runs 200]
      [--repeats 5] [--big 1000] [--skip-big] [--quick]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from _timing import add_quick, apply_quick, mmm
from rrr_robot.sweep.execution import batch_size, batches, dask_client, execute, worker_threads
from rrr_robot.sweep.job import make_plan
from rrr_robot.sweep.results import schema, write_part
from rrr_robot.sweep.runs import run_one
from rrr_robot.sweep.sampling import design
from rrr_robot.sweep.spec import read_spec

SPEC = """[sweep]
base = "mismatch"
samples = {samples}
seed = 11
[vary]
"mismatch.p_rel" = {{ uniform = [-0.1, 0.1] }}
"mismatch.kt_rel" = {{ normal = [0.0, 0.05] }}
"mismatch.f_rel" = {{ normal = [0.0, 0.2], per_element = true }}
"gains.kp" = {{ values = [[20.0, 50.0, 20.0], [40.0, 100.0, 40.0]] }}
"""


def cpu_seconds(client: object) -> float:
    """CPU time of this process (the client; a local cluster's scheduler and nannies are
    threads of it) and of every worker process."""
    workers = client.run(time.process_time)  # type: ignore[attr-defined]
    return time.process_time() + sum(workers.values())


def through_cluster(client: object, plan: object, inputs: list, folder: Path,
                    arrow_schema: object, engine: str) -> tuple[float, float]:
    """Wall and CPU seconds to run ``inputs`` on the cluster and record them as the sweep
    does."""
    size = batch_size(len(inputs), worker_threads(client), engine)
    cpu = cpu_seconds(client)
    start = time.perf_counter()
    lost = execute(client, plan, batches(inputs, size),
                   lambda rows: write_part(folder, rows, arrow_schema))
    elapsed = time.perf_counter() - start
    cpu = cpu_seconds(client) - cpu
    assert not lost, lost
    for p in folder.glob("part-*.parquet"):  # the next block writes the same part names
        p.unlink()
    return elapsed, cpu


def direct_loop(plan: object, inputs: list) -> tuple[float, float]:
    """Wall and CPU seconds of the runs made one after the other in this process."""
    cpu = time.process_time()
    start = time.perf_counter()
    for inp in inputs:
        run_one(plan, inp)  # type: ignore[arg-type]
    return time.perf_counter() - start, time.process_time() - cpu


def direct(pool: ProcessPoolExecutor, plan: object, inputs: list) -> tuple[float, float]:
    """The direct runs, in a plain process of their own (not this one, whose threads serve
    the local clusters' schedulers and nannies)."""
    return pool.submit(direct_loop, plan, inputs).result()


def rates(args: argparse.Namespace, case: tuple, one: object) -> None:
    """Runs per second on one and on two workers (and per core: per worker process of one
    thread), alternating blocks, for each block size of ``--sizes``."""
    plan, inputs, folder, arrow_schema = case
    t0 = time.perf_counter()
    with dask_client(2) as two:
        print(f"local cluster of 2 workers: ready (run module imported) in "
              f"{time.perf_counter() - t0:.2f} s")
        print(f"\nengine {args.engine}, {args.repeats} pairs of blocks per size; "
              "min / median / max\n")
        print("| runs per block | runs/s, 1 worker (= per core) | runs/s, 2 workers | "
              "runs/s per core, 2 workers | speed-up, 2 / 1 worker (per pair) |")
        print("|---:|---|---|---|---|")
        clusters = {1: one, 2: two}
        through_cluster(two, plan, inputs[:8], folder, arrow_schema, args.engine)  # warm-up
        for size in args.sizes:
            rate: dict[int, list[float]] = {1: [], 2: []}
            ratio = []
            for r in range(args.repeats):
                order = (1, 2) if r % 2 == 0 else (2, 1)
                t = {w: through_cluster(clusters[w], plan, inputs[:size], folder,
                                        arrow_schema, args.engine)[0] for w in order}
                for w in order:
                    rate[w].append(size / t[w])
                ratio.append(t[1] / t[2])
            print(f"| {size} | {mmm(rate[1])} | {mmm(rate[2])} | "
                  f"{mmm([x / 2 for x in rate[2]])} | {mmm(ratio)} |")
    print(f"\noverhead: {args.runs} runs per block, 1 worker against direct runs\n")
    print("| measure | value |\n|---|---|")


def overheads(args: argparse.Namespace, case: tuple, one: object) -> None:
    """The one-worker cluster against direct runs in a plain process, alternating blocks (only
    this cluster is running: its scheduler and nanny are the only ones in this process)."""
    plan, inputs, folder, arrow_schema = case
    inputs = inputs[:args.runs]
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        direct(pool, plan, inputs[:2])  # warm-up
        overhead, cpu_overhead, per_run_direct = [], [], []
        for r in range(args.repeats):
            pair = ("direct", "cluster") if r % 2 == 0 else ("cluster", "direct")
            times = {}
            for what in pair:
                times[what] = (direct(pool, plan, inputs) if what == "direct" else
                               through_cluster(one, plan, inputs, folder, arrow_schema,
                                               args.engine))
            per_run_direct.append(times["direct"][0] / len(inputs))
            overhead.append(times["cluster"][0] / times["direct"][0] - 1.0)
            cpu_overhead.append(times["cluster"][1] / times["direct"][1] - 1.0)
    print(f"| direct run (a plain process), ms per run | "
          f"{mmm([1e3 * x for x in per_run_direct])} |")
    print(f"| scheduling overhead per run, 1 worker against direct, wall time (goal <= 10 %) | "
          f"{mmm([100 * x for x in overhead], '.1f')} % |")
    print(f"| the same in CPU time (client, scheduler, nanny and worker against the direct loop) | "
          f"{mmm([100 * x for x in cpu_overhead], '.1f')} % |")


def blocks(args: argparse.Namespace, work: Path) -> None:
    spec_path = work / "bench.toml"
    spec_path.write_text(SPEC.format(samples=max(args.runs, *args.sizes)))
    spec = read_spec(spec_path)
    case = (make_plan(spec, args.engine), design(spec), work / "results.parquet",
            schema(spec.vary))
    t0 = time.perf_counter()
    with dask_client(1) as one:
        print(f"local cluster of 1 worker: ready (run module imported) in "
              f"{time.perf_counter() - t0:.2f} s")
        through_cluster(one, case[0], case[1][:8], case[2], case[3], args.engine)  # warm-up
        rates(args, case, one)
        overheads(args, case, one)


def big(args: argparse.Namespace, work: Path) -> None:
    spec_path = work / "big.toml"
    spec_path.write_text(SPEC.format(samples=args.big))
    print(f"\n`rrr sweep` of {args.big} runs, default local cluster ({os.cpu_count()} workers)\n")
    print("| engine | command wall time (s) | runs (s) | cluster start (s) | runs/s | "
          "runs/s per core | statuses |")
    print("|---|---:|---:|---:|---:|---:|---|")
    for engine in args.big_engine or ("native", "fmpy"):
        out = work / f"big-{engine}"
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "rrr_robot", "sweep", str(spec_path), "--out",
                        str(out), "--engine", engine, "-q"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - start
        s = json.loads((out / "summary.json").read_text())
        inv = s["this_invocation"]
        statuses = ", ".join(f"{k} {v}" for k, v in s["status"].items() if v)
        print(f"| {engine} | {wall:.1f} | {inv['wall_time']:.1f} | {inv['cluster_start']:.1f} "
              f"| {inv['runs_per_second']:.1f} "
              f"| {inv['runs_per_second'] / inv['worker_threads']:.1f} "
              f"| {statuses} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=200,
                    help="runs per block of the overhead (default 200)")
    ap.add_argument("--sizes", type=lambda s: [int(x) for x in s.split(",")],
                    default=[10, 100, 1000],
                    help="runs per block of the 1 / 2 worker rates (default 10,100,1000)")
    ap.add_argument("--repeats", type=int, default=5, help="pairs of blocks (default 5)")
    ap.add_argument("--engine", choices=("native", "fmpy"), default="native",
                    help="engine of the blocks (default native)")
    ap.add_argument("--big", type=int, default=1000, help="runs of the big sweep (1000)")
    ap.add_argument("--skip-big", action="store_true", help="leave out the big sweeps")
    ap.add_argument("--big-engine", action="append", choices=("native", "fmpy"),
                    help="the engines of the big sweeps (repeatable; default both)")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(),
                       {"runs": 4, "sizes": [4, 8], "repeats": 1, "big": 8,
                        "big_engine": ["native"]})
    import dask
    import distributed

    cpu = platform.processor() or platform.machine()
    print(f"Sweep benchmark, {time.strftime('%Y-%m-%dT%H:%M:%S')}, {cpu}, {os.cpu_count()} CPUs, "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"Python {platform.python_version()}, dask {dask.__version__}, distributed "
          f"{distributed.__version__}")
    with tempfile.TemporaryDirectory() as tmp:
        blocks(args, Path(tmp))
        if not args.skip_big:
            big(args, Path(tmp))
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
