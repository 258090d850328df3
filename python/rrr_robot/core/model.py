"""The RRR model: parameters plus every closed-form algorithm of librrr, with batch variants.

No model mathematics is done here: each method moves arrays into the C core and back.
"""

from __future__ import annotations

import copy
import ctypes as ct
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError, ModelError
from . import _lib
from ._arrays import FloatArray, as_rows, broadcast_rows, ptr, rows_of
from ._package import DATA_DIR
from .robot_file import parse_robot, read_robot_data, write_toml

DH_KEYS = ("d1", "a2", "a3", "d2", "d3")
SHOULDER = {"front": 0, "back": 1}
ELBOW = {"up": 0, "down": 1}
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
    tensors about the COM (3, 3, 3) and rotor inertias (3,)."""
    m_arr = np.asarray(masses, dtype=float)
    c_arr = np.asarray(coms, dtype=float)
    i_arr = np.asarray(inertias_com, dtype=float)
    j_arr = np.asarray(rotor_inertia, dtype=float)
    shapes = {"masses": (3,), "coms": (3, 3), "inertias_com": (3, 3, 3), "rotor_inertia": (3,)}
    for name, arr in zip(shapes, (m_arr, c_arr, i_arr, j_arr), strict=True):
        if arr.shape != shapes[name]:
            raise BadInputError(f"{name} must have shape {shapes[name]}, got {arr.shape}")
    raw = _lib.RawModel()
    for k in DH_KEYS:
        if k in dh:
            setattr(raw, k, float(dh[k]))
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
    _lib.call("rrr_bps_from_inertia", ct.byref(raw), ct.byref(inertial), ptr(p))
    return p


class Model:
    """Parameters of the RRR arm and its closed-form algorithms (all evaluated in C).

    Build with :meth:`default`, :meth:`from_toml` or :meth:`from_dict`. Array arguments are
    (3,) vectors or (n, 3) batches; results follow the shape of the input.
    """

    def __init__(self, raw: _lib.RawModel, *, validate: bool = True) -> None:
        self._raw = raw
        self._ref = ct.byref(raw)
        if validate:
            self.validate()

    # ---- construction -------------------------------------------------------------------
    @classmethod
    def default(cls) -> Model:
        """The default robot (C defaults; same numbers as data/default_robot.toml)."""
        raw = _lib.RawModel()
        _lib.call("rrr_model_default", ct.byref(raw))
        return cls(raw)

    @classmethod
    def from_toml(cls, path: str | Path) -> Model:
        """Read a robot file in the format of data/default_robot.toml (every table checked once
        by :func:`rrr_robot.core.robot_file.read_robot_data`; RobotFileError names the file, the
        table and the key). :func:`rrr_robot.core.robot.read_robot_file` gives the other tables
        as well."""
        return cls(read_robot_data(path).raw_model(), validate=False)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "robot data") -> Model:
        """Build from the nested mapping of a robot TOML file (see data/default_robot.toml),
        with the same checks as :meth:`from_toml`.

        A ``[base_parameters] p = [...]`` table, if present, is used as is; otherwise p is
        computed from ``[link1..3]`` and ``[motors] rotor_inertia`` by eq 12.
        """
        return cls(parse_robot(data, source).raw_model(), validate=False)

    def copy(self) -> Model:
        """An independent copy."""
        return Model(copy.deepcopy(self._raw), validate=False)

    def with_params(self, **changes: Any) -> Model:
        """A validated copy with some fields replaced (d1, a2, a3, d2, d3, g, p, kt, f, w, b,
        u_max)."""
        raw = copy.deepcopy(self._raw)
        for key, value in changes.items():
            if key in (*DH_KEYS, "g", "u_max"):
                setattr(raw, key, _finite_scalar(value, key))
            elif key in ("p", "kt", "b", "f", "w"):
                _set_array(raw, key, value)
            else:
                raise BadInputError(f"unknown model parameter {key!r}")
        return Model(raw)

    def validate(self) -> None:
        """Raise ModelError naming the offending field if the parameters are unusable."""
        field = ct.c_char_p()
        status = _lib.LIB.rrr_model_validate(self._ref, ct.byref(field))
        if status != 0:
            name = (field.value or b"?").decode()
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
        """Write the parameters as a robot TOML file readable by :meth:`from_toml`."""
        write_toml(self.to_dict(), Path(path))

    # ---- kinematics -----------------------------------------------------------------------
    def fk(self, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Tip position (3,) and orientation (3, 3) (eqs 3-5); (n, 3), (n, 3, 3) for batches."""
        qs, batch = as_rows(q, "q")
        x, rot = self._rowwise("rrr_fk", [qs], [(3,), (3, 3)], "q")
        return (x, rot) if batch else (x[0], rot[0])

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Position Jacobian dx/dq (3, 3) or (n, 3, 3)."""
        return self._map1("rrr_jacobian", q, "q", (3, 3))

    def tip_motion(
        self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Tip velocity and acceleration from joint motion."""
        rows, batch = broadcast_rows((q, "q"), (qd, "qd"), (qdd, "qdd"))
        xd, xdd = self._rowwise("rrr_tip_motion", rows, [(3,), (3,)], "q, qd, qdd")
        return (xd, xdd) if batch else (xd[0], xdd[0])

    def joint_motion(
        self, q: ArrayLike, xd: ArrayLike, xdd: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Joint velocity and acceleration from tip motion (raises SingularError at a
        singular configuration)."""
        rows, batch = broadcast_rows((q, "q"), (xd, "xd"), (xdd, "xdd"))
        qd, qdd = self._rowwise("rrr_joint_motion", rows, [(3,), (3,)], "q, xd, xdd")
        return (qd, qdd) if batch else (qd[0], qdd[0])

    def ik(self, x: ArrayLike) -> FloatArray:
        """Every IK solution of one target, shape (k, 3) with k = 1..4, ordered by branch
        (front/up, front/down, back/up, back/down). Raises UnreachableError if there is none."""
        xs, batch = as_rows(x, "x")
        if batch:
            raise BadInputError("ik takes one target (3,); use ik_nearest for paths")
        sol = _lib.RawIkSet()
        _lib.call("rrr_ik", self._ref, ptr(xs[0]), ct.byref(sol), context=f"x = {xs[0].tolist()}")
        return np.array([sol.q[i][:] for i in range(sol.n)])

    def ik_branches(self, x: ArrayLike) -> list[tuple[str, str]]:
        """The (shoulder, elbow) names of the solutions :meth:`ik` returns, in the same order."""
        xs, batch = as_rows(x, "x")
        if batch:
            raise BadInputError("ik_branches takes one target (3,), as ik does")
        sol = _lib.RawIkSet()
        _lib.call("rrr_ik", self._ref, ptr(xs[0]), ct.byref(sol), context=f"x = {xs[0].tolist()}")
        names = [("front", "up"), ("front", "down"), ("back", "up"), ("back", "down")]
        return [names[sol.branch[i]] for i in range(sol.n)]

    def ik_branch(self, x: ArrayLike, shoulder: str = "front", elbow: str = "up") -> FloatArray:
        """IK on one posture branch: shoulder 'front'|'back', elbow 'up'|'down'."""
        if shoulder not in SHOULDER or elbow not in ELBOW:
            raise BadInputError(f"posture must be front|back and up|down, got {shoulder}, {elbow}")
        xs, batch = as_rows(x, "x")
        q = np.empty_like(xs)
        fn = _lib.FUNCS["rrr_ik_branch"]
        (xb, xs_), (qb, qs_) = rows_of(xs), rows_of(q)
        for i in range(xs.shape[0]):
            status = fn(self._ref, xb + i * xs_, SHOULDER[shoulder], ELBOW[elbow], qb + i * qs_)
            if status:
                _lib.raise_for("rrr_ik_branch", status, f"sample {i}: x = {xs[i].tolist()}")
        return q if batch else q[0]

    def ik_nearest(self, x: ArrayLike, q_prev: ArrayLike) -> FloatArray:
        """IK solution nearest to q_prev, unwrapped by whole turns. For a batch of targets the
        solution of each row seeds the next, giving a continuous joint path."""
        xs, batch = as_rows(x, "x")
        prev_rows, prev_batch = as_rows(q_prev, "q_prev")
        if prev_batch:
            raise BadInputError(f"q_prev must have shape (3,) (the seed of the first target), "
                                f"got {prev_rows.shape}")
        prev = np.array(prev_rows[0])
        q = np.empty_like(xs)
        fn = _lib.FUNCS["rrr_ik_nearest"]
        (xb, xs_), (qb, qs_) = rows_of(xs), rows_of(q)
        prev_addr = ptr(prev)
        for i in range(xs.shape[0]):
            status = fn(self._ref, xb + i * xs_, prev_addr, qb + i * qs_, None)
            if status:
                _lib.raise_for("rrr_ik_nearest", status, f"sample {i}: x = {xs[i].tolist()}")
            prev_addr = qb + i * qs_
        return q if batch else q[0]

    def singularity(self, q: ArrayLike, tol: float = 1e-6) -> Singularity:
        """Classify one configuration (3,) against the singular sets (a batch is refused:
        classify a path row by row)."""
        qs, batch = as_rows(q, "q")
        if batch:
            raise BadInputError("singularity takes one configuration (3,); classify a path "
                                "row by row")
        s = _lib.RawSingularity()
        _lib.call("rrr_singularity_classify", self._ref, ptr(qs[0]), _finite_scalar(tol, "tol"),
                  ct.byref(s), context=f"q = {qs[0].tolist()}")
        return Singularity(
            stretched=bool(s.flags & 1), folded=bool(s.flags & 2), shoulder=bool(s.flags & 4),
            elbow_margin=s.elbow_margin, shoulder_margin=s.shoulder_margin,
            det_jacobian=s.det_jacobian,
        )

    def workspace_margin(self, x: ArrayLike) -> FloatArray | float:
        """Signed distance (m) of targets from the workspace boundary: > 0 reachable."""
        xs, batch = as_rows(x, "x")
        out = np.empty(xs.shape[0])
        fn = _lib.FUNCS["rrr_workspace_margin"]
        (xb, xs_), (ob, os_) = rows_of(xs), rows_of(out)
        for i in range(xs.shape[0]):
            status = fn(self._ref, xb + i * xs_, ob + i * os_, None)
            if status:
                _lib.raise_for("rrr_workspace_margin", status, f"sample {i}: x = {xs[i].tolist()}")
        return out if batch else float(out[0])

    # ---- dynamics -------------------------------------------------------------------------
    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """R(q, qd, qdd) of eq 10, (3, 16) or (n, 3, 16): tau = R p."""
        return self._map3("rrr_regressor", q, qd, qdd, (3, _lib.NP))

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Motor torque tau = R(q, qd, qdd) p (rigid body + rotor inertia), N m."""
        return self._map3("rrr_inverse_dynamics", q, qd, qdd, (3,))

    def mass_matrix(self, q: ArrayLike) -> FloatArray:
        """D(q) of eq 7 (rotor inertias included), (3, 3) or (n, 3, 3)."""
        return self._map1("rrr_mass_matrix", q, "q", (3, 3))

    def coriolis(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """c(q, qd) of eq 7, N m."""
        return self._map2("rrr_coriolis", (q, "q"), (qd, "qd"))

    def gravity(self, q: ArrayLike) -> FloatArray:
        """h(q) of eq 7, N m."""
        return self._map1("rrr_gravity", q, "q", (3,))

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> FloatArray:
        """qdd = D^-1 (tau - c - h), rad/s^2."""
        return self._map3("rrr_forward_dynamics", q, qd, tau, (3,), names=("q", "qd", "tau"))

    def energy(self, q: ArrayLike, qd: ArrayLike) -> tuple[Any, Any]:
        """Kinetic and potential energy, J: two floats for one state, two (n,) arrays for a
        batch."""
        (qs, qds), batch = broadcast_rows((q, "q"), (qd, "qd"))
        n = qs.shape[0]
        kin, pot = np.empty(n), np.empty(n)
        k, v = ct.c_double(), ct.c_double()
        fn = _lib.FUNCS["rrr_energy"]
        for i in range(n):
            if status := fn(self._ref, ptr(qs[i]), ptr(qds[i]), ct.byref(k), ct.byref(v)):
                _lib.raise_for("rrr_energy", status,
                               f"sample {i}: q = {qs[i].tolist()}, qd = {qds[i].tolist()}")
            kin[i], pot[i] = k.value, v.value
        return (kin, pot) if batch else (float(kin[0]), float(pot[0]))

    # ---- actuators and control ------------------------------------------------------------
    def friction(self, qd: ArrayLike) -> FloatArray:
        """Friction voltage u_f(qd) of eq 9, V."""
        return self._map1("rrr_friction", qd, "qd", (3,))

    def voltage_from_torque(self, qd: ArrayLike, tau: ArrayLike) -> FloatArray:
        """u = tau / k_t + u_f(qd) (eq 8/10), V, not saturated."""
        return self._map2("rrr_voltage_from_torque", (qd, "qd"), (tau, "tau"))

    def torque_from_voltage(self, qd: ArrayLike, u: ArrayLike) -> FloatArray:
        """tau = k_t (sat(u) - u_f(qd)), N m."""
        return self._map2("rrr_torque_from_voltage", (qd, "qd"), (u, "u"))

    def nominal_voltage(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Feedforward voltage u_n of eq 10 along a motion (not saturated)."""
        tau = self.inverse_dynamics(q, qd, qdd)
        return self.voltage_from_torque(qd, tau)

    # ---- helpers ---------------------------------------------------------------------------
    def _rowwise(self, fn: str, ins: list[FloatArray], out_shapes: list[tuple[int, ...]],
                 names: str) -> list[FloatArray]:
        """Call ``fn(model, in_1[i], ..., out_1[i], ...)`` for every row i of the inputs."""
        n = ins[0].shape[0]
        outs = [np.empty((n, *shape)) for shape in out_shapes]
        bases = [rows_of(a) for a in (*ins, *outs)]
        call = _lib.FUNCS[fn]
        ref = self._ref
        if len(bases) == 2:  # unrolled common cases: no per-row list building
            (a, sa), (b, sb) = bases
            for i in range(n):
                if status := call(ref, a + i * sa, b + i * sb):
                    self._fail(fn, status, ins, names, i)
        elif len(bases) == 3:
            (a, sa), (b, sb), (c, sc) = bases
            for i in range(n):
                if status := call(ref, a + i * sa, b + i * sb, c + i * sc):
                    self._fail(fn, status, ins, names, i)
        else:
            for i in range(n):
                if status := call(ref, *[base + i * step for base, step in bases]):
                    self._fail(fn, status, ins, names, i)
        return outs

    @staticmethod
    def _fail(fn: str, status: int, ins: list[FloatArray], names: str, i: int) -> None:
        values = ", ".join(str(a[i].tolist()) for a in ins)
        _lib.raise_for(fn, status, f"sample {i}: {names} = {values}")

    def _map1(self, fn: str, a: ArrayLike, name: str, shape: tuple[int, ...]) -> FloatArray:
        rows, batch = as_rows(a, name)
        (out,) = self._rowwise(fn, [rows], [shape], name)
        return out if batch else out[0]

    def _map2(self, fn: str, a: tuple[ArrayLike, str], b: tuple[ArrayLike, str]) -> FloatArray:
        rows, batch = broadcast_rows(a, b)
        (out,) = self._rowwise(fn, rows, [(3,)], f"{a[1]}, {b[1]}")
        return out if batch else out[0]

    def _map3(
        self, fn: str, a: ArrayLike, b: ArrayLike, c: ArrayLike, shape: tuple[int, ...],
        names: tuple[str, str, str] = ("q", "qd", "qdd"),
    ) -> FloatArray:
        rows, batch = broadcast_rows((a, names[0]), (b, names[1]), (c, names[2]))
        (out,) = self._rowwise(fn, rows, [shape], ", ".join(names))
        return out if batch else out[0]

    def __repr__(self) -> str:
        return f"Model(dh={self.dh}, g={self.g}, kt={self.kt.tolist()})"


def _finite_scalar(value: object, name: str) -> float:
    """A finite float from a number; BadInputError otherwise."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise BadInputError(f"{name} must be a finite number, got {value!r}") from exc
    if not np.isfinite(v):
        raise BadInputError(f"{name} must be a finite number, got {v}")
    return v


def _set_array(raw: _lib.RawModel, key: str, value: ArrayLike) -> None:
    arr = np.asarray(value, dtype=float)
    target = getattr(raw, key)
    expected = {"p": (_lib.NP,), "kt": (3,), "b": (3,), "f": (3, 3), "w": (3, 3)}[key]
    if arr.shape != expected:
        raise BadInputError(f"{key} must have shape {expected}, got {arr.shape}")
    if arr.ndim == 1:
        for i, v in enumerate(arr):
            target[i] = float(v)
    else:
        for i in range(3):
            for k in range(3):
                target[i][k] = float(arr[i, k])
