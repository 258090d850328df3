"""The compiled binding rrr_robot.core._ext, the one way the package reaches librrr: a batch is its
rows' one-state calls bit for bit (single states, batches, broadcast rows, every kind of input);
inputs are refused as ``_arrays.as_rows`` refuses them and a failing row raises its status's
exception naming the row; contiguous float64 input is read in place; large batches run without
the GIL; the module's functions refuse structs of the wrong size; and a package without the
module fails to import, saying what is missing."""

from __future__ import annotations

import array
import ctypes as ct
import os
import re
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
from rrr_robot.core import _arrays, _ext, _lib

RNG = np.random.default_rng(20261130)
MODEL = rr.Model.default()
EXT = _ext.Kernels(MODEL.raw)

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
# the argument names in the messages
NAMES: dict[str, tuple[str, ...]] = {
    "tip_motion": ("q", "qd", "qdd"), "joint_motion": ("q", "xd", "xdd"), "ik_nearest": ("x",
    "q_prev"), "regressor": ("q", "qd", "qdd"), "inverse_dynamics": ("q", "qd", "qdd"),
    "coriolis": ("q", "qd"), "forward_dynamics": ("q", "qd", "tau"), "energy": ("q", "qd"),
    "friction": ("qd",), "voltage_from_torque": ("qd", "tau"), "torque_from_voltage": ("qd", "u"),
    "nominal_voltage": ("q", "qd", "qdd"), "plant_jacobian": ("q", "qd", "u"),
    "workspace_margin": ("x",), "ik": ("x",), "ik_branches": ("x",),
}


def names_of(name: str) -> tuple[str, ...]:
    return NAMES.get(name, ("q",))


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


def stack(results: list[Any], template: Any) -> Any:
    """The rows' one-state results as one batch result (template: one row's result)."""
    if isinstance(template, tuple):
        return tuple(stack([r[k] for r in results], t) for k, t in enumerate(template))
    if isinstance(template, float):
        return np.array(results, dtype=np.float64)
    return np.array(results, dtype=np.float64).reshape(len(results), *np.shape(template))


def by_rows(name: str, *args: Any) -> tuple[str, Any]:
    """What a call must give: its arguments refused in order as _arrays.as_rows refuses them,
    batches broadcast, then the one-state call on each row (a failing row raising that call's
    error, with the row's index)."""
    names = names_of(name)
    try:
        parsed = [_arrays.as_rows(a, n) for a, n in zip(args, names, strict=True)]
    except Exception as exc:
        return "error", (type(exc), str(exc), getattr(exc, "function", None),
                         getattr(exc, "status", None))
    if not any(batch for _, batch in parsed):
        return outcome(getattr(EXT, name), *[rows[0] for rows, _ in parsed])
    n = max(rows.shape[0] for rows, _ in parsed)
    for (rows, _), arg in zip(parsed, names, strict=True):
        if rows.shape[0] not in (1, n):
            return "error", (rr.BadInputError, f"{arg} has {rows.shape[0]} rows, expected {n}",
                             "", "")
    results = []
    for i in range(n):
        kind, result = outcome(getattr(EXT, name),
                               *[rows[0 if rows.shape[0] == 1 else i] for rows, _ in parsed])
        if kind == "error":
            cls, msg, function, status = result
            return "error", (cls, msg.replace("sample 0:", f"sample {i}:"), function, status)
        results.append(result)
    template = getattr(EXT, name)(*[draw(k, None) for k in SIGNATURES[name]])
    return "ok", stack(results, template)


def same_outcome(name: str, *args: Any) -> tuple[str, Any]:
    got, want = outcome(getattr(EXT, name), *args), by_rows(name, *args)
    assert got[0] == want[0], (name, args, got, want)
    if got[0] == "ok":
        same_bits(got[1], want[1])
    else:
        assert got[1] == want[1], (name, args)
    return got


def test_the_extension_is_the_binding() -> None:
    assert isinstance(MODEL._k, _ext.Kernels)
    assert re.search(r"_ext\.(abi3\.so|pyd)$", _ext.__file__), _ext.__file__  # stable ABI
    for name, mirror in _lib._MIRRORS.items():
        assert _ext.SIZES[name] == ct.sizeof(mirror), name
    assert _ext.VERSION == rr.__version__
    assert _ext.NP == _lib.NP == 16


def test_kernels_mirror_the_model_and_the_plant() -> None:
    public = {n for n in dir(_ext.Kernels) if not n.startswith("_")}
    model_methods = {n for n in dir(rr.Model) if not n.startswith("_")}
    plant = {"plant_step": "step", "plant_accel": "accel", "plant_rollout": "rollout"}
    assert public - set(plant) <= model_methods
    assert all(hasattr(rr.Plant, m) for m in plant.values())


@pytest.mark.parametrize("name", sorted(n for n in SIGNATURES if n != "ik_nearest"))
@pytest.mark.parametrize("n", [None, 0, 1, 7, 1500])
def test_every_method_is_its_rows_bit_for_bit(name: str, n: int | None) -> None:
    kinds = SIGNATURES[name]
    for _ in range(3):
        same_outcome(name, *[draw(k, n) for k in kinds])


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
            full = list(args)
            full[single] = np.repeat(np.reshape(one, (1, 3)), 5, axis=0)
            same_bits(getattr(EXT, name)(*full), result)


def test_ik_nearest_seeds_each_row_with_the_last() -> None:
    x = draw("x", 9)
    seed = draw("q", None)
    q = EXT.ik_nearest(x, seed)
    prev = seed
    for i in range(9):
        same_bits(q[i], EXT.ik_nearest(x[i], prev))
        prev = q[i]


def test_model_methods_use_the_extension() -> None:
    q, qd, qdd = (draw(k, 40) for k in ("q", "v", "v"))
    # a batch's scalar path is the extension's row loop (the default: librrr's vector kernels,
    # within 1e-13 N m: tests/python/unit/test_batch.py)
    same_bits(MODEL.inverse_dynamics(q, qd, qdd, simd="scalar"), EXT.inverse_dynamics(q, qd, qdd))
    assert np.abs(MODEL.inverse_dynamics(q, qd, qdd) - EXT.inverse_dynamics(q, qd, qdd)).max() <= (
        1e-13)
    same_bits(MODEL.regressor(q, qd, qdd, simd="scalar"), EXT.regressor(q, qd, qdd))
    same_bits(MODEL.fk(q, simd="scalar"), EXT.fk(q))
    same_bits(MODEL.forward_dynamics(q, qd, qdd, simd="scalar"), EXT.forward_dynamics(q, qd, qdd))
    same_bits(MODEL.nominal_voltage(q[3], qd[3], qdd[3]),
              MODEL.voltage_from_torque(qd[3], MODEL.inverse_dynamics(q[3], qd[3], qdd[3])))
    x = draw("x", None)
    same_bits(MODEL.ik(x), EXT.ik(x))
    assert MODEL.ik_branches(x) == EXT.ik_branches(x)
    targets = draw("x", 9)
    for k, (shoulder, elbow) in enumerate((("front", "up"), ("front", "down"), ("back", "up"),
                                           ("back", "down"))):
        rows = np.array([EXT.ik_branch(t, k // 2, k % 2) for t in targets])
        same_bits(MODEL.ik_branch(targets, shoulder, elbow), rows)
        same_bits(MODEL.ik_branch(x, shoulder, elbow), EXT.ik_branch(x, k // 2, k % 2))
    same_bits(MODEL.ik_nearest(targets, q[0]), EXT.ik_nearest(targets, q[0]))
    sing = MODEL.singularity(q[0], 1e-3)
    assert sing == rr.Singularity(*EXT.singularity(q[0], 1e-3))


def test_ik_gives_every_branch_in_order() -> None:
    for _ in range(50):
        x = draw("x", None)
        sols = EXT.ik(x)
        branches = EXT.ik_branches(x)
        assert sols.shape == (len(branches), 3) and 1 <= len(branches) <= 4
        index = {("front", "up"): (0, 0), ("front", "down"): (0, 1), ("back", "up"): (1, 0),
                 ("back", "down"): (1, 1)}
        assert [index[b] for b in branches] == sorted(index[b] for b in branches)
        for q, b in zip(sols, branches, strict=True):
            same_bits(q, EXT.ik_branch(x, *index[b]))
        q = draw("q", None)
        for tol in (0.0, 1e-6, 0.5, 2):
            stretched, folded, shoulder, *margins = EXT.singularity(q, tol)
            assert all(isinstance(f, bool) for f in (stretched, folded, shoulder))
            assert all(isinstance(v, float) for v in margins)


def test_ik_of_unreachable_and_singular_targets() -> None:
    reach = MODEL.dh["a2"] + MODEL.dh["a3"]
    for x in ([0.0, 0.0, 10.0], [0.0, 0.0, MODEL.dh["d1"]], [reach, 0.0, MODEL.dh["d1"]]):
        for name in ("ik", "ik_branches"):
            kind, result = outcome(getattr(EXT, name), x)
            assert kind == "ok" or result[0] in (rr.UnreachableError, rr.SingularError)
        same_outcome("workspace_margin", x)
    with pytest.raises(rr.UnreachableError, match=r"rrr_ik failed with RRR_UNREACHABLE .*: "
                                                   r"x = \[0\.0, 0\.0, 10\.0\]"):
        EXT.ik([0.0, 0.0, 10.0])
    # a singular configuration: joint_motion refuses it (SingularError), row named
    q = np.array([[0.1, 0.2, 0.3], [0.3, 0.5, 0.0]])
    kind, (cls, msg, *_) = same_outcome("joint_motion", q, np.ones((2, 3)), np.ones((2, 3)))
    assert kind == "error" and cls is rr.SingularError and "sample 1" in msg


CTC_GAINS = [rr.CtcGains.default(), rr.CtcGains((0.0, 3.0, 7.5), (0.0, 0.2, 0.0), False),
             rr.CtcGains((1e6, 1e6, 1e6), (1e3, 0.0, 1.0))]


@pytest.mark.parametrize("gains", CTC_GAINS, ids=["default", "pd", "saturating"])
@pytest.mark.parametrize("n", [None, 1, 6, 1200])
def test_ctc_is_its_rows_bit_for_bit(gains: rr.CtcGains, n: int | None) -> None:
    args = [draw(k, n) for k in ("q", "v", "v", "q", "v")]
    result = EXT.ctc(gains.packed, *args)
    same_bits(MODEL.ctc(gains, *args), result)
    if n is not None:
        rows = [EXT.ctc(gains.packed, *[a[i] for a in args]) for i in range(n)]
        same_bits(result, tuple(np.array([r[k] for r in rows]).reshape(n, 3) for k in range(3)))
    u, u_n, u_c = result
    assert np.all(np.abs(u) <= MODEL.u_max)
    np.testing.assert_allclose(u_c, np.asarray(gains.kp) * (args[0] - args[3])
                               + np.asarray(gains.kd) * (args[1] - args[4]), rtol=1e-12)
    if not gains.feedforward:
        assert not np.any(u_n)
    else:  # u_n: the feedforward of eq 10 along the reference
        np.testing.assert_allclose(u_n, MODEL.nominal_voltage(*args[:3]), rtol=1e-12)


def test_ctc_refusals() -> None:
    args = [draw(k, 4) for k in ("q", "v", "v", "q", "v")]
    args[2][3, 0] = np.nan
    with pytest.raises(rr.BadInputError) as err:
        EXT.ctc(CTC_GAINS[0].packed, *args)
    assert err.value.function == "rrr_ctc" and err.value.status == "RRR_BAD_INPUT"
    assert "sample 3: q_ref, qd_ref, qdd_ref, q, qd = " in str(err.value)
    with pytest.raises(TypeError, match="ctc needs the 56 bytes of an rrr_ctc_gains"):
        EXT.ctc(b"short", *args)
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
    want = EXT.inverse_dynamics(q, qd, qd)
    for kind in kinds_of(q):
        same_outcome("inverse_dynamics", kind, qd, qd)
        if not isinstance(kind, np.ndarray) or kind.dtype == np.float64:
            same_bits(EXT.inverse_dynamics(kind, qd, qd), want)
    ints = [1, -2, 3]
    same_bits(EXT.fk(ints), EXT.fk(np.array(ints, dtype=np.float64)))
    same_outcome("fk", np.array(ints))
    same_bits(EXT.fk([True, False, True]), EXT.fk([1.0, 0.0, 1.0]))
    same_outcome("fk", [1, 2.5, 10**30])
    with pytest.raises(OverflowError):  # as numpy raises it
        EXT.fk([1, 2.5, 10**400])
    same_bits(EXT.fk(q.view(_Subclass)), EXT.fk(q))  # an ndarray subclass is read in place too


class _Subclass(np.ndarray):
    pass


BAD_INPUTS: list[Any] = [
    "abc", None, {"a": 1}, [1j, 0, 0], np.array([1j, 0, 0]), [0.1, 0.2], np.zeros((2, 2, 3)),
    np.zeros(()), np.zeros((3, 1)), [[0.1, 0.2, 0.3], [0.1, 0.2]], [0.1, "x", 0.3], b"abcdefgh",
    [0.1, np.nan, 0.3], [np.inf, 0, 0], np.zeros((0, 3)), object(), 3.0,
]


@pytest.mark.parametrize("name", sorted({**SIGNATURES, **SINGLE_ONLY}))
def test_refusals_name_the_argument_and_the_row(name: str) -> None:
    kinds = {**SIGNATURES, **SINGLE_ONLY}[name]
    for bad in BAD_INPUTS:
        for pos in range(len(kinds)):
            args: list[Any] = [draw(k, None) for k in kinds]
            args[pos] = bad
            kind, result = outcome(getattr(EXT, name), *args)
            try:  # what as_rows says of it, if anything
                _arrays.as_rows(bad, names_of(name)[pos])
            except Exception as exc:
                assert kind == "error" and result[:2] == (type(exc), str(exc)), (name, bad)
                continue
            if name in SINGLE_ONLY or name == "ik_nearest":
                continue  # their own rules below
            same_outcome(name, *args)
    if name in SINGLE_ONLY:
        with pytest.raises(rr.BadInputError, match="takes one target"):
            getattr(EXT, name)(draw("x", 2))
        with pytest.raises(rr.BadInputError, match="takes one target"):
            getattr(EXT, name)(draw("x", 1))
    elif name != "ik_nearest":
        for bad in (np.nan, np.inf, -np.inf):  # a bad row in a batch (and in a broadcast row)
            args = [draw(k, 6) for k in kinds]
            args[-1][4, 1] = bad
            kind, (cls, msg, function, status) = same_outcome(name, *args)
            assert kind == "error" and cls is rr.BadInputError and "sample 4" in msg
            assert status == "RRR_BAD_INPUT" and msg.startswith(f"{function} failed with ")
            args[-1] = args[-1][4]
            kind, (cls, msg, *_) = same_outcome(name, *args)
            assert kind == "error" and "sample 0" in msg
        if len(kinds) > 1:  # mismatched batches
            kind, (cls, msg, *_) = same_outcome(name, *[draw(k, 2 + i)
                                                        for i, k in enumerate(kinds)])
            assert kind == "error" and cls is rr.BadInputError and "rows, expected" in msg
            same_outcome(name, *[draw(k, 0 if i == 0 else 3) for i, k in enumerate(kinds)])


def test_single_only_refusals() -> None:
    q = draw("q", None)
    for tol in ("x", float("nan"), float("inf"), None, [1.0]):
        with pytest.raises(rr.BadInputError, match="tol must be a finite number, got "):
            EXT.singularity(q, tol)
    assert EXT.singularity(q, "1e-3") == EXT.singularity(q, 1e-3)  # read as float() reads it
    with pytest.raises(rr.BadInputError, match="rrr_singularity_classify failed with "
                                                "RRR_BAD_INPUT"):
        EXT.singularity(q, -1.0)
    with pytest.raises(OverflowError):  # as float() raises it
        EXT.singularity(q, 10**400)
    with pytest.raises(rr.BadInputError, match="singularity takes one configuration"):
        EXT.singularity(draw("q", 3), 1e-6)
    with pytest.raises(rr.BadInputError, match=r"rrr_singularity_classify failed .*q = "
                                                r"\[nan, 0\.0, 0\.0\]"):
        EXT.singularity([np.nan, 0, 0], 1e-6)
    with pytest.raises(rr.BadInputError, match="q must be an array of numbers"):
        EXT.singularity("abc", float("nan"))  # q's error comes first
    x = draw("x", 5)
    with pytest.raises(rr.BadInputError, match=r"q_prev must have shape \(3,\)"):
        EXT.ik_nearest(x, draw("q", 2))
    for seed in ([1e7, 0.0, 0.0], [np.nan, 0.0, 0.0]):  # a seed librrr refuses: row 0 named
        with pytest.raises(rr.BadInputError, match="rrr_ik_nearest failed with RRR_BAD_INPUT "
                                                    r".*: sample 0: x = \["):
            EXT.ik_nearest(x, seed)
    x[3] = [0.0, 0.0, 10.0]
    with pytest.raises(rr.UnreachableError, match=r"sample 3: x = \[0\.0, 0\.0, 10\.0\]"):
        EXT.ik_nearest(x, [0.0, 0.0, 0.0])
    for s, e in ((2, 0), (0, -1)):
        with pytest.raises(rr.BadInputError, match="posture indices"):
            EXT.ik_branch(x, s, e)
    with pytest.raises(TypeError):
        EXT.fk()  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="Kernels needs an aligned rrr_model"):
        _ext.Kernels(bytearray(8))  # type: ignore[arg-type]


def test_nominal_voltage_reports_like_its_two_steps() -> None:
    q, qd, qdd = (draw(k, 5) for k in ("q", "v", "v"))
    qdd[2, 0] = np.nan
    with pytest.raises(rr.BadInputError) as err:
        EXT.nominal_voltage(q, qd, qdd)
    assert err.value.function == "rrr_inverse_dynamics"
    assert "sample 2: q, qd, qdd" in str(err.value)


# ---- the module's functions on the structs of _lib -----------------------------------------------
def test_the_module_functions_refuse_structs_of_another_size() -> None:
    raw = MODEL.raw
    with pytest.raises(TypeError, match=r"needs the 376 bytes of an rrr_model"):
        _ext.model_validate(bytes(8))
    with pytest.raises(TypeError, match="writable rrr_model"):
        _ext.model_default(bytes(ct.sizeof(raw)))  # read-only
    with pytest.raises(TypeError, match="writable rrr_ctc_gains"):
        _ext.ctc_gains_default(_lib.RawPlantState())
    with pytest.raises(rr.BadInputError, match="bps_from_inertia: p must be a"):
        _ext.bps_from_inertia(raw, _lib.RawInertial(), np.zeros(15))
    with pytest.raises(rr.BadInputError, match="plant_state_init takes one q0"):
        _ext.plant_state_init(np.zeros((2, 3)), np.zeros(3), _lib.RawPlantState())
    with pytest.raises(rr.BadInputError, match=r"rrr_plant_state_init failed .*q0 = \[nan"):
        _ext.plant_state_init([np.nan, 0, 0], [0, 0, 0], _lib.RawPlantState())
    assert _ext.model_validate(raw) == (0, "")
    bad = _lib.RawModel.from_buffer_copy(raw)
    bad.kt[1] = -1.0
    assert _ext.model_validate(bad) == (2, "kt[2]")
    assert _ext.param_index("f[2,3]") == _lib.param_index("f[2,3]") >= 0
    assert _lib.param_index("nope") == _lib.param_index("p[1]\0") == _lib.param_index("\ud800") \
        == -1
    assert np.isnan(_ext.param_get(raw, 10**6)) and np.isnan(_ext.param_get(raw, -1))
    assert _ext.param_set(_lib.RawModel(), 10**6, 1.0) == 1  # RRR_BAD_INPUT
    with pytest.raises(rr.BadInputError, match=r"rrr_param_set failed .*row 0 = nan"):
        _lib.param_set(_lib.RawModel(), 0, float("nan"))


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
    batch only if the batch released the GIL (the extension's row loop: simd="scalar")."""
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
    want = np.array([EXT.inverse_dynamics(q[i], qd[i], qdd[i]) for i in range(2000)])
    results: list[np.ndarray] = []

    vector: list[np.ndarray] = []

    def worker() -> None:
        for _ in range(5):
            results.append(MODEL.inverse_dynamics(q, qd, qdd, simd="scalar"))  # the row loop
            vector.append(MODEL.inverse_dynamics(q, qd, qdd))  # librrr's batch kernels

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
    same_bits(m.gravity(q), _ext.Kernels(m.raw).gravity(q))


def test_without_the_extension_the_package_says_what_is_missing(tmp_path: Path) -> None:
    """A package without _ext (a source tree on sys.path, a broken install) fails to import
    its model, naming the module and how to build it: there is no other binding."""
    package = Path(rr.__file__).parent
    shutil.copytree(package, tmp_path / "rrr_robot",
                    ignore=shutil.ignore_patterns("__pycache__", "_ext.*"))
    code = "import rrr_robot as rr\nrr.Model.default()\n"
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=False)
    assert run.returncode != 0
    assert "ImportError: rrr_robot.core._ext, the compiled binding of librrr, is missing" in (
        run.stderr)
    assert "pip install ." in run.stderr and "python3-dev" in run.stderr
