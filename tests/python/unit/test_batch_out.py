"""``out=`` of the batch methods (inverse dynamics, regressor, FK, forward dynamics, IK on a
posture): the result written into the caller's array, bit for bit the new array's, on every path
and through the binding's own methods; every kind of bad ``out`` refused with a BadInputError
before anything is written; a failing row raising its error with the rows before it in ``out``;
and the ``simd`` names the binding takes directly."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core import batch

N = 517  # not a multiple of a vector's 4 or 8 states


@pytest.fixture(scope="module")
def states() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(11)
    return (rng.uniform(-np.pi, np.pi, (N, 3)), rng.uniform(-5, 5, (N, 3)),
            rng.uniform(-20, 20, (N, 3)))


Call = Callable[..., Any]


def calls(model: rr.Model, states: tuple[np.ndarray, ...]) -> dict[str, tuple[Call, tuple]]:
    q, qd, qdd = states
    x = model.fk(q, simd="scalar")[0]
    tau = model.inverse_dynamics(q, qd, qdd, simd="scalar")
    return {
        "inverse_dynamics": (model.inverse_dynamics, (q, qd, qdd)),
        "regressor": (model.regressor, (q, qd, qdd)),
        "forward_dynamics": (model.forward_dynamics, (q, qd, tau)),
        "ik": (lambda *a, **kw: model.ik(a[0], "back", "down", *a[1:], **kw), (x,)),
    }


def empty_like_result(result: Any) -> Any:
    if isinstance(result, tuple):
        return tuple(np.full_like(r, np.nan) for r in result)
    return np.full_like(result, np.nan)


def same(a: Any, b: Any) -> bool:
    if isinstance(a, tuple):
        return all(x.tobytes() == y.tobytes() for x, y in zip(a, b, strict=True))
    return bool(a.tobytes() == b.tobytes())


@pytest.mark.parametrize("simd", ["auto", "scalar", "avx2", "avx512"])
@pytest.mark.parametrize("name", ["inverse_dynamics", "regressor", "forward_dynamics", "ik",
                                  "fk"])
def test_out_holds_the_new_arrays_result_bit_for_bit(model, states, name: str, simd: str) -> None:
    if name == "fk":
        f: Call = model.fk
        args: tuple = (states[0],)
    else:
        f, args = calls(model, states)[name]
    if simd not in batch.simd_available():  # refused, with or without out
        with pytest.raises(rr.BadInputError, match="not available here"):
            f(*args, simd=simd, out=empty_like_result(f(*args)))
        return
    for rows in (args, tuple(a[0] for a in args)):  # a batch, and one state
        want = f(*rows, simd=simd)
        out = empty_like_result(want)
        got = f(*rows, simd=simd, out=out)
        if isinstance(out, tuple):
            assert isinstance(got, tuple) and all(g is o for g, o in zip(got, out, strict=True))
        else:
            assert got is out
        assert same(out, want)


@pytest.mark.parametrize("name", ["inverse_dynamics", "regressor", "forward_dynamics", "ik"])
def test_the_binding_writes_the_new_arrays_bits_into_out(model, states, name: str) -> None:
    ext = model._k
    args = calls(model, states)[name][1]
    post = (1, 1) if name == "ik" else ()  # ik_branch(x, shoulder, elbow, ...)
    method = "ik_branch" if name == "ik" else name
    want = getattr(ext, method)(*args, *post, "auto")
    out = np.full_like(want, np.nan)
    assert getattr(ext, method)(*args, *post, "auto", out) is out
    assert out.tobytes() == want.tobytes()


def bad_outs(q: np.ndarray) -> dict[str, object]:
    read_only = np.empty((N, 3))
    read_only.flags.writeable = False
    return {
        "a wrong shape": np.empty((N, 4)),
        "too few rows": np.empty((N - 1, 3)),
        "one state's shape for a batch": np.empty(3),
        "float32": np.empty((N, 3), dtype=np.float32),
        "big-endian float64": np.empty((N, 3), dtype=">f8"),
        "Fortran order": np.asfortranarray(np.empty((N, 3))),
        "a strided view": np.empty((2 * N, 3))[::2],
        "read-only": read_only,
        "a list": [[0.0] * 3] * N,
        "an input": q,
        "a view of an input": q[:, :],
    }


def test_a_bad_out_is_refused_and_left_as_it_was(model, states) -> None:
    q, qd, qdd = states
    kernels = model._k
    for why, bad in bad_outs(q).items():
        before = np.array(bad, copy=True)
        with pytest.raises(rr.BadInputError, match="inverse_dynamics: out") as err:
            kernels.inverse_dynamics(q, qd, qdd, "auto", bad)
        assert "out" in str(err.value), why
        assert np.asarray(bad).tobytes() == before.tobytes(), f"{why}: written"
    # fk's out is a pair (x, R): of two distinct arrays of the right shapes
    x, rot = np.empty((N, 3)), np.empty((N, 3, 3))
    overlapping = (rot.reshape(-1)[: 3 * N].reshape(N, 3), rot)
    for bad in (x, (x, x), (x, rot, rot), [x, rot], overlapping):
        with pytest.raises(rr.BadInputError, match="fk: "):
            kernels.fk(q, "auto", bad)


def test_a_model_method_refuses_out_where_the_shape_is_unknown(model, states) -> None:
    x = model.fk(states[0][0])[0]
    with pytest.raises(rr.BadInputError, match="out needs a posture"):
        model.ik(x, out=np.empty((4, 3)))


@pytest.mark.parametrize("simd", ["auto", "scalar"])
def test_a_failing_row_raises_with_the_rows_before_it_in_out(model, states, simd: str) -> None:
    q, qd, qdd = (a.copy() for a in states)
    qdd[300, 2] = np.inf
    out = np.full((N, 3), np.nan)
    with pytest.raises(rr.BadInputError, match="300"):
        model.inverse_dynamics(q, qd, qdd, simd=simd, out=out)
    want = model.inverse_dynamics(*states, simd=simd)  # the same rows at the same places
    assert out[:300].tobytes() == want[:300].tobytes()


def test_the_binding_takes_simd_names_and_refuses_others(model, states) -> None:
    kernels = model._k
    want = model.inverse_dynamics(*states, simd="scalar")
    # "auto" as a string that is not the interned literal finds the same path
    auto = "".join(["au", "to"])
    assert kernels.inverse_dynamics(*states, auto).tobytes() == model.inverse_dynamics(
        *states).tobytes()
    assert kernels.inverse_dynamics(*states, "scalar").tobytes() == want.tobytes()
    for bad in ("AUTO", "sse", 1.0, None, b"auto"):
        with pytest.raises(rr.BadInputError, match="simd must be one of"):
            kernels.inverse_dynamics(*states, bad)
    for missing in ("avx2", "avx512"):
        if missing not in batch.simd_available():
            with pytest.raises(rr.BadInputError, match="not available here"):
                kernels.inverse_dynamics(*states, missing)
