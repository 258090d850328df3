"""The plant of the FMUs, stepped from Python: :class:`Plant` holds a plant state and advances it
with librrr's ``rrr_plant_step`` (the call the plant FMU's doStep makes), through the compiled
binding. The same model, integrator settings, inputs and state give the FMU's numbers bit for
bit; :meth:`Plant.snapshot` and :meth:`Plant.restore` carry the whole state (the adaptive step
size's memory included), so a rerun from a snapshot is bit-exact."""

from __future__ import annotations

import ctypes as ct
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import _lib
from ._arrays import FloatArray, as_rows
from ._lib import _ext
from .integrator import PlantIntegrator
from .model import Model

__all__ = ["Plant", "PlantSnapshot", "PlantStats", "Rollout"]

_ZERO = (0.0, 0.0, 0.0)
#: Steps of one C call of :meth:`Plant.rollout` (a few ms): Ctrl-C is handled between two calls.
ROLLOUT_PART = 4096


@dataclass(frozen=True)
class PlantStats:
    """Work of the last :meth:`Plant.step`: internal steps accepted and rejected, and
    right-hand-side evaluations (one = the dynamics and friction at one state)."""

    steps: int
    rejected: int
    evals: int


@dataclass(frozen=True)
class Rollout:
    """The plant's motion along an input table (:meth:`Plant.rollout`): row k is the state
    after step k, at time ``t[k]``."""

    t: FloatArray          # (n,) s
    q: FloatArray          # (n, 3) rad
    qd: FloatArray         # (n, 3) rad/s
    qdd: FloatArray        # (n, 3) rad/s^2, at the end of each step under its input
    stats: PlantStats      # the work of the n steps, summed


@dataclass(frozen=True)
class PlantSnapshot:
    """Everything :meth:`Plant.restore` needs to continue bit-exactly from a moment."""

    state: bytes           # the C rrr_plant_state: q, qd, the step-size controller's memory
    qdd: tuple[float, float, float]
    t: float


def _vector(value: ArrayLike, name: str) -> FloatArray:
    rows, batch = as_rows(value, name)
    if batch:
        raise BadInputError(f"{name} must be one vector (3,), got shape {np.shape(value)}")
    return np.ascontiguousarray(rows[0])


class Plant:
    """Voltages in, joint motion out: the motor mapping (eq 8), friction (eq 9) and rigid-body
    dynamics (eq 7) of ``model``, integrated over each :meth:`step` with the input held.

    Starts at (``q0``, ``qd0``) at time ``t0`` with ``qdd`` under u = 0 (the FMU's start input)
    and no step-size history, as the plant FMU after its initialization.
    """

    def __init__(self, model: Model, q0: ArrayLike = _ZERO, qd0: ArrayLike = _ZERO,
                 integrator: PlantIntegrator | None = None, t0: float = 0.0) -> None:
        if not isinstance(model, Model):
            raise BadInputError(f"model must be a Model, got {type(model).__name__}")
        integrator = integrator if integrator is not None else PlantIntegrator()
        if not isinstance(integrator, PlantIntegrator):
            raise BadInputError(f"integrator must be a PlantIntegrator, got "
                                f"{type(integrator).__name__}")
        if not np.isfinite(t0):
            raise BadInputError(f"t0 must be finite, got {t0!r}")
        self._model = model
        self._k = model._k
        self._integrator = integrator
        self._packed = integrator.packed
        self._state = _lib.RawPlantState()
        q, qd = _vector(q0, "q0"), _vector(qd0, "qd0")
        _ext.plant_state_init(q, qd, self._state)
        self._stats = _lib.RawPlantStats()
        self._qdd = self._k.plant_accel(self._state, _ZERO)
        self._t = float(t0)

    def step(self, u: ArrayLike, h: float) -> FloatArray:
        """Advance by ``h`` seconds under the input voltage ``u`` (3,) V (saturated at the
        model's u_max), and return qdd at the end. A refused step (bad input, a state the
        integrator cannot continue) raises and leaves the plant as it was."""
        qdd = self._k.plant_step(self._packed, u, h, self._state, self._stats)
        self._qdd = qdd
        self._t += h
        return qdd

    def rollout(self, u: ArrayLike, h: float) -> Rollout:
        """Open loop in one call: step k of ``h`` seconds under the input row ``u[k]`` (an
        (n, 3) table of voltages, V), for every row, in C (``rrr_plant_rollout``): the same
        numbers as n calls of :meth:`step`, bit for bit, without a Python call per step. The
        plant ends after the last row. A row the integrator refuses (non-finite, a state it
        cannot continue) raises, naming the row; the plant is then left after the row before
        it, as that many :meth:`step` calls would have left it."""
        rows, batch = as_rows(u, "u")
        if not batch:
            raise BadInputError(f"u must be a table of shape (n, 3), got shape {np.shape(u)}")
        if not isinstance(h, (int, float)) or isinstance(h, bool):
            raise BadInputError(f"h must be a number, got {type(h).__name__}")
        h = float(h)
        n = rows.shape[0]
        q, qd, qdd = (np.empty((n, 3)) for _ in range(3))
        times = np.cumsum(np.concatenate(([self._t], np.full(n, h))))[1:]  # as t += h does
        part, total = _lib.RawPlantStats(), [0, 0, 0]
        state = _lib.RawPlantState.from_buffer_copy(self._state)  # self's until a part is done
        k = 0
        while k < n:
            end = k + min(ROLLOUT_PART, n - k)
            status, done = self._k.plant_rollout(self._packed, rows[k:end], h, state, q[k:end],
                                                 qd[k:end], qdd[k:end], part)
            total = [total[0] + part.steps, total[1] + part.rejected, total[2] + part.evals]
            k += done
            self._commit(state, qdd, times, k, total)
            if status != 0:
                _lib.raise_for("rrr_plant_rollout", status,
                               f"at row {k} (t = {self._t:.6f} s to {self._t + h:.6f} s), "
                               f"u = {rows[k].tolist()}, h = {h!r}, q = {self.q.tolist()}, "
                               f"qd = {self.qd.tolist()}")
        return Rollout(times, q, qd, qdd, self.stats)

    def _commit(self, state: _lib.RawPlantState, qdd: FloatArray, times: FloatArray, k: int,
                total: list[int]) -> None:
        """The plant after the first k rows of a rollout."""
        self._state = _lib.RawPlantState.from_buffer_copy(state)
        self._stats = _lib.RawPlantStats(*total)
        if k > 0:
            self._qdd = qdd[k - 1].copy()
            self._t = float(times[k - 1])

    def accel(self, u: ArrayLike) -> FloatArray:
        """qdd of the present state under the input voltage ``u`` (``rrr_plant_accel``)."""
        return self._k.plant_accel(self._state, u)

    @property
    def q(self) -> FloatArray:
        """Joint positions, rad (unwrapped)."""
        return np.array(self._state.q[:])

    @property
    def qd(self) -> FloatArray:
        """Joint velocities, rad/s."""
        return np.array(self._state.qd[:])

    @property
    def qdd(self) -> FloatArray:
        """Joint accelerations at the end of the last step (at the start: under u = 0)."""
        return self._qdd.copy()

    @property
    def t(self) -> float:
        """Time, s: t0 plus the steps taken."""
        return self._t

    @property
    def tip(self) -> FloatArray:
        """Tip position, m (the plant FMU's ``tip.x``, ``tip.y``, ``tip.z``)."""
        return self._model.fk(self.q)[0]

    @property
    def stats(self) -> PlantStats:
        """The work of the last step, or of the last rollout's steps summed (zeros before the
        first)."""
        s = self._stats
        return PlantStats(int(s.steps), int(s.rejected), int(s.evals))

    @property
    def model(self) -> Model:
        return self._model

    @property
    def integrator(self) -> PlantIntegrator:
        return self._integrator

    def snapshot(self) -> PlantSnapshot:
        """The whole state, to :meth:`restore` later (on this plant or another one with the
        same model and integrator)."""
        q = self._qdd
        return PlantSnapshot(bytes(self._state), (float(q[0]), float(q[1]), float(q[2])),
                             self._t)

    def restore(self, snapshot: PlantSnapshot) -> None:
        """Continue from ``snapshot``: the following steps repeat those after it bit for bit."""
        if not isinstance(snapshot, PlantSnapshot) or len(snapshot.state) != ct.sizeof(
                _lib.RawPlantState):
            raise BadInputError("restore needs a PlantSnapshot of Plant.snapshot()")
        state = _lib.RawPlantState.from_buffer_copy(snapshot.state)
        values = [*state.q, *state.qd, state.h_guess, state.err_prev, *snapshot.qdd, snapshot.t]
        if not all(np.isfinite(values)) or state.h_guess < 0 or state.err_prev < 0:
            raise BadInputError("the snapshot holds non-finite or negative values")
        self._state = state
        self._qdd = np.array(snapshot.qdd)
        self._t = float(snapshot.t)

    def __repr__(self) -> str:
        return (f"Plant(t={self._t}, q={self.q.tolist()}, qd={self.qd.tolist()}, "
                f"integrator={self._integrator})")
