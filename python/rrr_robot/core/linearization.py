"""Linearisation of the plant and of the closed loop with the computed-torque controller, from
librrr's exact partial derivatives (``rrr_plant_jacobian``, ``rrr_ctc_jacobian``; the same
numbers the FMUs' directional derivatives give): no finite differences.

The plant is the ODE of the plant FMU, x = (q, qd), dx/dt = (qd, qdd(q, qd, u)); the closed
loop feeds it u = ctc(q_ref, qd_ref, qdd_ref, q, qd) (eq 15, the controller FMU with lead = 0),
so its inputs are the reference. Outputs: q, qd and the tip position (and, closed loop, the
applied voltage u).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import fmu_vars as fv
from ._arrays import FloatArray, as_rows
from .control import CtcGains
from .model import Model

if TYPE_CHECKING:
    from scipy.signal import StateSpace as ScipyStateSpace

__all__ = ["LinearSystem", "linearize"]


def _joint_names(base: str) -> tuple[str, ...]:
    return tuple(fv.joint_names(base))


STATES = (*fv.names("plant", "q"), *fv.names("plant", "qd"))
TIP = tuple(fv.names("plant", "tip"))


@dataclass(frozen=True)
class LinearSystem:
    """d(dx)/dt = A dx + B du, dy = C dx + D du about an operating point (x0, u0): the first
    order of the model there (the FMUs' variable names in ``states``, ``inputs``, ``outputs``).

    Along a moving trajectory ``xdot0`` (the derivative at the point) is not zero: the matrices
    are then the local, time-varying linearisation, still exact at that instant.
    """

    A: FloatArray                   #: (6, 6), d(qd, qdd) / d(q, qd)
    B: FloatArray                   #: (6, m), d(qd, qdd) / d(inputs)
    C: FloatArray                   #: (p, 6)
    D: FloatArray                   #: (p, m)
    x0: FloatArray                  #: (6,) the state (q, qd) linearised about
    u0: FloatArray                  #: (m,) the inputs there
    xdot0: FloatArray               #: (6,) dx/dt there (0 at an equilibrium)
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    def poles(self) -> np.ndarray:
        """Eigenvalues of A, 1/s (complex, sorted by real part then imaginary part)."""
        return np.sort_complex(np.linalg.eigvals(self.A))

    def to_scipy(self) -> ScipyStateSpace:
        """The same matrices as a ``scipy.signal.StateSpace`` (continuous time)."""
        from scipy.signal import StateSpace

        return StateSpace(self.A, self.B, self.C, self.D)


def _vec(value: ArrayLike | None, name: str, default: FloatArray) -> FloatArray:
    if value is None:
        return default.copy()
    rows, batch = as_rows(value, name)
    if batch:
        raise BadInputError(f"{name} must be one vector (3,): linearize one point at a time, "
                            f"got shape {np.shape(value)}")
    return np.array(rows[0])


def _plant_blocks(model: Model, q: FloatArray, qd: FloatArray, u: FloatArray
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """qdd and the (6, 6) A and (6, 3) B of the plant at (q, qd, u)."""
    qdd, jac = model.plant_jacobian(q, qd, u)
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    A[3:, :] = jac[:, :6]
    B = np.zeros((6, 3))
    B[3:, :] = jac[:, 6:]
    return qdd, A, B


def _outputs_c(model: Model, q: FloatArray) -> FloatArray:
    """C of (q, qd, tip): the identity and the tip's kinematic Jacobian."""
    C = np.zeros((9, 6))
    C[:6, :] = np.eye(6)
    C[6:, :3] = model.jacobian(q)
    return C


def linearize(
    model: Model,
    q: ArrayLike,
    qd: ArrayLike,
    u: ArrayLike | None = None,
    *,
    gains: CtcGains | None = None,
    q_ref: ArrayLike | None = None,
    qd_ref: ArrayLike | None = None,
    qdd_ref: ArrayLike | None = None,
) -> LinearSystem:
    """The linearisation of the plant (``gains`` None) or of the closed loop with the
    computed-torque controller (``gains`` given) at the state (``q``, ``qd``), rad and rad/s.

    Plant: inputs u (V), A (6, 6), B (6, 3); ``u`` defaults to the voltage that holds the state
    without acceleration (the model's nominal voltage for qdd = 0, saturated like every input).
    Closed loop: inputs (q_ref, qd_ref, qdd_ref), B (6, 9), outputs also u (V); the reference
    defaults to the state itself and qdd_ref = 0, the point the loop rests at; pass u only to
    the plant (the loop computes it). A clamped voltage has no effect on the motion to first
    order: its column of B (plant) or row of du (closed loop) is zero.
    """
    if not isinstance(model, Model):
        raise BadInputError(f"model must be a Model, got {type(model).__name__}")
    zero = np.zeros(3)
    qv, qdv = _vec(q, "q", zero), _vec(qd, "qd", zero)
    x0 = np.concatenate([qv, qdv])
    if gains is None:
        if q_ref is not None or qd_ref is not None or qdd_ref is not None:
            raise BadInputError("q_ref, qd_ref, qdd_ref belong to the closed loop: pass gains")
        uv = _vec(u, "u", zero) if u is not None else model.nominal_voltage(qv, qdv, zero)
        qdd, A, B = _plant_blocks(model, qv, qdv, uv)
        return LinearSystem(A, B, _outputs_c(model, qv), np.zeros((9, 3)), x0, uv,
                            np.concatenate([qdv, qdd]), STATES, _joint_names("u"),
                            (*STATES, *TIP))
    if not isinstance(gains, CtcGains):
        raise BadInputError(f"gains must be a CtcGains, got {type(gains).__name__}")
    if u is not None:
        raise BadInputError("u is the controller's output in the closed loop: pass either u "
                            "(the plant) or gains (the closed loop)")
    r = [_vec(q_ref, "q_ref", qv), _vec(qd_ref, "qd_ref", qdv), _vec(qdd_ref, "qdd_ref", zero)]
    uv, du, _ = model.ctc_jacobian(gains, r[0], r[1], r[2], qv, qdv)
    qdd, A, B = _plant_blocks(model, qv, qdv, uv)
    du_ref, du_x = du[:, :9], du[:, 9:]
    a_cl = A + B @ du_x
    b_cl = B @ du_ref
    C = np.vstack([_outputs_c(model, qv), du_x])
    D = np.vstack([np.zeros((9, 9)), du_ref])
    return LinearSystem(a_cl, b_cl, C, D, x0, np.concatenate(r), np.concatenate([qdv, qdd]),
                        STATES, (*_joint_names("q_ref"), *_joint_names("qd_ref"),
                                 *_joint_names("qdd_ref")),
                        (*STATES, *TIP, *_joint_names("u")))
