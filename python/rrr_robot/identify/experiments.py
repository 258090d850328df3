"""Simulated identification experiments on the plant FMU, with encoder quantisation and noise.

The plant FMU is driven directly (FmuSlave) by a PD position controller written here, at the
communication step of the reference (``step``: the robot file's [control] sample_time, default
1 ms). One experiment is bounded to MAX_EXPERIMENT_SAMPLES samples (checked before it runs,
:func:`check_experiments`). Sensor effects are applied in Python because the
plant FMU outputs ideal signals:

- encoder: q is rounded to ``counts_per_rev`` counts per revolution, then white noise
  ``sigma_q`` is added; the log records this measured q (and, for ideal sensors, the plant's
  exact qd and qdd as optional columns);
- the controller's velocity is the plant's qd plus white noise ``sigma_qd`` (a tachometer);
- an unmeasured white voltage disturbance ``sigma_u`` is added to the applied voltage (inverter
  noise); the log records the commanded voltage.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..core import fmu_vars as fv
from ..core._arrays import FloatArray
from ..core.model import Model
from ..core.param_names import model_fmu_values
from ..core.robot import DEFAULT_SAMPLE_TIME
from ..errors import BadInputError
from ..sim.cosim import initial_state_values
from ..sim.fmu_slave import pooled_slave
from ..sim.fmus import fmu_path
from .excitation import FourierTrajectory
from .logs import Log

log = logging.getLogger(__name__)

J = fv.JOINTS
#: Samples of one simulated experiment: 1,000,000 (1000 s at 1 ms; the default friction sweep has
#: about 330,000, one 10 s excitation period 10,000). The loop steps the FMU from Python.
MAX_EXPERIMENT_SAMPLES = 1_000_000
#: Period of the excitation (s), design_excitation's default.
EXCITATION_PERIOD = 10.0
#: Samples between two progress reports of an experiment.
PROGRESS_SAMPLES = 1000
#: ``progress(done, total)``: samples simulated of an experiment.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Sensors:
    """Sensor and actuator imperfections of a simulated experiment (see module docstring)."""

    counts_per_rev: int = 0        # 0: no quantisation
    sigma_q: float = 0.0           # rad
    sigma_qd: float = 0.0          # rad/s, controller's velocity only
    sigma_u: float = 0.0           # V, applied voltage disturbance (not in the log)
    seed: int = 0

    @property
    def ideal(self) -> bool:
        return self.counts_per_rev == 0 and self.sigma_q == 0 and self.sigma_u == 0


#: The stated noisy setting: 16384 counts/rev (4096-line quadrature encoder, 0.38 mrad),
#: 0.1 mrad position noise, 5 mrad/s tachometer noise, 20 mV inverter noise.
NOISY = Sensors(counts_per_rev=16384, sigma_q=1e-4, sigma_qd=5e-3, sigma_u=0.02, seed=1)
IDEAL = Sensors()


@dataclass(frozen=True)
class Gains:
    kp: tuple[float, float, float] = (40.0, 100.0, 40.0)    # V/rad
    kd: tuple[float, float, float] = (1.5, 4.0, 1.5)        # V s/rad


def simulate(model: Model, t: FloatArray, q_ref: FloatArray, qd_ref: FloatArray,
             sensors: Sensors = IDEAL, gains: Gains = Gains(),
             joint: np.ndarray | None = None, progress: Progress | None = None) -> Log:
    """Track (q_ref, qd_ref) with PD on the plant FMU (true parameters ``model``); the log.
    ``progress(done, n)`` every :data:`PROGRESS_SAMPLES` samples and at the end."""
    _check_samples(t.shape[0], "the experiment", float(t[1] - t[0]) if t.shape[0] > 1 else 0.0)
    n, h = t.shape[0], float(t[1] - t[0])
    rng = np.random.default_rng(sensors.seed)
    noise_q = sensors.sigma_q * rng.standard_normal((n, 3))
    noise_qd = sensors.sigma_qd * rng.standard_normal((n, 3))
    noise_u = sensors.sigma_u * rng.standard_normal((n, 3))
    quantum = 2 * np.pi / sensors.counts_per_rev if sensors.counts_per_rev else 0.0
    kp, kd = np.asarray(gains.kp), np.asarray(gains.kd)
    values = model_fmu_values(model) | initial_state_values(q_ref[0], qd_ref[0])
    rec = np.empty((n, 12))
    with pooled_slave(fmu_path("plant"), "identification plant") as plant:
        plant.initialize(float(t[0]), values)
        state = plant.real_block(fv.names("plant", "q") + fv.names("plant", "qd"))
        acc = plant.real_block(fv.names("plant", "qdd"))
        inp = plant.real_block(fv.names("plant", "u"))
        for k in range(n):
            plant.get_block(state)
            q_true, qd_true = state.values[:3], state.values[3:]
            q_meas = (np.round(q_true / quantum) * quantum if quantum else q_true) + noise_q[k]
            u = kp * (q_ref[k] - q_meas) + kd * (qd_ref[k] - qd_true - noise_qd[k])
            inp.values[:] = u + noise_u[k]
            plant.set_block(inp)
            plant.get_block(acc)
            rec[k] = np.concatenate([q_meas, u, qd_true, acc.values])
            if k < n - 1:
                plant.do_step(h)
            if progress is not None and ((k + 1) % PROGRESS_SAMPLES == 0 or k == n - 1):
                progress(k + 1, n)
    ideal = sensors.ideal
    return Log(t, rec[:, :3], rec[:, 3:6], rec[:, 6:9] if ideal else None,
               rec[:, 9:12] if ideal else None, joint, "simulated experiment")


def _check_samples(n: float, what: str, step: float, hint: str = "") -> None:
    if n < 2:
        raise BadInputError(f"{what} would have {n:.0f} samples: it needs at least 2")
    if n > MAX_EXPERIMENT_SAMPLES:
        raise BadInputError(f"{what} would have {n:,.0f} samples at the sample time {step:g} s; "
                            f"one experiment is bounded to {MAX_EXPERIMENT_SAMPLES:,} samples "
                            f"(1000 s at 1 ms){hint}")


def excitation_samples(periods: int, step: float = DEFAULT_SAMPLE_TIME,
                       period: float = EXCITATION_PERIOD) -> int:
    """Samples of the excitation experiment; BadInputError beyond MAX_EXPERIMENT_SAMPLES."""
    if not isinstance(periods, int) or isinstance(periods, bool) or periods < 1:
        raise BadInputError(f"the excitation runs for a whole number of periods >= 1, got "
                            f"{periods!r}")
    if not (np.isfinite(step) and step > 0 and np.isfinite(period) and period > 0):
        raise BadInputError(f"sample time {step!r} s and period {period!r} s must be > 0")
    n = periods * period / step
    _check_samples(n, f"the excitation experiment ({periods} period(s) of {period:g} s)", step,
                   ": use fewer periods or a longer sample time")
    return round(n)


def friction_samples(design: SweepDesign | None = None, step: float = DEFAULT_SAMPLE_TIME) -> int:
    """Samples of the friction sweep; BadInputError beyond MAX_EXPERIMENT_SAMPLES."""
    d = SweepDesign() if design is None else design
    if not (np.isfinite(step) and step > 0):
        raise BadInputError(f"sample time {step!r} s must be > 0")
    fixed = (d.hold + 2 * d.ramp + 2 * d.settle) / step
    n = d.hold / step + 2 * len(J) * sum(fixed + min(d.cruise, 2 * np.pi / abs(v)) / step
                                         for v in d.speeds)
    _check_samples(n, "the friction sweep", step, ": use a longer sample time")
    return round(n)


def check_experiments(periods: int, step: float = DEFAULT_SAMPLE_TIME) -> None:
    """Both experiments of ``rrr identify-experiment`` within the bounds (before anything runs)."""
    friction_samples(SweepDesign(), step)
    excitation_samples(periods, step)


def excitation_experiment(model: Model, traj: FourierTrajectory, periods: int = 1,
                          step: float = DEFAULT_SAMPLE_TIME, sensors: Sensors = IDEAL,
                          gains: Gains = Gains(), progress: Progress | None = None) -> Log:
    """Run the periodic excitation for whole periods; the plant starts on the reference."""
    excitation_samples(periods, step, traj.period)
    t = np.arange(round(periods * traj.period / step), dtype=np.float64) * step
    q, qd, _ = traj.evaluate(t)
    return simulate(model, t, q, qd, sensors, gains, progress=progress)


@dataclass(frozen=True)
class SweepDesign:
    """Constant-velocity friction sweep (see :func:`friction_reference`)."""

    speeds: Sequence[float] = tuple(np.geomspace(0.002, 4.0, 14))   # rad/s, both directions
    pose: tuple[float, float, float] = (0.0, 0.3, 1.0)             # rad, locked joints
    cruise: float = 2.0           # s of constant velocity per pass (capped at one revolution)
    ramp: float = 0.3             # s, smooth acceleration to the speed
    settle: float = 0.5           # s at speed before the recorded cruise
    hold: float = 0.3             # s at rest between passes


def _smooth_ramp(n: int, v0: float, v1: float) -> FloatArray:
    s = np.linspace(0.0, 1.0, n, endpoint=False)
    return v0 + (v1 - v0) * s * s * (3 - 2 * s)


def _pass(v: float, d: SweepDesign, step: float) -> tuple[FloatArray, FloatArray]:
    """Velocity profile and tag (1 during the recorded cruise) of one pass at velocity v: hold,
    ramp, settle, cruise, settle, ramp; the settles before and after make a reversed pass
    cruise over exactly the same arc."""
    n_ramp, n_settle, n_hold = (round(x / step) for x in (d.ramp, d.settle, d.hold))
    n_cruise = round(min(d.cruise, 2 * np.pi / abs(v)) / step)
    prof = [np.zeros(n_hold), _smooth_ramp(n_ramp, 0, v), np.full(2 * n_settle + n_cruise, v),
            _smooth_ramp(n_ramp, v, 0)]
    tag = [np.zeros(n_hold + n_ramp + n_settle), np.ones(n_cruise), np.zeros(n_settle + n_ramp)]
    return np.concatenate(prof), np.concatenate(tag)


def friction_reference(design: SweepDesign = SweepDesign(), step: float = DEFAULT_SAMPLE_TIME,
                       ) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
    """One continuous reference: for joint 1, 2, 3 in turn, at each speed a forward pass and a
    backward pass over the same arc, the other joints held at ``pose``. The backward pass
    retraces the forward one (settle and ramp distances are symmetric), so gravity, which
    depends on position only, is the same on both cruises and separates from the odd friction.
    Returns t, q_ref, qd_ref and the joint tag (0 outside the recorded cruises)."""
    friction_samples(design, step)
    qd_parts, tags = [], []
    for i in J:
        for v in design.speeds:
            for sign in (1.0, -1.0):
                prof, tag = _pass(sign * v, design, step)
                qd_j = np.zeros((prof.size, 3))
                qd_j[:, i - 1] = prof
                qd_parts.append(qd_j)
                tags.append(tag.astype(int) * i)
    qd_parts.append(np.zeros((round(design.hold / step), 3)))
    tags.append(np.zeros(qd_parts[-1].shape[0], dtype=int))
    qd = np.concatenate(qd_parts)
    t = np.arange(qd.shape[0], dtype=np.float64) * step
    from scipy.integrate import cumulative_trapezoid  # slow to import: when a sweep is made

    q = np.asarray(design.pose) + cumulative_trapezoid(qd, t, axis=0, initial=0.0)
    return t, q, qd, np.concatenate(tags)


#: stiffer position loops for the friction sweep: the locked joints must stay still
LOCKING_GAINS = Gains(kp=(200.0, 400.0, 200.0), kd=(6.0, 12.0, 3.0))


def friction_experiment(model: Model, design: SweepDesign = SweepDesign(),
                        step: float = DEFAULT_SAMPLE_TIME,
                        sensors: Sensors = IDEAL, gains: Gains = LOCKING_GAINS,
                        progress: Progress | None = None) -> Log:
    """Simulate the friction sweep; the log has the ``joint`` column."""
    t, q, qd, tag = friction_reference(design, step)
    log.info("friction sweep: %.0f s simulated", t[-1])
    return simulate(model, t, q, qd, sensors, gains, joint=tag, progress=progress)
