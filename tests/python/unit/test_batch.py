"""Batch inverse dynamics, regressor, FK, forward dynamics and IK through librrr's batch kernels
(rrr_robot.core.batch): every path this machine runs against the one-state calls (the scalar path
bit for bit, the vector kernels within 1e-13, multi-turn angles included), broadcasting as
before, a bad row raising the one-state call's error, and bad paths refused."""

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


# the other batch calls: Model method and its inputs from (q, qd, qdd)
OTHER = {
    "regressor": lambda m, q, qd, qdd: (q, qd, qdd),
    "fk": lambda m, q, qd, qdd: (q,),
    "forward_dynamics": lambda m, q, qd, qdd: (q, qd, m.inverse_dynamics(q, qd, qdd,
                                                                           simd="scalar")),
}


def flat(result: object) -> np.ndarray:
    """One array of a result (fk's (x, R) concatenated)."""
    if isinstance(result, tuple):
        return np.concatenate([np.asarray(r).ravel() for r in result])
    return np.asarray(result).ravel()


@pytest.mark.parametrize("name", sorted(OTHER))
@pytest.mark.parametrize("simd", ["auto", "scalar", "avx2", "avx512"])
def test_every_path_of_the_other_batch_calls_agrees(model, states, name: str,
                                                     simd: str) -> None:
    args = OTHER[name](model, *states)
    method = getattr(model, name)
    if simd not in batch.simd_available():
        with pytest.raises(rr.BadInputError, match="not available here"):
            method(*args, simd=simd)
        return
    # the one-state results row by row, in the layout of the batch's
    rows = [method(*(a[k] for a in args)) for k in range(N)]
    if isinstance(rows[0], tuple):  # fk: (x, R)
        ref = flat(tuple(np.stack([r[i] for r in rows]) for i in range(len(rows[0]))))
    else:
        ref = np.stack(rows).ravel()
    got = flat(method(*args, simd=simd))
    used = batch.simd_best() if simd == "auto" else simd
    if used == "scalar":
        assert got.tobytes() == ref.tobytes()
    else:
        assert np.abs(got - ref).max() <= 1e-13
    # broadcasting: the first argument's row 0 against every row of the others
    if len(args) > 1:
        b_args = (args[0][0], *args[1:])
        rows = [method(args[0][0], *(a[k] for a in args[1:])) for k in range(N)]
        got_b = method(*b_args, simd=simd)
        assert np.abs(got_b - np.stack(rows)).max() <= (0.0 if used == "scalar" else 1e-13)


@pytest.mark.parametrize("name", sorted(OTHER))
def test_a_bad_row_of_the_other_calls_raises_the_one_state_error(model, states,
                                                                 name: str) -> None:
    args = [a.copy() for a in OTHER[name](model, *states)]
    args[-1][500, 1] = np.nan
    args[0][700, 2] = np.inf
    method = getattr(model, name)
    with pytest.raises(rr.BadInputError) as batch_err:
        method(*args)
    with pytest.raises(rr.BadInputError) as scalar_err:
        method(*args, simd="scalar")
    assert str(batch_err.value) == str(scalar_err.value)
    assert "sample 500" in str(batch_err.value)
    with pytest.raises(rr.BadInputError, match="simd must be one of"):
        method(*args, simd="fast")
    with pytest.raises(rr.BadInputError, match="simd must be one of"):
        method(*(a[0] for a in args), simd=None)


def test_a_mass_matrix_that_is_not_positive_definite_is_the_scalar_calls(model, states) -> None:
    """A model whose D is not positive definite (every p negated): the batch raises what the
    row loop raises, at row 0."""
    raw = type(model.raw).from_buffer_copy(model.raw)
    for i in range(len(raw.p)):
        raw.p[i] = -raw.p[i]
    broken = rr.Model(raw, validate=False)
    args = OTHER["forward_dynamics"](model, *states)
    with pytest.raises(rr.RrrError) as scalar_err:
        broken.forward_dynamics(*args, simd="scalar")
    for simd in batch.simd_available():
        with pytest.raises(type(scalar_err.value)) as batch_err:
            broken.forward_dynamics(*args, simd=simd)
        assert str(batch_err.value) == str(scalar_err.value)
    assert "sample 0" in str(scalar_err.value)


@pytest.mark.parametrize("name", sorted(OTHER))
def test_a_bad_row_of_the_other_batch_kernels_is_named(model, states, name: str) -> None:
    """A bad row raises the same error on the batch kernels' path as on the row loop, naming
    the row; broadcast rows give the batch of the repeated rows, bit for bit."""
    args = OTHER[name](model, *states)
    if len(args) > 1:
        b_args = (args[0], args[1][0], *args[2:])
        full = (args[0], np.repeat(args[1][:1], len(args[0]), axis=0), *args[2:])
        assert flat(getattr(model, name)(*b_args)).tobytes() == flat(
            getattr(model, name)(*full)).tobytes()
    bad = [a.copy() for a in args]
    bad[-1][321, 0] = np.nan
    with pytest.raises(rr.BadInputError) as vec_err:
        getattr(model, name)(*bad)
    with pytest.raises(rr.BadInputError) as row_err:
        getattr(model, name)(*bad, simd="scalar")
    assert str(vec_err.value) == str(row_err.value) and "sample 321" in str(row_err.value)


# ---- IK: Model.ik(x, shoulder, elbow, simd) over (n, 3) targets (rrr_ik_batch) -------------
POSTURES = [("front", "up"), ("front", "down"), ("back", "up"), ("back", "down")]


@pytest.fixture(scope="module")
def targets(model, states) -> np.ndarray:
    """Reachable targets: FK of the states' angles, with singular and wrap-edge rows."""
    q = states[0].copy()
    q[3] = [0.3, 0.2, 0.0]       # stretched elbow (outer sphere)
    q[4] = [0.3, 0.2, np.pi]     # folded elbow (inner sphere)
    q[5] = [np.pi, 0.5, 1.0]     # q1 at the wrap
    q[6] = [-np.pi, -np.pi, 0.4]
    x = model.fk(q, simd="scalar")[0]
    e = model.dh["d2"] + model.dh["d3"]
    x[7] = [0.0, -e, model.dh["d1"] + 0.3]  # on the shoulder cylinder (r = 0)
    return x


@pytest.mark.parametrize("simd", ["auto", "scalar", "avx2", "avx512"])
@pytest.mark.parametrize(("shoulder", "elbow"), POSTURES)
def test_batch_ik_agrees_with_ik_branch_on_every_path(model, targets, simd: str, shoulder: str,
                                                      elbow: str) -> None:
    if simd not in batch.simd_available():
        with pytest.raises(rr.BadInputError, match="not available here"):
            model.ik(targets, shoulder, elbow, simd=simd)
        return
    ref = np.array([model.ik_branch(x, shoulder, elbow) for x in targets])
    q = model.ik(targets, shoulder, elbow, simd=simd)
    assert q.shape == targets.shape
    used = batch.simd_best() if simd == "auto" else simd
    if used == "scalar":
        assert q.tobytes() == ref.tobytes()
    else:
        assert np.abs(q - ref).max() <= 1e-13
    assert np.all((q > -np.pi) & (q <= np.pi))
    assert np.abs(model.fk(q)[0] - targets).max() <= 1e-12  # FK(IK(x)) = x


def test_batch_ik_auto_within_1e_13_of_scalar(model, targets) -> None:
    auto = model.ik(targets, "back", "down")
    scalar = model.ik(targets, "back", "down", simd="scalar")
    assert np.abs(auto - scalar).max() <= 1e-13
    path = batch.PATHS_HERE["auto"]  # the binding takes the rrr_simd value as well
    assert model._k.ik_branch(targets, 1, 1, path).tobytes() == auto.tobytes()
    assert model._k.ik_branch(targets, 1, 1, 1).tobytes() == scalar.tobytes()


@pytest.mark.parametrize("simd", ["auto", "scalar"])
def test_a_bad_ik_row_raises_its_error_naming_the_first_one(model, targets, simd: str) -> None:
    x = targets.copy()
    x[300] = [5.0, 1.0, 0.0]       # beyond the outer sphere
    x[400, 2] = np.nan
    with pytest.raises(rr.UnreachableError, match="sample 300") as err:
        model.ik(x, "front", "up", simd=simd)
    assert "rrr_ik_branch failed with RRR_UNREACHABLE" in str(err.value)
    assert "sample 300: x = [5.0, 1.0, 0.0]" in str(err.value)
    x[300] = targets[300]
    with pytest.raises(rr.BadInputError, match="sample 400") as nan_err:
        model.ik(x, "front", "up", simd=simd)
    with pytest.raises(rr.BadInputError) as one_err:
        model.ik_branch(x, "front", "up")  # the row loop: the same message
    assert str(nan_err.value) == str(one_err.value)
    x[400] = [1e-3, 1e-3, 0.9]     # inside the shoulder cylinder
    with pytest.raises(rr.UnreachableError, match="sample 400"):
        model.ik(x, "back", "up", simd=simd)


def test_ik_of_one_target_is_unchanged_and_postures_are_checked(model, targets) -> None:
    x = targets[10]
    sols = model.ik(x)  # every branch, as before
    assert sols.ndim == 2 and sols.shape[1] == 3 and 1 <= len(sols) <= 4
    for (sh, el), q in zip(model.ik_branches(x), sols, strict=True):
        assert model.ik(x, sh, el).tobytes() == model.ik_branch(x, sh, el).tobytes()
        assert q.tobytes() == model.ik_branch(x, sh, el).tobytes()
    assert model.ik(x.tolist(), "back", "down", simd="scalar").shape == (3,)
    with pytest.raises(rr.BadInputError, match="needs a posture"):
        model.ik(targets)
    with pytest.raises(rr.BadInputError, match="posture must be"):
        model.ik(targets, "front")
    with pytest.raises(rr.BadInputError, match="posture must be"):
        model.ik(targets, elbow="up")
    with pytest.raises(rr.BadInputError, match="posture must be"):
        model.ik(targets, "left", "up")
    with pytest.raises(rr.BadInputError, match="simd must be one of"):
        model.ik(targets, "front", "up", simd="fast")
    with pytest.raises(rr.UnreachableError):
        model.ik([5.0, 0.0, 0.0])
    assert model.ik(np.empty((0, 3)), "front", "up").shape == (0, 3)
