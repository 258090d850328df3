"""Calibrate the default torque constants k_t to the paper's eq 16 (CALIBRATION, not validation).

The paper prints no motor data. Its eq 16 gives the RMS of the feedforward voltage u_n on the
writing task of the real robot: [0.25, 1.98, 0.78] V. With the controller's model equal to the
plant's, u_n depends only on the reference motion: u_n,i = (R p)_i / k_t,i + u_f,i(qd_ref,i)
(eq 10). For each joint this script finds the k_t,i whose RMS u_n,i over the default writing
reference equals the paper's figure (RMS falls monotonically with k_t towards the RMS of the
friction voltage alone), rounds it to two significant digits and prints the values to put in
c_src/rrr/src/rrr_internal.h (RRR_DEFAULT_KT*) and python/rrr_robot/data/default_robot.toml.

Run:  python tools/calibrate_kt.py
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import rrr_robot as rr
from rrr_robot.writing.job import PAPER_RMS_U_N
from rrr_robot.writing.trajectory import make_reference
from scipy.optimize import brentq


def rms_u_n(model: rr.Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    u_n = model.nominal_voltage(q, qd, qdd)
    return np.sqrt(np.mean(u_n**2, axis=0))


def round_sig(x: float, digits: int = 2) -> float:
    return round(x, digits - 1 - math.floor(math.log10(abs(x))))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--digits", type=int, default=2, help="significant digits of k_t")
    args = parser.parse_args()
    model = rr.Model.default()
    ref = make_reference(model)
    tau = model.inverse_dynamics(ref.q, ref.qd, ref.qdd)
    u_f = model.friction(ref.qd)
    before = rms_u_n(model, ref.q, ref.qd, ref.qdd)
    kt = model.kt.copy()
    for i, target in enumerate(PAPER_RMS_U_N):
        floor = float(np.sqrt(np.mean(u_f[:, i] ** 2)))
        if floor >= target:
            raise SystemExit(f"joint {i + 1}: friction alone gives RMS {floor:.3f} V >= {target}")

        def excess(k: float, i: int = i, target: float = target) -> float:
            return float(np.sqrt(np.mean((tau[:, i] / k + u_f[:, i]) ** 2))) - target

        kt[i] = round_sig(brentq(excess, 1e-3, 1e4, xtol=1e-10), args.digits)
    after = rms_u_n(model.with_params(kt=kt), ref.q, ref.qd, ref.qdd)
    print(f"reference: {ref.spec.text!r}, {ref.t[-1]:.2f} s")
    print(f"{'joint':>5} {'k_t before':>11} {'RMS u_n':>8} {'k_t after':>10} {'RMS u_n':>8} "
          f"{'paper':>6} {'off':>6}")
    for i in range(3):
        off = after[i] / PAPER_RMS_U_N[i] - 1.0
        print(f"{i + 1:>5} {model.kt[i]:>11.3g} {before[i]:>8.3f} {kt[i]:>10.3g} {after[i]:>8.3f} "
              f"{PAPER_RMS_U_N[i]:>6.2f} {100 * off:>5.1f}%")
    print("kt = [" + ", ".join(f"{k:g}" for k in kt) + "]")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
