"""The compiled binding rrr_robot.core._ext against the ctypes binding (_ctypes_kernels, the
reference: one ctypes call of librrr per row): every method gives bit-identical results on random
inputs (single states, batches, broadcast rows, every kind of input), the same refusals (class,
message, function and status), reads contiguous float64 input in place, and runs large batches
without the GIL."""

from __future__ import annotations

import array
import ctypes as ct
import os
import shutil
import subprocess
import sys
import threading
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core import _ctypes_kernels, _ext, _lib
from rrr_robot.core import model as model_module

RNG = np.random.default_rng(20261130)
MODEL = rr.Model.default()
EXT = _ext.Kernels(MODEL.raw)
REF = _ctypes_kernels.Kernels(MODEL.raw)

# every Kernels method with the kind of each argument: q (joint angles), v (joint rates, torques,
# voltages), x (tip targets, inside the workspace), X (tip velocity, acceleration)
SIGNATURES: dict[str, tuple[str, ...]] = {
    "fk": ("q",),
    "fk_frames": ("q",),
    "jacobian": ("q",),
    "tip_motion": ("q", "v", "v"),
    "joint_motion": ("q", "X", "X"),
    "workspace_margin": ("x",),
    "ik_nearest": ("x", "q1"),
    "regressor": ("q", "v", "v"),
    "inverse_dynamics": ("q", "v", "v"),
    "mass_matrix": ("q",),
    "coriolis": ("q", "v"),
    "gravity": ("q",),
    "forward_dynamics": ("q", "v", "v"),
    "energy": ("q", "v"),
    "friction": ("v",),
    "voltage_from_torque": ("v", "v"),
    "torque_from_voltage": ("v", "v"),
    "nominal_voltage": ("q", "v", "v"),
    "plant_jacobian": ("q", "v", "v"),
}
SINGLE_ONLY = {"ik": ("x",), "ik_branches": ("x",)}


def draw(kind: str, n: int | None) -> np.ndarray:
    """n rows (None: one (3,) vector) of random values of one kind."""
    rows = 1 if n is None else n
    if kind in ("q", "q1"):
        out = RNG.uniform(-4.0, 4.0, (rows, 3))
    elif kind == "v":
        out = RNG.uniform(-5.0, 5.0, (rows, 3))
    elif kind == "X":
        out = RNG.uniform(-0.5, 0.5, (rows, 3))
    else:  # reachable targets: the tips of random configurations
        out, _ = MODEL.fk(RNG.uniform(-3.0, 3.0, (rows, 3)))
    return out[0] if n is None else out


def same_bits(a: Any, b: Any) -> None:
    """Equal to the last bit (NaN payloads and signed zeros included), shape and type."""
    if isinstance(a, tuple | list):
        assert type(a) is type(b) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            same_bits(x, y)
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray)
        assert a.dtype == b.dtype == np.float64 and a.shape == b.shape
        assert a.tobytes() == b.tobytes()
    elif isinstance(a, float):
        assert type(b) is float
        assert np.float64(a).tobytes() == np.float64(b).tobytes()
    else:
        assert type(a) is type(b) and a == b


def outcome(fn: Callable[..., Any], *args: Any) -> tuple[str, Any]:
    """("ok", result) or ("error", (class, message, function, status))."""
    try:
        return "ok", fn(*args)
    except Exception as exc:  # the comparison includes non-RrrError exceptions
        detail = (getattr(exc, "function", None), getattr(exc, "status", None))
        return "error", (type(exc), str(exc), *detail)


def same_outcome(name: str, *args: Any) -> tuple[str, Any]:
    got, want = outcome(getattr(EXT, name), *args), outcome(getattr(REF, name), *args)
    assert got[0] == want[0], (name, args, got, want)
    if got[0] == "ok":
        same_bits(got[1], want[1])
    else:
        assert got[1] == want[1], (name, args)
    return got


def test_the_extension_is_in_use() -> None:
    assert model_module.BINDING == "extension"
    assert isinstance(MODEL._k, _ext.Kernels)
    # the fast paths hold on this numpy (the module falls back to the buffer protocol and
    # numpy.empty when its checks at import fail)
    assert _ext.NUMPY_IN_PLACE and _ext.NUMPY_C_API
    assert _ext.MODEL_SIZE == ct.sizeof(_lib.RawModel)
    assert _ext.CTC_GAINS_SIZE == ct.sizeof(_lib.RawCtcGains)


def test_kernels_interfaces_match() -> None:
    public = {n for n in dir(_ext.Kernels) if not n.startswith("_")}
    assert public == {n for n in dir(_ctypes_kernels.Kernels) if not n.startswith("_")}
    model_methods = {n for n in dir(rr.Model) if not n.startswith("_")}
    plant = {"plant_step": "step", "plant_accel": "accel"}  # rr.Plant's, on its own state
    assert public - set(plant) <= model_methods
    assert all(hasattr(rr.Plant, m) for m in plant.values())


@pytest.mark.parametrize("name", sorted(SIGNATURES))
@pytest.mark.parametrize("n", [None, 0, 1, 7, 1500])
def test_every_method_is_bit_identical(name: str, n: int | None) -> None:
    kinds = SIGNATURES[name]
    for _ in range(3):
        args = [draw(k, n) for k in kinds]
        if name == "ik_nearest":
            args[1] = draw("q", None)  # one seed
        same_outcome(name, *args)


@pytest.mark.parametrize("name", sorted(n for n, k in SIGNATURES.items()
                                         if len(k) > 1 and n != "ik_nearest"))
def test_broadcast_rows_are_bit_identical(name: str) -> None:
    kinds = SIGNATURES[name]
    for single in range(len(kinds)):  # each argument in turn a single (3,) row, or (1, 3)
        for one in (draw(kinds[single], None), draw(kinds[single], 1)):
            args = [draw(k, 5) for k in kinds]
            args[single] = one
            kind, result = same_outcome(name, *args)
            assert kind == "ok"
            first = result[0] if isinstance(result, tuple) else result
            assert first.shape[0] == 5


def test_model_methods_use_the_extension() -> None:
    q, qd, qdd = (draw(k, 40) for k in ("q", "v", "v"))
    # a batch's scalar path is the extension's row loop (the default: librrr's vector kernels,
    # within 1e-13 N m: tests/python/test_batch.py)
    same_bits(MODEL.inverse_dynamics(q, qd, qdd, simd="scalar"), REF.inverse_dynamics(q, qd, qdd))
    assert np.abs(MODEL.inverse_dynamics(q, qd, qdd) - REF.inverse_dynamics(q, qd, qdd)).max() <= (
        1e-13)
    same_bits(MODEL.regressor(q, qd, qdd, simd="scalar"), REF.regressor(q, qd, qdd))
    same_bits(MODEL.fk(q, simd="scalar"), REF.fk(q))
    same_bits(MODEL.forward_dynamics(q, qd, qdd, simd="scalar"), REF.forward_dynamics(q, qd, qdd))
    same_bits(MODEL.nominal_voltage(q[3], qd[3], qdd[3]), REF.nominal_voltage(q[3], qd[3], qdd[3]))
    x = draw("x", None)
    same_bits(MODEL.ik(x), REF.ik(x))
    assert MODEL.ik_branches(x) == REF.ik_branches(x)
    targets = draw("x", 9)
    for shoulder, s in (("front", 0), ("back", 1)):
        for elbow, e in (("up", 0), ("down", 1)):
            same_bits(MODEL.ik_branch(targets, shoulder, elbow), REF.ik_branch(targets, s, e))
            same_bits(MODEL.ik_branch(x, shoulder, elbow), REF.ik_branch(x, s, e))
    same_bits(MODEL.ik_nearest(targets, q[0]), REF.ik_nearest(targets, q[0]))
    sing = MODEL.singularity(q[0], 1e-3)
    assert sing == rr.Singularity(*REF.singularity(q[0], 1e-3))


def test_single_state_methods_are_bit_identical() -> None:
    for _ in range(50):
        x = draw("x", None)
        same_outcome("ik", x)
        same_outcome("ik_branches", x)
        for s in (0, 1):
            for e in (0, 1):
                same_outcome("ik_branch", x, s, e)
                same_outcome("ik_branch", draw("x", 4), s, e)
        q = draw("q", None)
        for tol in (0.0, 1e-6, 0.5, 2):
            same_outcome("singularity", q, tol)


def test_ik_of_unreachable_and_singular_targets() -> None:
    reach = MODEL.dh["a2"] + MODEL.dh["a3"]
    for x in ([0.0, 0.0, 10.0], [0.0, 0.0, MODEL.dh["d1"]], [reach, 0.0, MODEL.dh["d1"]]):
        for name in ("ik", "ik_branches"):
            same_outcome(name, x)
        same_outcome("ik_branch", x, 1, 1)
        same_outcome("ik_nearest", x, [0.1, 0.2, 0.3])
        same_outcome("workspace_margin", x)
    # a singular configuration: joint_motion refuses it (SingularError), row named
    q = np.array([[0.1, 0.2, 0.3], [0.3, 0.5, 0.0]])
    kind, (cls, msg, *_) = same_outcome("joint_motion", q, np.ones((2, 3)), np.ones((2, 3)))
    assert kind == "error" and cls is rr.SingularError and "sample 1" in msg


CTC_GAINS = [rr.CtcGains.default(), rr.CtcGains((0.0, 3.0, 7.5), (0.0, 0.2, 0.0), False),
             rr.CtcGains((1e6, 1e6, 1e6), (1e3, 0.0, 1.0))]


@pytest.mark.parametrize("gains", CTC_GAINS, ids=["default", "pd", "saturating"])
@pytest.mark.parametrize("n", [None, 1, 6, 1200])
def test_ctc_is_bit_identical(gains: rr.CtcGains, n: int | None) -> None:
    args = [draw(k, n) for k in ("q", "v", "v", "q", "v")]
    kind, result = same_outcome("ctc", gains.packed, *args)
    assert kind == "ok"
    same_bits(MODEL.ctc(gains, *args), result)
    u, u_n, u_c = result
    assert np.all(np.abs(u) <= MODEL.u_max)
    np.testing.assert_allclose(u_c, np.asarray(gains.kp) * (args[0] - args[3])
                               + np.asarray(gains.kd) * (args[1] - args[4]), rtol=1e-12)
    if not gains.feedforward:
        assert not np.any(u_n)


def test_ctc_equals_a_direct_librrr_call() -> None:
    gains = rr.CtcGains.default()
    args = [draw(k, None) for k in ("q", "v", "v", "q", "v")]
    raw_gains = _lib.RawCtcGains.from_buffer_copy(gains.packed)
    out = _lib.RawCtcOutput()
    ptrs = [np.ascontiguousarray(a).ctypes.data for a in args]
    assert _lib.LIB.rrr_ctc(ct.byref(MODEL.raw), ct.byref(raw_gains), *ptrs, ct.byref(out)) == 0
    u, u_n, u_c = MODEL.ctc(gains, *args)
    assert u.tolist() == out.u[:] and u_n.tolist() == out.u_n[:] and u_c.tolist() == out.u_c[:]


def test_ctc_refusals() -> None:
    args = [draw(k, 4) for k in ("q", "v", "v", "q", "v")]
    args[2][3, 0] = np.nan
    kind, (cls, msg, function, status) = same_outcome("ctc", CTC_GAINS[0].packed, *args)
    assert kind == "error" and cls is rr.BadInputError
    assert function == "rrr_ctc" and status == "RRR_BAD_INPUT"
    assert "sample 3: q_ref, qd_ref, qdd_ref, q, qd = " in msg
    same_outcome("ctc", b"short", *args)
    with pytest.raises(rr.BadInputError, match="gains must be a CtcGains"):
        MODEL.ctc((1, 2, 3), *args)  # type: ignore[arg-type]
    for bad in ([1.0, 2.0], [1.0, -1.0, 0.0], [1.0, np.inf, 0.0], "abc"):
        with pytest.raises(rr.BadInputError, match="kp must be 3 finite numbers >= 0"):
            rr.CtcGains(bad, (0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(rr.BadInputError, match="feedforward"):
        rr.CtcGains((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), 1)  # type: ignore[arg-type]


# ---- input kinds ----------------------------------------------------------------------------
def kinds_of(a: np.ndarray) -> list[Any]:
    """The same numbers as many kinds of input: in place (contiguous float64 arrays, buffers of
    doubles, lists of floats) and converted (everything else)."""
    out: list[Any] = [a, a.copy(order="F"), np.asfortranarray(a), a.astype(np.float32),
                      a.astype(">f8"), a.tolist(), np.array(a, copy=True)]
    readonly = a.copy()
    readonly.flags.writeable = False
    out.append(readonly)
    raw = np.empty(a.size * 8 + 1, dtype=np.uint8)[1:].view(np.float64)  # misaligned
    misaligned = raw.reshape(a.shape)
    misaligned[...] = a
    out.append(misaligned)
    wide = np.zeros((*a.shape[:-1], 6))
    wide[..., ::2] = a
    out.append(wide[..., ::2])  # strided, not contiguous
    out.append(memoryview(np.ascontiguousarray(a)))
    if a.ndim == 1:
        out += [tuple(a.tolist()), array.array("d", a.tolist()), (ct.c_double * 3)(*a.tolist())]
    return out


@pytest.mark.parametrize("shape", [(3,), (4, 3)])
def test_every_kind_of_input_gives_the_same_bits(shape: tuple[int, ...]) -> None:
    q = RNG.uniform(-3.0, 3.0, shape)
    qd = RNG.uniform(-3.0, 3.0, shape)
    want = REF.inverse_dynamics(q, qd, qd)
    for kind in kinds_of(q):
        same_outcome("inverse_dynamics", kind, qd, qd)
        if not isinstance(kind, np.ndarray) or kind.dtype == np.float64:
            same_bits(EXT.inverse_dynamics(kind, qd, qd), want)
    ints = [1, -2, 3]
    same_outcome("fk", ints)
    same_outcome("fk", np.array(ints))
    same_outcome("fk", [True, False, True])
    same_outcome("fk", [1, 2.5, 10**30])
    same_outcome("fk", [1, 2.5, 10**400])  # OverflowError, as numpy raises it
    same_outcome("fk", q.view(_Subclass))  # an ndarray subclass is read in place too


class _Subclass(np.ndarray):
    pass


BAD_INPUTS: list[Any] = [
    "abc", None, {"a": 1}, [1j, 0, 0], np.array([1j, 0, 0]), [0.1, 0.2], np.zeros((2, 2, 3)),
    np.zeros(()), np.zeros((3, 1)), [[0.1, 0.2, 0.3], [0.1, 0.2]], [0.1, "x", 0.3], b"abcdefgh",
    [0.1, np.nan, 0.3], [np.inf, 0, 0], np.zeros((0, 3)), object(), 3.0,
]


@pytest.mark.parametrize("name", sorted({**SIGNATURES, **SINGLE_ONLY}))
def test_refusals_are_identical(name: str) -> None:
    kinds = {**SIGNATURES, **SINGLE_ONLY}[name]
    for bad in BAD_INPUTS:
        for pos in range(len(kinds)):
            args: list[Any] = [draw(k, None) for k in kinds]
            args[pos] = bad
            same_outcome(name, *args)
    if name in SINGLE_ONLY:
        same_outcome(name, draw("x", 2))
        same_outcome(name, draw("x", 1))
    elif name != "ik_nearest":
        for bad in (np.nan, np.inf, -np.inf):  # a bad row in a batch (and in a broadcast row)
            args = [draw(k, 6) for k in kinds]
            args[-1][4, 1] = bad
            kind, (cls, msg, *_) = same_outcome(name, *args)
            assert kind == "error" and cls is rr.BadInputError and "sample 4" in msg
            args[-1] = args[-1][4]
            same_outcome(name, *args)
        if len(kinds) > 1:  # mismatched batches
            same_outcome(name, *[draw(k, 2 + i) for i, k in enumerate(kinds)])
            same_outcome(name, *[draw(k, 0 if i == 0 else 3) for i, k in enumerate(kinds)])


def test_single_only_refusals_are_identical() -> None:
    q = draw("q", None)
    for tol in ("x", float("nan"), float("inf"), None, "1e-3", -1.0, [1.0], 10**400):
        same_outcome("singularity", q, tol)
    same_outcome("singularity", draw("q", 3), 1e-6)
    same_outcome("singularity", [np.nan, 0, 0], 1e-6)
    same_outcome("singularity", "abc", float("nan"))  # q's error comes first
    x = draw("x", 5)
    same_outcome("ik_nearest", x, draw("q", 2))
    same_outcome("ik_nearest", x, [1e7, 0.0, 0.0])
    same_outcome("ik_nearest", x, [np.nan, 0.0, 0.0])
    x[3] = [0.0, 0.0, 10.0]
    kind, (cls, msg, *_) = same_outcome("ik_nearest", x, [0.0, 0.0, 0.0])
    assert kind == "error" and cls is rr.UnreachableError
    assert "sample 3: x = [0.0, 0.0, 10.0]" in msg
    for s, e in ((2, 0), (0, -1)):
        with pytest.raises(rr.BadInputError, match="posture indices"):
            EXT.ik_branch(x, s, e)
    with pytest.raises(TypeError):
        EXT.fk()  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        _ext.Kernels(bytearray(8))  # type: ignore[arg-type]


def test_nominal_voltage_reports_like_its_two_steps() -> None:
    q, qd, qdd = (draw(k, 5) for k in ("q", "v", "v"))
    qdd[2, 0] = np.nan
    kind, (cls, msg, function, _) = same_outcome("nominal_voltage", q, qd, qdd)
    assert kind == "error" and cls is rr.BadInputError and function == "rrr_inverse_dynamics"
    assert "sample 2: q, qd, qdd" in msg


# ---- in place, without copies; without the GIL -------------------------------------------------
def test_contiguous_float64_input_is_not_copied() -> None:
    n = 200_000
    q, qd, qdd = (RNG.uniform(-1.0, 1.0, (n, 3)) for _ in range(3))
    out_bytes = n * 3 * 8
    MODEL.inverse_dynamics(q, qd, qdd)
    tracemalloc.start()
    try:
        tau = MODEL.inverse_dynamics(q, qd, qdd)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert tau.shape == (n, 3)
    assert peak < 1.2 * out_bytes  # the result only: no input was copied
    tracemalloc.start()
    try:
        MODEL.inverse_dynamics(q.astype(np.float32), qd, qdd)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak > 1.9 * out_bytes  # float32 is converted (and the measurement sees copies)


@pytest.mark.parametrize(("rows", "released"), [(_ext.NOGIL_ROWS - 1, False),
                                                 (400_000, True)])
def test_large_batches_release_the_gil(rows: int, released: bool) -> None:
    """With a switch interval of 100 s, the main thread runs while the worker is inside the
    batch only if the batch released the GIL (the extension's row loop: simd="scalar"; the
    batch kernels' ctypes call always releases it)."""
    q = RNG.uniform(-1.0, 1.0, (rows, 3))
    started, state = threading.Event(), {"done": False, "seen_running": None}

    def worker() -> None:
        started.set()
        MODEL.inverse_dynamics(q, q, q, simd="scalar")
        state["done"] = True

    old = sys.getswitchinterval()
    sys.setswitchinterval(100.0)
    try:
        t = threading.Thread(target=worker)
        t.start()
        started.wait()
        state["seen_running"] = not state["done"]
        t.join()
    finally:
        sys.setswitchinterval(old)
    assert state["seen_running"] is released


def test_batches_from_threads_are_correct() -> None:
    q, qd, qdd = (RNG.uniform(-2.0, 2.0, (30_000, 3)) for _ in range(3))
    want = REF.inverse_dynamics(q[:2000], qd[:2000], qdd[:2000])
    results: list[np.ndarray] = []

    vector: list[np.ndarray] = []

    def worker() -> None:
        for _ in range(5):
            results.append(MODEL.inverse_dynamics(q, qd, qdd, simd="scalar"))  # the extension
            vector.append(MODEL.inverse_dynamics(q, qd, qdd))  # librrr's batch call (ctypes)

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(results) == 20 and len(vector) == 20
    for r in results:
        same_bits(r[:2000], want)
        assert r.tobytes() == results[0].tobytes()
    for v in vector:
        assert v.tobytes() == vector[0].tobytes()
    assert np.abs(vector[0] - results[0]).max() <= 1e-13


def test_the_model_struct_is_read_in_place() -> None:
    m = MODEL.copy()
    q = draw("q", None)
    before = m.gravity(q)
    m.raw.g = 2.0 * m.raw.g  # the Kernels read the ctypes struct, not a copy
    np.testing.assert_allclose(m.gravity(q), 2.0 * before, rtol=1e-12)
    same_bits(m.gravity(q), _ctypes_kernels.Kernels(m.raw).gravity(q))


def test_without_the_extension_model_uses_ctypes(tmp_path: Path) -> None:
    """A package built without the Python headers has no _ext: Model falls back to the ctypes
    binding (with a warning), with the same results."""
    package = Path(rr.__file__).parent
    shutil.copytree(package, tmp_path / "rrr_robot",
                    ignore=shutil.ignore_patterns("__pycache__", "_ext.*"))
    code = ("import rrr_robot as rr\n"
            "from rrr_robot.core import model\n"
            "tau = rr.Model.default().inverse_dynamics([0.1, 0.2, 0.3], [0.4, 0.5, 0.6],"
            " [0.7, 0.8, 0.9])\n"
            "print(model.BINDING, tau.tobytes().hex())\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    binding, tau = run.stdout.split()
    assert binding == "ctypes"
    assert "rrr_robot.core._ext is not installed" in run.stderr
    want = MODEL.inverse_dynamics([0.1, 0.2, 0.3], [0.4, 0.5, 0.6], [0.7, 0.8, 0.9])
    assert bytes.fromhex(tau) == want.tobytes()
