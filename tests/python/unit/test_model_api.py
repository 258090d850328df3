"""The Python API of Model, under property tests (hypothesis): batches are handled row by row
or refused (never reduced to their first row), finite input never gives a non-finite output,
and misuse raises the package's own exceptions."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

MODEL = rr.Model.default()

# methods with their argument names: every (3,) argument may be an (n, 3) batch
BATCH_METHODS: dict[str, tuple[str, ...]] = {
    "fk": ("q",),
    "jacobian": ("q",),
    "tip_motion": ("q", "qd", "qdd"),
    "regressor": ("q", "qd", "qdd"),
    "inverse_dynamics": ("q", "qd", "qdd"),
    "mass_matrix": ("q",),
    "coriolis": ("q", "qd"),
    "gravity": ("q",),
    "forward_dynamics": ("q", "qd", "tau"),
    "energy": ("q", "qd"),
    "friction": ("qd",),
    "voltage_from_torque": ("qd", "tau"),
    "torque_from_voltage": ("qd", "u"),
    "nominal_voltage": ("q", "qd", "qdd"),
    "workspace_margin": ("x",),
}
ONE_ONLY = {"ik": ("x",), "ik_branches": ("x",), "singularity": ("q",)}

moderate = st.floats(-4.0, 4.0, allow_nan=False, allow_infinity=False)
any_finite = st.floats(allow_nan=False, allow_infinity=False)
states = arrays(np.float64, (5, 3), elements=moderate)


# the methods with batch kernels: bit for bit the rows on their scalar path (their vector
# kernels are within 1e-13 of it: test_batch.py)
SIMD_METHODS = {"fk", "regressor", "inverse_dynamics", "forward_dynamics"}


def call(name: str, args: list[Any]) -> Any:
    if name in SIMD_METHODS:
        return getattr(MODEL, name)(*args, simd="scalar")
    return getattr(MODEL, name)(*args)


def leaves(result: Any) -> list[np.ndarray]:
    if isinstance(result, tuple):
        return [np.asarray(r, dtype=float) for r in result]
    return [np.asarray(result, dtype=float)]


@pytest.mark.parametrize("name", sorted(BATCH_METHODS))
@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_batch_equals_row_by_row(name: str, data: st.DataObject) -> None:
    n_args = len(BATCH_METHODS[name])
    batch = [data.draw(states) for _ in range(n_args)]
    try:
        whole = leaves(call(name, batch))
    except rr.RrrError:
        return  # e.g. a target outside the workspace: refused, the row is named (next test)
    for i in range(5):
        single = leaves(call(name, [a[i] for a in batch]))
        for w, s in zip(whole, single, strict=True):
            assert w.shape[0] == 5
            np.testing.assert_array_equal(w[i], s)


@pytest.mark.parametrize("name", sorted(BATCH_METHODS))
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_bad_row_is_named(name: str, bad: float) -> None:
    n_args = len(BATCH_METHODS[name])
    rows = np.tile([0.1, 0.2, 0.3], (6, 1))
    args = [rows.copy() for _ in range(n_args)]
    args[-1][4, 1] = bad
    with pytest.raises(rr.BadInputError, match="sample 4"):
        call(name, args)


@pytest.mark.parametrize("name", sorted(ONE_ONLY))
def test_single_only_methods_refuse_batches(name: str) -> None:
    with pytest.raises(rr.BadInputError, match=r"\(3,\)"):
        call(name, [np.tile([0.3, 0.0, 0.4], (2, 1))])
    one = call(name, [[0.3, 0.0, 0.4]])
    assert one is not None


@pytest.mark.parametrize("name", sorted(BATCH_METHODS) + sorted(ONE_ONLY))
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_finite_input_gives_finite_output_or_the_packages_error(name: str,
                                                                data: st.DataObject) -> None:
    n_args = len({**BATCH_METHODS, **ONE_ONLY}[name])
    args = [data.draw(arrays(np.float64, (3,), elements=any_finite)) for _ in range(n_args)]
    try:
        result = call(name, args)
    except rr.RrrError:
        return
    if isinstance(result, rr.Singularity):
        values = [result.elbow_margin, result.shoulder_margin, result.det_jacobian]
        assert np.all(np.isfinite(values)), (args, result)
    elif name == "ik_branches":
        assert result and all(isinstance(b, tuple) for b in result)
    else:
        for leaf in leaves(result):
            assert np.all(np.isfinite(leaf)), (name, args, leaf)


MISUSE: list[tuple[str, Callable[[], object]]] = [
    ("string array", lambda: MODEL.fk("abc")),
    ("None", lambda: MODEL.gravity(None)),
    ("dict", lambda: MODEL.friction({"a": 1})),
    ("complex", lambda: MODEL.gravity([1j, 0, 0])),
    ("wrong width", lambda: MODEL.mass_matrix([0.1, 0.2])),
    ("3-d array", lambda: MODEL.gravity(np.zeros((2, 2, 3)))),
    ("mismatched batches", lambda: MODEL.coriolis(np.zeros((2, 3)), np.zeros((3, 3)))),
    ("tol text", lambda: MODEL.singularity([0.1, 0.2, 0.3], tol="x")),  # type: ignore[arg-type]
    ("tol NaN", lambda: MODEL.singularity([0.1, 0.2, 0.3], tol=float("nan"))),
    ("parameter text", lambda: MODEL.with_params(a2="long")),
    ("parameter NaN", lambda: MODEL.with_params(g=float("nan"))),
    ("parameter shape", lambda: MODEL.with_params(p=[1.0, 2.0])),
    ("unknown parameter", lambda: MODEL.with_params(mass=3.0)),
    ("posture", lambda: MODEL.ik_branch([0.3, 0.0, 0.4], shoulder="left")),
    ("seed batch", lambda: MODEL.ik_nearest([0.3, 0.0, 0.4], np.zeros((2, 3)))),
]


@pytest.mark.parametrize(("what", "fn"), MISUSE, ids=[m[0] for m in MISUSE])
def test_misuse_raises_the_packages_error(what: str, fn: Callable[[], object]) -> None:
    with pytest.raises(rr.RrrError):
        fn()
