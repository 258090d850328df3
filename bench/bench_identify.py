"""Benchmark: the 16 base parameters from 10 s of 1 kHz data (issue 4: under a second).

Simulates one 10 s excitation period on the plant FMU with encoder quantisation and noise,
writes it as CSV, then times reading + filtering + regressor + LS/WLS with standard deviations.

    RRR_LIBRARY=... RRR_FMU_DIR=... PYTHONPATH=python python bench/bench_identify.py
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from rrr_robot.core.model import Model
from rrr_robot.identify import experiments as ex
from rrr_robot.identify.base_params import estimate_base_params
from rrr_robot.identify.excitation import design_excitation
from rrr_robot.identify.logs import read_log


def main() -> int:
    model = Model.default()
    traj, _ = design_excitation(model, np.array(ex.SweepDesign().pose), maxiter=30)
    lg = ex.excitation_experiment(model, traj, periods=1, sensors=ex.NOISY)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "excitation.csv"
        lg.to_csv(path)
        times, est_times = [], []
        for _ in range(5):
            t0 = time.perf_counter()
            log = read_log(path)
            t1 = time.perf_counter()
            res = estimate_base_params(log, model)
            t2 = time.perf_counter()
            times.append(t2 - t0)
            est_times.append(t2 - t1)
    err = (res.wls.p - model.p) / res.wls.std
    print(f"{len(lg)} samples ({lg.t[-1] - lg.t[0]:.1f} s at {1 / lg.dt:.0f} Hz), cond(W) "
          f"{res.cond:.1f}, {res.rows} regression rows")
    est, total = statistics.median(est_times), statistics.median(times)
    print(f"estimate (filter + regressor + LS + WLS + std): median {est:.3f} s; with reading "
          f"the CSV: median {total:.3f} s (5 runs)")
    print(f"true p inside the 95 % interval for {int(np.sum(np.abs(err) <= 1.96))}/16 parameters")
    return 0 if statistics.median(times) < 1.0 else 1


if __name__ == "__main__":
    sys.exit(main())
