"""The calls of librrr behind Model through ctypes: the interface of the compiled ``_ext.Kernels``
(same arguments, results and refusals), used when the extension module was not built (no Python
headers on the build machine) and, in the tests, as the reference the extension is compared with
bit for bit. Each call costs microseconds of ctypes overhead; batches loop in Python.
"""

from __future__ import annotations

import ctypes as ct
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import _lib, batch
from ._arrays import FloatArray, as_rows, broadcast_rows, ptr, rows_of

_BRANCHES = (("front", "up"), ("front", "down"), ("back", "up"), ("back", "down"))


def finite_scalar(value: object, name: str) -> float:
    """A finite float from a number; BadInputError otherwise."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise BadInputError(f"{name} must be a finite number, got {value!r}") from exc
    if not np.isfinite(v):
        raise BadInputError(f"{name} must be a finite number, got {v}")
    return v


#: what ``ik`` (all branches of one target) says to a batch
IK_BATCH_REFUSAL = ("ik without a posture takes one target (3,) (every branch); a batch (n, 3) "
                    "needs a posture: ik(x, shoulder, elbow); ik_nearest follows a path")


def path_value(path: int | str) -> int:
    """The rrr_simd value of a path argument: a ``simd=`` name (batch.refuse's BadInputError
    when it is no path here) or an rrr_simd value, as the extension takes it."""
    if isinstance(path, str):
        try:
            return batch.PATHS_HERE[path]
        except KeyError:
            batch.refuse(path)
    if isinstance(path, bool) or not isinstance(path, int):
        batch.refuse(path)
    if path not in batch.PATHS_HERE.values():
        raise ValueError(f"batch path {path} is not available here (rrr_simd_available)")
    return path


def _one_out(method: str, out: object, result: FloatArray, inputs: tuple[object, ...]
             ) -> FloatArray:
    want = ", ".join(str(d) for d in result.shape) + ("," if result.ndim == 1 else "")
    if not (isinstance(out, np.ndarray) and out.dtype == np.float64 and out.shape == result.shape
            and out.flags.c_contiguous and out.flags.aligned):
        raise BadInputError(f"{method}: out must be a float64 array of shape ({want}), "
                            f"C-contiguous and aligned; got {type(out).__name__}")
    if not out.flags.writeable:
        raise BadInputError(f"{method}: out must be writable, C-contiguous float64 arrays of "
                            f"shape ({want}), got {type(out).__name__}")
    for name, value in zip(("the inputs",) * len(inputs), inputs, strict=True):
        if isinstance(value, np.ndarray) and np.may_share_memory(out, value):
            raise BadInputError(f"{method}: out shares memory with {name}: the results would "
                                "overwrite inputs still to be read")
    out[...] = result
    return out


def into(method: str, out: object, result: Any, inputs: tuple[object, ...]) -> Any:
    """``result`` written into the caller's ``out`` (one array, or a tuple for a tuple result),
    checked as the extension checks it; ``result`` itself when ``out`` is None."""
    if out is None:
        return result
    if isinstance(result, tuple):
        if not (isinstance(out, tuple) and len(out) == len(result)):
            raise BadInputError(f"{method}: out must be a tuple of {len(result)} arrays, got "
                                f"{type(out).__name__}")
        if any(np.may_share_memory(a, b) for i, a in enumerate(out) for b in out[:i]):
            raise BadInputError(f"{method}: the arrays of out share memory")
        return tuple(_one_out(method, o, r, inputs) for o, r in zip(out, result, strict=True))
    return _one_out(method, out, result, inputs)


class Kernels:
    """The librrr calls on ``raw`` (read in place), one ctypes call per row."""

    def __init__(self, raw: _lib.RawModel) -> None:
        self._raw = raw
        self._ref = ct.byref(raw)

    # ---- kinematics -----------------------------------------------------------------------
    def fk(self, q: ArrayLike, path: int | str = 1, out: object = None, /
           ) -> tuple[FloatArray, FloatArray]:
        """Rows of rrr_fk; a batch on a path other than 1 (RRR_SIMD_SCALAR) through
        rrr_fk_batch (its failing row raised by the row loop); written into ``out`` if given."""
        return into("fk", out, self._fk(q, path_value(path)), (q,))  # type: ignore[no-any-return]

    def _fk(self, q: ArrayLike, path: int) -> tuple[FloatArray, FloatArray]:
        qs, batch = as_rows(q, "q")
        if batch and path != 1:
            outs = self._batch("rrr_fk_batch", [qs], [(3,), (3, 3)], path)
            if outs is not None:
                return outs[0], outs[1]
        x, rot = self._rowwise("rrr_fk", [qs], [(3,), (3, 3)], "q")
        return (x, rot) if batch else (x[0], rot[0])

    def fk_frames(self, q: ArrayLike, /) -> FloatArray:
        return self._map1("rrr_fk_frames", q, "q", (4, 4, 4))

    def jacobian(self, q: ArrayLike, /) -> FloatArray:
        return self._map1("rrr_jacobian", q, "q", (3, 3))

    def tip_motion(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, /
                   ) -> tuple[FloatArray, FloatArray]:
        rows, batch = broadcast_rows((q, "q"), (qd, "qd"), (qdd, "qdd"))
        xd, xdd = self._rowwise("rrr_tip_motion", rows, [(3,), (3,)], "q, qd, qdd")
        return (xd, xdd) if batch else (xd[0], xdd[0])

    def joint_motion(self, q: ArrayLike, xd: ArrayLike, xdd: ArrayLike, /
                     ) -> tuple[FloatArray, FloatArray]:
        rows, batch = broadcast_rows((q, "q"), (xd, "xd"), (xdd, "xdd"))
        qd, qdd = self._rowwise("rrr_joint_motion", rows, [(3,), (3,)], "q, xd, xdd")
        return (qd, qdd) if batch else (qd[0], qdd[0])

    def _ik_set(self, x: ArrayLike, refusal: str) -> _lib.RawIkSet:
        xs, batch = as_rows(x, "x")
        if batch:
            raise BadInputError(refusal)
        sol = _lib.RawIkSet()
        _lib.call("rrr_ik", self._ref, ptr(xs[0]), ct.byref(sol), context=f"x = {xs[0].tolist()}")
        return sol

    def ik(self, x: ArrayLike, /) -> FloatArray:
        sol = self._ik_set(x, IK_BATCH_REFUSAL)
        return np.array([sol.q[i][:] for i in range(sol.n)]).reshape(sol.n, 3)

    def ik_branches(self, x: ArrayLike, /) -> list[tuple[str, str]]:
        sol = self._ik_set(x, "ik_branches takes one target (3,), as ik does")
        return [_BRANCHES[sol.branch[i]] for i in range(sol.n)]

    def ik_branch(self, x: ArrayLike, shoulder: int, elbow: int, path: int | str = 1,
                  out: object = None, /) -> FloatArray:
        """Rows of rrr_ik_branch; a batch on a path other than 1 (RRR_SIMD_SCALAR) through
        rrr_ik_batch. The first row that fails raises its error. Written into ``out`` if
        given."""
        if shoulder not in (0, 1) or elbow not in (0, 1):
            raise BadInputError(f"posture indices must be 0 or 1, got {shoulder}, {elbow}")
        result = self._ik_branch(x, shoulder, elbow, path_value(path))
        return into("ik_branch", out, result, (x,))  # type: ignore[no-any-return]

    def _ik_branch(self, x: ArrayLike, shoulder: int, elbow: int, path: int) -> FloatArray:
        xs, batch = as_rows(x, "x")
        q = np.empty_like(xs)
        if batch and path != 1 and xs.shape[0] > 0:
            done = ct.c_size_t(0)
            if status := _lib.FUNCS["rrr_ik_batch"](self._ref, xs.shape[0], ptr(xs), shoulder,
                                                    elbow, ptr(q), None, path, ct.byref(done)):
                i = done.value
                _lib.raise_for("rrr_ik_branch", status, f"sample {i}: x = {xs[i].tolist()}")
            return q
        fn = _lib.FUNCS["rrr_ik_branch"]
        (xb, xs_), (qb, qs_) = rows_of(xs), rows_of(q)
        for i in range(xs.shape[0]):
            if status := fn(self._ref, xb + i * xs_, shoulder, elbow, qb + i * qs_):
                _lib.raise_for("rrr_ik_branch", status, f"sample {i}: x = {xs[i].tolist()}")
        return q if batch else q[0]

    def ik_nearest(self, x: ArrayLike, q_prev: ArrayLike, /) -> FloatArray:
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
            if status := fn(self._ref, xb + i * xs_, prev_addr, qb + i * qs_, None):
                _lib.raise_for("rrr_ik_nearest", status, f"sample {i}: x = {xs[i].tolist()}")
            prev_addr = qb + i * qs_
        return q if batch else q[0]

    def singularity(self, q: ArrayLike, tol: object, /
                    ) -> tuple[bool, bool, bool, float, float, float]:
        qs, batch = as_rows(q, "q")
        if batch:
            raise BadInputError("singularity takes one configuration (3,); classify a path "
                                "row by row")
        s = _lib.RawSingularity()
        _lib.call("rrr_singularity_classify", self._ref, ptr(qs[0]), finite_scalar(tol, "tol"),
                  ct.byref(s), context=f"q = {qs[0].tolist()}")
        return (bool(s.flags & 1), bool(s.flags & 2), bool(s.flags & 4), s.elbow_margin,
                s.shoulder_margin, s.det_jacobian)

    def workspace_margin(self, x: ArrayLike, /) -> FloatArray | float:
        xs, batch = as_rows(x, "x")
        out = np.empty(xs.shape[0])
        fn = _lib.FUNCS["rrr_workspace_margin"]
        (xb, xs_), (ob, os_) = rows_of(xs), rows_of(out)
        for i in range(xs.shape[0]):
            if status := fn(self._ref, xb + i * xs_, ob + i * os_, None):
                _lib.raise_for("rrr_workspace_margin", status, f"sample {i}: x = {xs[i].tolist()}")
        return out if batch else float(out[0])

    # ---- dynamics -------------------------------------------------------------------------
    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, path: int | str = 1,
                  out: object = None, /) -> FloatArray:
        """Rows of rrr_regressor; a batch on a path other than 1 through
        rrr_regressor_batch; written into ``out`` if given."""
        result = self._map3_batch("rrr_regressor", q, qd, qdd, (3, _lib.NP), path_value(path))
        return into("regressor", out, result, (q, qd, qdd))  # type: ignore[no-any-return]

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
                         path: int | str = 1, out: object = None, /) -> FloatArray:
        """Rows of rrr_inverse_dynamics; a batch on a path other than 1 (RRR_SIMD_SCALAR)
        through rrr_inverse_dynamics_batch (its failing row raised by the row loop); written
        into ``out`` if given."""
        result = self._map3_batch("rrr_inverse_dynamics", q, qd, qdd, (3,), path_value(path))
        return into("inverse_dynamics", out, result,  # type: ignore[no-any-return]
                    (q, qd, qdd))

    def mass_matrix(self, q: ArrayLike, /) -> FloatArray:
        return self._map1("rrr_mass_matrix", q, "q", (3, 3))

    def coriolis(self, q: ArrayLike, qd: ArrayLike, /) -> FloatArray:
        return self._map2("rrr_coriolis", (q, "q"), (qd, "qd"))

    def gravity(self, q: ArrayLike, /) -> FloatArray:
        return self._map1("rrr_gravity", q, "q", (3,))

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike,
                         path: int | str = 1, out: object = None, /) -> FloatArray:
        """Rows of rrr_forward_dynamics; a batch on a path other than 1 through
        rrr_forward_dynamics_batch; written into ``out`` if given."""
        result = self._map3_batch("rrr_forward_dynamics", q, qd, tau, (3,), path_value(path),
                                  names=("q", "qd", "tau"))
        return into("forward_dynamics", out, result,  # type: ignore[no-any-return]
                    (q, qd, tau))

    def energy(self, q: ArrayLike, qd: ArrayLike, /) -> tuple[Any, Any]:
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
    def friction(self, qd: ArrayLike, /) -> FloatArray:
        return self._map1("rrr_friction", qd, "qd", (3,))

    def voltage_from_torque(self, qd: ArrayLike, tau: ArrayLike, /) -> FloatArray:
        return self._map2("rrr_voltage_from_torque", (qd, "qd"), (tau, "tau"))

    def torque_from_voltage(self, qd: ArrayLike, u: ArrayLike, /) -> FloatArray:
        return self._map2("rrr_torque_from_voltage", (qd, "qd"), (u, "u"))

    def nominal_voltage(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, /) -> FloatArray:
        return self.voltage_from_torque(qd, self.inverse_dynamics(q, qd, qdd))

    def ctc(self, gains: bytes, q_ref: ArrayLike, qd_ref: ArrayLike, qdd_ref: ArrayLike,
            q: ArrayLike, qd: ArrayLike, /) -> tuple[FloatArray, FloatArray, FloatArray]:
        if len(gains) != ct.sizeof(_lib.RawCtcGains):
            raise TypeError(f"ctc needs the {ct.sizeof(_lib.RawCtcGains)} bytes of an "
                            "rrr_ctc_gains (CtcGains.packed)")
        raw_gains = _lib.RawCtcGains.from_buffer_copy(gains)
        names = ("q_ref", "qd_ref", "qdd_ref", "q", "qd")
        rows, batch = broadcast_rows(*zip((q_ref, qd_ref, qdd_ref, q, qd), names, strict=True))
        n = rows[0].shape[0]
        u, u_n, u_c = (np.empty((n, 3)) for _ in range(3))
        out = _lib.RawCtcOutput()
        fn = _lib.FUNCS["rrr_ctc"]
        for i in range(n):
            if status := fn(self._ref, ct.byref(raw_gains), *(ptr(a[i]) for a in rows),
                            ct.byref(out)):
                self._fail("rrr_ctc", status, rows, ", ".join(names), i)
            u[i], u_n[i], u_c[i] = out.u[:], out.u_n[:], out.u_c[:]
        return (u, u_n, u_c) if batch else (u[0], u_n[0], u_c[0])

    # ---- plant -----------------------------------------------------------------------------
    def plant_step(self, integrator: bytes, u: ArrayLike, h: object, state: Any, stats: Any, /
                   ) -> FloatArray:
        integ = _struct_from(integrator, _lib.RawPlantIntegrator, "plant_step",
                             "rrr_plant_integrator (PlantIntegrator.packed)")
        u_arr = _one(u, "u", "plant_step takes one input voltage u (3,)")
        step = finite_scalar(h, "h")
        _writable(state, _lib.RawPlantState, "plant_step", "rrr_plant_state (RawPlantState)")
        _writable(stats, _lib.RawPlantStats, "plant_step", "rrr_plant_stats (RawPlantStats)")
        x = _lib.RawPlantState.from_buffer_copy(state)
        qdd = np.empty(3)
        out = _lib.RawPlantStats()
        status = _lib.FUNCS["rrr_plant_step"](self._ref, ct.byref(integ), ptr(u_arr), step,
                                               ct.byref(x), ptr(qdd), ct.byref(out))
        if status:
            _lib.raise_for("rrr_plant_step", status, _plant_context(u_arr, step, x))
        ct.memmove(ct.addressof(state), ct.addressof(x), ct.sizeof(x))
        ct.memmove(ct.addressof(stats), ct.addressof(out), ct.sizeof(out))
        return qdd

    def plant_accel(self, state: Any, u: ArrayLike, /) -> FloatArray:
        x = _struct_from(state, _lib.RawPlantState, "plant_accel",
                         "rrr_plant_state (RawPlantState)")
        u_arr = _one(u, "u", "plant_accel takes one input voltage u (3,)")
        qdd = np.empty(3)
        if status := _lib.FUNCS["rrr_plant_accel"](self._ref, ct.byref(x), ptr(u_arr), ptr(qdd)):
            _lib.raise_for("rrr_plant_accel", status, _plant_context(u_arr, 0.0, x))
        return qdd

    # ---- partial derivatives -------------------------------------------------------------
    def plant_jacobian(self, q: ArrayLike, qd: ArrayLike, u: ArrayLike, /
                       ) -> tuple[FloatArray, FloatArray]:
        rows, batch = broadcast_rows((q, "q"), (qd, "qd"), (u, "u"))
        n = rows[0].shape[0]
        qdd, jac = np.empty((n, 3)), np.empty((n, 3, 9))
        x, d = _lib.RawPlantState(), _lib.RawPlantDerivatives()
        fn = _lib.FUNCS["rrr_plant_jacobian"]
        for i in range(n):
            x.q[:], x.qd[:] = rows[0][i], rows[1][i]
            if status := fn(self._ref, ct.byref(x), ptr(rows[2][i]), ct.byref(d)):
                self._fail("rrr_plant_jacobian", status, rows, "q, qd, u", i)
            qdd[i] = d.qdd[:]
            jac[i] = np.hstack([np.ctypeslib.as_array(d.dqdd_dq), np.ctypeslib.as_array(
                d.dqdd_dqd), np.ctypeslib.as_array(d.dqdd_du)])
        return (qdd, jac) if batch else (qdd[0], jac[0])

    def ctc_jacobian(self, gains: bytes, q_ref: ArrayLike, qd_ref: ArrayLike, qdd_ref: ArrayLike,
                     q: ArrayLike, qd: ArrayLike, /
                     ) -> tuple[FloatArray, FloatArray, FloatArray]:
        if len(gains) != ct.sizeof(_lib.RawCtcGains):
            raise TypeError(f"ctc_jacobian needs the {ct.sizeof(_lib.RawCtcGains)} bytes of an "
                            "rrr_ctc_gains (CtcGains.packed)")
        raw_gains = _lib.RawCtcGains.from_buffer_copy(gains)
        names = ("q_ref", "qd_ref", "qdd_ref", "q", "qd")
        rows, batch = broadcast_rows(*zip((q_ref, qd_ref, qdd_ref, q, qd), names, strict=True))
        n = rows[0].shape[0]
        u, du, du_n = np.empty((n, 3)), np.empty((n, 3, 15)), np.empty((n, 3, 15))
        d = _lib.RawCtcDerivatives()
        fn = _lib.FUNCS["rrr_ctc_jacobian"]
        for i in range(n):
            if status := fn(self._ref, ct.byref(raw_gains), *(ptr(a[i]) for a in rows),
                            ct.byref(d)):
                self._fail("rrr_ctc_jacobian", status, rows, ", ".join(names), i)
            u[i] = d.out.u[:]
            # [k][i][j] -> [i][3 k + j]
            du[i] = np.ctypeslib.as_array(d.du).transpose(1, 0, 2).reshape(3, 15)
            du_n[i] = np.ctypeslib.as_array(d.du_n).transpose(1, 0, 2).reshape(3, 15)
        return (u, du, du_n) if batch else (u[0], du[0], du_n[0])

    # ---- helpers ---------------------------------------------------------------------------
    def _rowwise(self, fn: str, ins: list[FloatArray], out_shapes: list[tuple[int, ...]],
                 names: str) -> list[FloatArray]:
        """Call ``fn(model, in_1[i], ..., out_1[i], ...)`` for every row i of the inputs."""
        n = ins[0].shape[0]
        outs = [np.empty((n, *shape)) for shape in out_shapes]
        bases = [rows_of(a) for a in (*ins, *outs)]
        call = _lib.FUNCS[fn]
        ref = self._ref
        for i in range(n):
            if status := call(ref, *[base + i * step for base, step in bases]):
                self._fail(fn, status, ins, names, i)
        return outs

    @staticmethod
    def _fail(fn: str, status: int, ins: list[FloatArray], names: str, i: int) -> None:
        values = ", ".join(str(a[i].tolist()) for a in ins)
        _lib.raise_for(fn, status, f"sample {i}: {names} = {values}")

    def _batch(self, fn: str, ins: list[FloatArray], out_shapes: list[tuple[int, ...]],
               path: int) -> list[FloatArray] | None:
        """The outputs of the batch call ``fn`` on path ``path``, or None when it fails (the
        caller's row loop then raises the failing row's error)."""
        n = ins[0].shape[0]
        outs = [np.empty((n, *shape)) for shape in out_shapes]
        done = ct.c_size_t(0)
        if _lib.FUNCS[fn](self._ref, n, *[ptr(a) for a in (*ins, *outs)], path,
                          ct.byref(done)) == 0:
            return outs
        return None

    def _map3_batch(
        self, fn: str, a: ArrayLike, b: ArrayLike, c: ArrayLike, shape: tuple[int, ...],
        path: int, names: tuple[str, str, str] = ("q", "qd", "qdd"),
    ) -> FloatArray:
        """_map3 of ``fn``, a batch on a path other than 1 through ``fn``_batch."""
        if path != 1:
            rows, batch = broadcast_rows((a, names[0]), (b, names[1]), (c, names[2]))
            if batch:
                outs = self._batch(f"{fn}_batch", rows, [shape], path)
                if outs is not None:
                    return outs[0]
        return self._map3(fn, a, b, c, shape, names)

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


def _struct_from(data: Any, kind: Any, method: str, what: str) -> Any:
    """A copy of the C struct ``kind`` from a buffer of exactly its size; TypeError otherwise."""
    try:
        view = memoryview(data)
    except TypeError:
        view = None
    if view is None or view.nbytes != ct.sizeof(kind):
        raise TypeError(f"{method} needs the {ct.sizeof(kind)} bytes of an {what}")
    return kind.from_buffer_copy(view.cast("B"))


def _writable(data: Any, kind: Any, method: str, what: str) -> None:
    """TypeError unless ``data`` is a writable ctypes struct of ``kind``'s size."""
    if not isinstance(data, ct.Structure) or ct.sizeof(data) != ct.sizeof(kind):
        raise TypeError(f"{method} needs a writable {what} of {ct.sizeof(kind)} bytes")


def _one(value: ArrayLike, name: str, refusal: str) -> FloatArray:
    rows, batch = as_rows(value, name)
    if batch:
        raise BadInputError(refusal)
    return np.ascontiguousarray(rows[0])


def _plant_context(u: FloatArray, h: float, x: Any) -> str:
    return f"u = {u.tolist()}, h = {h!r}, q = {list(x.q)}, qd = {list(x.qd)}"
