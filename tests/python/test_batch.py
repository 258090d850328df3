"""Batch inverse dynamics through librrr's batch kernels (rrr_robot.core.batch): every path this
machine runs against the one-state calls (the scalar path bit for bit, the vector kernels within
1e-13 N m, multi-turn angles included), broadcasting as before, a bad row raising the one-state
call's error, and bad paths refused."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core import batch

N = 1001


@pytest.fixture(scope="module")
def states() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (N, 3))
    q[::10] *= 3000.0  # multi-turn
    return q, rng.uniform(-5, 5, (N, 3)), rng.uniform(-20, 20, (N, 3))


def one_by_one(model: rr.Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    return np.array([model.inverse_dynamics(q[k], qd[k], qdd[k]) for k in range(len(q))])


@pytest.mark.parametrize("simd", ["auto", "scalar", "avx2", "avx512"])
def test_every_available_path_agrees_with_the_one_state_call(model, states, simd: str) -> None:
    if simd not in batch.simd_available():
        with pytest.raises(rr.BadInputError, match="not available here"):
            model.inverse_dynamics(*states, simd=simd)
        return
    ref = one_by_one(model, *states)
    tau = model.inverse_dynamics(*states, simd=simd)
    used = batch.simd_best() if simd == "auto" else simd
    if used == "scalar":
        assert tau.tobytes() == ref.tobytes()
    else:
        assert np.abs(tau - ref).max() <= 1e-13
    # broadcasting: one row against many, as the one-state kernels do
    q, qd, qdd = states
    tau_b = model.inverse_dynamics(q[0], qd, qdd, simd=simd)
    assert np.abs(tau_b - one_by_one(model, np.broadcast_to(q[0], q.shape), qd, qdd)).max() <= (
        0.0 if used == "scalar" else 1e-13)


def test_this_x86_machine_has_a_vector_path() -> None:
    """The CI machines are x86-64 Linux with AVX2: the vector kernels must be built there."""
    import platform

    if platform.machine() == "x86_64" and "avx2" in open("/proc/cpuinfo").read():
        assert "avx2" in batch.simd_available() and batch.simd_best() != "scalar"


def test_a_bad_row_raises_the_one_state_error_and_bad_paths_are_refused(model, states) -> None:
    q, qd, qdd = (a.copy() for a in states)
    qd[500, 1] = np.nan
    with pytest.raises(rr.BadInputError) as batch_err:
        model.inverse_dynamics(q, qd, qdd)
    with pytest.raises(rr.BadInputError) as scalar_err:
        model.inverse_dynamics(q, qd, qdd, simd="scalar")
    assert str(batch_err.value) == str(scalar_err.value)
    for bad in ("AVX2", "", "fast"):
        with pytest.raises(rr.BadInputError, match="simd must be one of"):
            model.inverse_dynamics(*states, simd=bad)
        with pytest.raises(rr.BadInputError, match="simd must be one of"):
            model.inverse_dynamics(q[0], qd[0], qdd[0], simd=bad)
    with pytest.raises(rr.BadInputError, match="rows"):
        model.inverse_dynamics(q[:5], qd[:4], qdd[:5])


def test_both_bindings_call_the_same_batch_kernels(model, states) -> None:
    """The extension (the Model's binding) and the ctypes binding run the same librrr call:
    bit for bit the same batch, broadcast rows included."""
    from rrr_robot.core import _ctypes_kernels

    slow = _ctypes_kernels.Kernels(model.raw)
    auto = batch.PATHS_HERE["auto"]
    assert model.inverse_dynamics(*states).tobytes() == slow.inverse_dynamics(
        *states, auto).tobytes()
    q, qd, qdd = states
    assert model.inverse_dynamics(q, qd[0], qdd).tobytes() == slow.inverse_dynamics(
        q, qd[0], qdd, auto).tobytes()
