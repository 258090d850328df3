"""The RRR model: parameters plus every closed-form algorithm of librrr, with batch variants.

No model mathematics is done here: each method hands its arguments to the compiled binding
``_ext.Kernels`` (c_src/pyext/rrr_ext.c), which converts them, loops over the rows in C and
raises the package's exceptions.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError, ModelError, one_line
from . import _lib
from ._arrays import FloatArray
from ._lib import _ext
from ._package import DATA_DIR
from .checked import write_toml
from .control import CtcGains

Kernels = _ext.Kernels

DH_KEYS = ("d1", "a2", "a3", "d2", "d3")
SHOULDER = {"front": 0, "back": 1}
ELBOW = {"up": 0, "down": 1}
#: The packaged default robot file (``Model.default()`` reads it).
DEFAULT_ROBOT_TOML = DATA_DIR / "default_robot.toml"


@dataclass(frozen=True)
class Singularity:
    """Distance of a configuration from the singular sets (see rrr_kinematics.h)."""

    stretched: bool
    folded: bool
    shoulder: bool
    elbow_margin: float
    shoulder_margin: float
    det_jacobian: float


def bps_from_inertia(
    dh: Mapping[str, float],
    masses: ArrayLike,
    coms: ArrayLike,
    inertias_com: ArrayLike,
    rotor_inertia: ArrayLike,
) -> FloatArray:
    """Base parameters p (eq 12) from link masses (3,), COMs in DH frame i (3, 3), inertia
    tensors about the COM (3, 3, 3) and rotor inertias (3,); ``dh``: some of the DH lengths
    d1, a2, a3, d2, d3 (m). BadInputError names the argument that is not finite numbers of its
    shape, or a key of ``dh`` that is no DH length."""
    shapes = {"masses": (3,), "coms": (3, 3), "inertias_com": (3, 3, 3), "rotor_inertia": (3,)}
    m_arr, c_arr, i_arr, j_arr = (
        finite_array(value, name, shapes[name])
        for name, value in zip(shapes, (masses, coms, inertias_com, rotor_inertia),
                               strict=True))
    if not isinstance(dh, Mapping):
        raise BadInputError(f"dh must be a mapping of DH lengths ({', '.join(DH_KEYS)}), got "
                            f"{type(dh).__name__}")
    unknown = [str(k) for k in dh if k not in DH_KEYS]
    if unknown:
        raise BadInputError(f"dh[{unknown[0]!r}] is no DH length (keys: {', '.join(DH_KEYS)})")
    raw = _lib.RawModel()
    for k in DH_KEYS:
        if k in dh:
            setattr(raw, k, finite_scalar(dh[k], f"dh[{k!r}]"))
    inertial = _lib.RawInertial()
    for i in range(3):
        link = inertial.link[i]
        link.mass = float(m_arr[i])
        for r in range(3):
            link.com[r] = float(c_arr[i, r])
            for c in range(3):
                link.inertia_com[r][c] = float(i_arr[i, r, c])
        inertial.rotor_inertia[i] = float(j_arr[i])
    p = np.zeros(_lib.NP)
    _ext.bps_from_inertia(raw, inertial, p)
    return p


class Model:
    """Parameters of the RRR arm and its closed-form algorithms (all evaluated in C).

    Build with :meth:`default`, or read a robot file with
    :func:`~rrr_robot.core.robot.read_robot_file` (its ``model``). Array arguments are
    (3,) vectors or (n, 3) batches; results follow the shape of the input.
    """

    def __init__(self, raw: _lib.RawModel, *, validate: bool = True) -> None:
        self._raw = raw
        self._k = Kernels(raw)  # reads raw in place
        if validate:
            self.validate()

    # ---- construction -------------------------------------------------------------------
    @classmethod
    def default(cls) -> Model:
        """The default robot (C defaults; same numbers as data/default_robot.toml)."""
        raw = _lib.RawModel()
        _ext.model_default(raw)
        return cls(raw)

    def copy(self) -> Model:
        """An independent copy."""
        return Model(copy.deepcopy(self._raw), validate=False)

    def with_params(self, **changes: Any) -> Model:
        """A validated copy with some fields replaced (d1, a2, a3, d2, d3, g, p, kt, f, w, b,
        u_max)."""
        raw = copy.deepcopy(self._raw)
        for key, value in changes.items():
            if key in (*DH_KEYS, "g", "u_max"):
                setattr(raw, key, finite_scalar(value, key))
            elif key in ("p", "kt", "b", "f", "w"):
                _set_array(raw, key, value)
            else:
                raise BadInputError(f"unknown model parameter {key!r}")
        return Model(raw)

    def validate(self) -> None:
        """Raise ModelError naming the offending field if the parameters are unusable."""
        status, field = _ext.model_validate(self._raw)
        if status != 0:
            name = field or "?"
            raise ModelError(
                f"invalid model parameter {name} ({_lib.STATUS_NAMES[status]})",
                "rrr_model_validate",
                _lib.STATUS_NAMES[status],
            )

    # ---- parameters -----------------------------------------------------------------------
    @property
    def raw(self) -> _lib.RawModel:
        """The underlying C struct (for the FMU and HIL layers)."""
        return self._raw

    @property
    def p(self) -> FloatArray:
        """The 16 base parameters of eq 12 (corrected), p[0] = p1."""
        return np.array(self._raw.p[:])

    @property
    def dh(self) -> dict[str, float]:
        """DH lengths in metres."""
        return {k: float(getattr(self._raw, k)) for k in DH_KEYS}

    @property
    def g(self) -> float:
        return float(self._raw.g)

    @property
    def kt(self) -> FloatArray:
        return np.array(self._raw.kt[:])

    @property
    def f(self) -> FloatArray:
        return np.array([row[:] for row in self._raw.f])

    @property
    def w(self) -> FloatArray:
        return np.array([row[:] for row in self._raw.w])

    @property
    def b(self) -> FloatArray:
        return np.array(self._raw.b[:])

    @property
    def u_max(self) -> float:
        return float(self._raw.u_max)

    def to_dict(self) -> dict[str, Any]:
        """Parameters as the nested mapping of a robot TOML file (with base_parameters)."""
        return {
            "kinematics": self.dh,
            "gravity": {"g": self.g},
            "base_parameters": {"p": self.p.tolist()},
            "motors": {"kt": self.kt.tolist(), "u_max": self.u_max},
            "friction": {"f": self.f.tolist(), "w": self.w.tolist(), "b": self.b.tolist()},
        }

    def to_toml(self, path: str | Path) -> None:
        """Write the parameters as a robot TOML file ([base_parameters]; read it with
        :func:`rrr_robot.core.robot.read_robot_file`)."""
        write_toml(self.to_dict(), Path(path))

    # ---- kinematics -----------------------------------------------------------------------
    def fk(self, q: ArrayLike, simd: str = "auto",
           out: tuple[FloatArray, FloatArray] | None = None) -> tuple[FloatArray, FloatArray]:
        """Tip position (3,) and orientation (3, 3) (eqs 3-5); (n, 3), (n, 3, 3) for batches.

        A batch runs in one call of librrr's batch kernels; ``simd`` and ``out`` (here a pair
        of arrays, x and R) as for :meth:`inverse_dynamics` (``"auto"``: within 1e-13 m of the
        scalar path)."""
        return self._k.fk(q, simd, out)

    def fk_frames(self, q: ArrayLike) -> FloatArray:
        """Every DH frame in frame 0 as 4 x 4 homogeneous transforms, shape (4, 4, 4) (frames
        0..3; frame 3 is the tool, equal to :meth:`fk` bit for bit) or (n, 4, 4, 4) for a batch.
        The URDF's ``link<k>`` (:func:`~rrr_robot.core.urdf.robot_urdf`) is frame k-1 turned
        by q_k about its z."""
        return self._k.fk_frames(q)

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Position Jacobian dx/dq (3, 3) or (n, 3, 3)."""
        return self._k.jacobian(q)

    def tip_motion(
        self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Tip velocity and acceleration from joint motion."""
        return self._k.tip_motion(q, qd, qdd)

    def joint_motion(
        self, q: ArrayLike, xd: ArrayLike, xdd: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Joint velocity and acceleration from tip motion (raises SingularError at a
        singular configuration)."""
        return self._k.joint_motion(q, xd, xdd)

    def ik(self, x: ArrayLike, shoulder: str | None = None, elbow: str | None = None,
           simd: str = "auto", out: FloatArray | None = None) -> FloatArray:
        """Inverse kinematics (eq 6, valid in the whole workspace).

        Without a posture: every solution of one target (3,), shape (k, 3) with k = 1..4,
        ordered by branch (front/up, front/down, back/up, back/down); UnreachableError if there
        is none (a batch is refused: it needs a posture).

        With a posture (``shoulder`` 'front'|'back' and ``elbow`` 'up'|'down'): the solution on
        that branch, (3,) for one target, (n, 3) for a batch of targets, which runs in one call
        of librrr's batch kernels (``rrr_ik_batch``); ``simd`` and ``out`` as for
        :meth:`inverse_dynamics` (``"auto"``: within 1e-13 rad of the scalar path, which is
        :meth:`ik_branch` bit for bit). A row that is unreachable or not finite raises its error
        (UnreachableError, BadInputError) naming the row, as the other batch methods do; screen
        a batch with :meth:`workspace_margin` (> 0 reachable) first to keep the others."""
        if shoulder is None and elbow is None:
            if out is not None:
                raise BadInputError("ik: out needs a posture (shoulder and elbow): without one "
                                    "the number of solutions is not known in advance")
            return self._k.ik(x)
        if shoulder not in SHOULDER or elbow not in ELBOW:
            raise BadInputError(f"posture must be shoulder='front'|'back' and elbow='up'|'down', "
                                f"got {shoulder!r}, {elbow!r}")
        return self._k.ik_branch(x, SHOULDER[shoulder], ELBOW[elbow], simd, out)

    def ik_branches(self, x: ArrayLike) -> list[tuple[str, str]]:
        """The (shoulder, elbow) names of the solutions :meth:`ik` returns, in the same order."""
        return self._k.ik_branches(x)

    def ik_branch(self, x: ArrayLike, shoulder: str = "front", elbow: str = "up") -> FloatArray:
        """IK on one posture branch: shoulder 'front'|'back', elbow 'up'|'down'."""
        if shoulder not in SHOULDER or elbow not in ELBOW:
            raise BadInputError(f"posture must be front|back and up|down, got {shoulder}, {elbow}")
        return self._k.ik_branch(x, SHOULDER[shoulder], ELBOW[elbow])

    def ik_nearest(self, x: ArrayLike, q_prev: ArrayLike) -> FloatArray:
        """IK solution nearest to q_prev, unwrapped by whole turns. For a batch of targets the
        solution of each row seeds the next, giving a continuous joint path."""
        return self._k.ik_nearest(x, q_prev)

    def singularity(self, q: ArrayLike, tol: float = 1e-6) -> Singularity:
        """Classify one configuration (3,) against the singular sets (a batch is refused:
        classify a path row by row)."""
        return Singularity(*self._k.singularity(q, tol))

    def workspace_margin(self, x: ArrayLike) -> FloatArray | float:
        """Signed distance (m) of targets from the workspace boundary: > 0 reachable."""
        return self._k.workspace_margin(x)

    # ---- dynamics -------------------------------------------------------------------------
    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                  simd: str = "auto", out: FloatArray | None = None) -> FloatArray:
        """R(q, qd, qdd) of eq 10, (3, 16) or (n, 3, 16): tau = R p.

        A batch runs in one call of librrr's batch kernels; ``simd`` and ``out`` as for
        :meth:`inverse_dynamics` (``"auto"``: within 1e-13 of the scalar path)."""
        return self._k.regressor(q, qd, qdd, simd, out)

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                         simd: str = "auto", out: FloatArray | None = None) -> FloatArray:
        """Motor torque tau = R(q, qd, qdd) p (rigid body + rotor inertia), N m.

        A batch ((n, 3) rows) runs in one call of librrr's batch kernels
        (:mod:`rrr_robot.core.batch`): ``simd="auto"`` the widest this CPU runs (AVX-512, AVX2,
        else scalar), within 1e-13 N m of the scalar path; ``"scalar"`` bit for bit the
        one-state call on every row; ``"avx2"``, ``"avx512"`` those kernels (refused where they
        are not available). One state is always the scalar call.

        ``out``: an array to write the result into and return, instead of a new one: float64,
        C-contiguous, writable, of exactly the result's shape ((3,) or (n, 3)), sharing no
        memory with an input (BadInputError otherwise). A loop over batches of one size saves
        the allocation and, on Linux, the page faults of first writing fresh memory (on this
        project's VM about a third of a 1e5-state call: docs/performance.md). When a row fails,
        its error is raised and ``out`` holds the rows before it; the rest is unspecified."""
        return self._k.inverse_dynamics(q, qd, qdd, simd, out)

    def mass_matrix(self, q: ArrayLike) -> FloatArray:
        """D(q) of eq 7 (rotor inertias included), (3, 3) or (n, 3, 3)."""
        return self._k.mass_matrix(q)

    def coriolis(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """c(q, qd) of eq 7, N m."""
        return self._k.coriolis(q, qd)

    def gravity(self, q: ArrayLike) -> FloatArray:
        """h(q) of eq 7, N m."""
        return self._k.gravity(q)

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike,
                         simd: str = "auto", out: FloatArray | None = None) -> FloatArray:
        """qdd = D^-1 (tau - c - h), rad/s^2.

        A batch runs in one call of librrr's batch kernels (a branch-free Cholesky over the
        states; a row whose D is not positive definite is the scalar call's); ``simd`` and
        ``out`` as for :meth:`inverse_dynamics` (``"auto"``: within 1e-13 rad/s^2 of the
        scalar path for the default robot)."""
        return self._k.forward_dynamics(q, qd, tau, simd, out)

    def energy(self, q: ArrayLike, qd: ArrayLike) -> tuple[Any, Any]:
        """Kinetic and potential energy, J: two floats for one state, two (n,) arrays for a
        batch."""
        return self._k.energy(q, qd)

    # ---- actuators and control ------------------------------------------------------------
    def friction(self, qd: ArrayLike) -> FloatArray:
        """Friction voltage u_f(qd) of eq 9, V."""
        return self._k.friction(qd)

    def voltage_from_torque(self, qd: ArrayLike, tau: ArrayLike) -> FloatArray:
        """u = tau / k_t + u_f(qd) (eq 8/10), V, not saturated."""
        return self._k.voltage_from_torque(qd, tau)

    def torque_from_voltage(self, qd: ArrayLike, u: ArrayLike) -> FloatArray:
        """tau = k_t (sat(u) - u_f(qd)), N m."""
        return self._k.torque_from_voltage(qd, u)

    def nominal_voltage(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Feedforward voltage u_n of eq 10 along a motion (not saturated): every row's
        :meth:`inverse_dynamics`, then :meth:`voltage_from_torque`."""
        return self._k.nominal_voltage(q, qd, qdd)

    def ctc(
        self, gains: CtcGains, q_ref: ArrayLike, qd_ref: ArrayLike, qdd_ref: ArrayLike,
        q: ArrayLike, qd: ArrayLike,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The computed-torque law of eq 15 (``rrr_ctc``): the applied voltage
        u = sat(u_n + u_c), the feedforward u_n (eq 10 along the reference; 0 without
        feedforward) and the PD part u_c = Kp (q_ref - q) + Kd (qd_ref - qd), V. One state or
        (n, 3) batches, as the other methods."""
        if not isinstance(gains, CtcGains):
            raise BadInputError(f"gains must be a CtcGains, got {type(gains).__name__}")
        return self._k.ctc(gains.packed, q_ref, qd_ref, qdd_ref, q, qd)

    # ---- exact partial derivatives (rrr_derivatives.h) ----------------------------------------
    def plant_jacobian(self, q: ArrayLike, qd: ArrayLike, u: ArrayLike
                       ) -> tuple[FloatArray, FloatArray]:
        """The plant's qdd = f(q, qd, u) (eqs 7-9, u saturated at u_max) and its exact
        Jacobian d qdd / d(q, qd, u), (3, 9): columns q1..q3, qd1..qd3, u1..u3 (rad/s^2 per
        rad, per rad/s, per V); a clamped input's column is 0. (n, 3) and (n, 3, 9) for rows."""
        return self._k.plant_jacobian(q, qd, u)

    def ctc_jacobian(
        self, gains: CtcGains, q_ref: ArrayLike, qd_ref: ArrayLike, qdd_ref: ArrayLike,
        q: ArrayLike, qd: ArrayLike,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The computed-torque law's u (eq 15) and its exact Jacobians du and du_n, (3, 15) each:
        columns 3 k + j are joint j of q_ref, qd_ref, qdd_ref, q, qd (k = 0..4), V per unit; a
        clamped u_i has row i = 0 in du."""
        if not isinstance(gains, CtcGains):
            raise BadInputError(f"gains must be a CtcGains, got {type(gains).__name__}")
        return self._k.ctc_jacobian(gains.packed, q_ref, qd_ref, qdd_ref, q, qd)

    def __repr__(self) -> str:
        return f"Model(dh={self.dh}, g={self.g}, kt={self.kt.tolist()})"


def finite_scalar(value: object, name: str) -> float:
    """A finite float from a number; BadInputError naming ``name`` otherwise."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise BadInputError(f"{name} must be a finite number, got {value!r}") from exc
    if not np.isfinite(v):
        raise BadInputError(f"{name} must be a finite number, got {v}")
    return v


def finite_array(value: ArrayLike, name: str, shape: tuple[int, ...]) -> FloatArray:
    """``value`` as float64 of ``shape`` with finite elements; BadInputError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise BadInputError(f"{name} must be finite numbers of shape {shape}: "
                            f"{one_line(exc)}") from None
    if arr.shape != shape:
        raise BadInputError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise BadInputError(f"{name} must be finite numbers, got {value!r}")
    return arr


def _set_array(raw: _lib.RawModel, key: str, value: ArrayLike) -> None:
    target = getattr(raw, key)
    expected = {"p": (_lib.NP,), "kt": (3,), "b": (3,), "f": (3, 3), "w": (3, 3)}[key]
    arr = finite_array(value, key, expected)
    if arr.ndim == 1:
        for i, v in enumerate(arr):
            target[i] = float(v)
    else:
        for i in range(3):
            for k in range(3):
                target[i][k] = float(arr[i, k])
