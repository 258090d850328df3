"""rr.linearize: the plant's and the closed loop's state-space matrices against central finite
differences of rr.Plant (the plant FMU's right-hand side, rrr_plant_accel) and of Model.ctc, to
1e-6 relative; a batch's Jacobians are its rows' bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr

MODEL = rr.Model.default()
GAINS = rr.CtcGains.default()
H_REL = 1e-6
TOL = 1e-6
N_POINTS = 200


def plant_rhs(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """dx/dt = (qd, qdd) of rr.Plant at state x under the input u."""
    plant = rr.Plant(MODEL, x[:3], x[3:])
    return np.concatenate([x[3:], plant.accel(u)])


def closed_rhs(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    u, _, _ = MODEL.ctc(GAINS, r[:3], r[3:6], r[6:], x[:3], x[3:])
    return plant_rhs(x, u)


def central(f: object, x: np.ndarray, other: np.ndarray, wrt_x: bool) -> np.ndarray:
    """Central differences of f(x, other) with respect to x (wrt_x) or other, a step per
    variable."""
    base = x if wrt_x else other
    cols = []
    for j in range(base.size):
        h = H_REL * max(1.0, abs(base[j]))
        bp, bm = base.copy(), base.copy()
        bp[j] += h
        bm[j] -= h
        fp = f(bp, other) if wrt_x else f(x, bp)  # type: ignore[operator]
        fm = f(bm, other) if wrt_x else f(x, bm)  # type: ignore[operator]
        cols.append((fp - fm) / (bp[j] - bm[j]))
    return np.array(cols).T


def rel_err(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(a - ref)) / max(np.max(np.abs(ref)), 1e-300))


def random_state(rng: np.random.Generator) -> np.ndarray:
    return np.concatenate([rng.uniform(-np.pi, np.pi, 3), rng.uniform(-2.0, 2.0, 3)])


def test_plant_linearization_equals_finite_differences_of_plant() -> None:
    rng = np.random.default_rng(250)
    worst = 0.0
    for n in range(N_POINTS):
        x = random_state(rng)
        u = rng.uniform(-0.95, 0.95, 3) * MODEL.u_max
        if n % 4 == 3:  # beyond the limit (by far more than a step)
            u = np.sign(u) * rng.uniform(1.05, 1.5, 3) * MODEL.u_max
        lin = rr.linearize(MODEL, x[:3], x[3:], u)
        worst = max(worst, rel_err(lin.A, central(plant_rhs, x, u, True)),
                    rel_err(lin.B, central(plant_rhs, x, u, False)))
        np.testing.assert_array_equal(lin.xdot0, plant_rhs(x, u))
        np.testing.assert_array_equal(lin.x0, x)
        np.testing.assert_array_equal(lin.u0, u)
    print(f"plant: worst relative error {worst:.2e} over {N_POINTS} points")
    assert worst <= TOL


def test_closed_loop_linearization_equals_finite_differences() -> None:
    rng = np.random.default_rng(251)
    worst = 0.0
    done = 0
    while done < N_POINTS:
        x = random_state(rng)
        r = np.concatenate([x[:3] + rng.uniform(-0.01, 0.01, 3),
                            x[3:] + rng.uniform(-0.05, 0.05, 3), rng.uniform(-3.0, 3.0, 3)])
        u_n, u_c = MODEL.ctc(GAINS, r[:3], r[3:6], r[6:], x[:3], x[3:])[1:]
        if np.min(np.abs(np.abs(u_n + u_c) - MODEL.u_max)) < 1e-2:
            continue  # differences across the voltage limit's kink are not a derivative
        lin = rr.linearize(MODEL, x[:3], x[3:], gains=GAINS, q_ref=r[:3], qd_ref=r[3:6],
                           qdd_ref=r[6:])
        worst = max(worst, rel_err(lin.A, central(closed_rhs, x, r, True)),
                    rel_err(lin.B, central(closed_rhs, x, r, False)))
        done += 1
    print(f"closed loop: worst relative error {worst:.2e} over {N_POINTS} points")
    assert worst <= TOL


def test_outputs_and_defaults() -> None:
    q, qd = np.array([0.2, 0.6, -0.9]), np.zeros(3)
    lin = rr.linearize(MODEL, q, qd)
    # u defaults to the voltage that holds the arm still: no acceleration
    np.testing.assert_allclose(lin.xdot0, 0.0, atol=1e-12)
    assert lin.A.shape == (6, 6) and lin.B.shape == (6, 3)
    assert lin.C.shape == (9, 6) and lin.D.shape == (9, 3)
    np.testing.assert_array_equal(lin.C[6:, :3], MODEL.jacobian(q))
    assert lin.inputs == ("u[1]", "u[2]", "u[3]")
    assert lin.outputs[-3:] == ("tip.x", "tip.y", "tip.z")
    cl = rr.linearize(MODEL, q, qd, gains=GAINS)
    assert cl.B.shape == (6, 9) and cl.C.shape == (12, 6) and cl.D.shape == (12, 9)
    assert np.all(cl.poles().real < 0.0)  # the computed-torque loop is stable at rest
    ss = cl.to_scipy()
    np.testing.assert_array_equal(ss.A, cl.A)
    # with the reference at the state, the loop rests: dx/dt = 0
    np.testing.assert_allclose(cl.xdot0, 0.0, atol=1e-12)


def test_refusals() -> None:
    q = np.zeros(3)
    with pytest.raises(rr.BadInputError):
        rr.linearize(MODEL, q, q, q, gains=GAINS)
    with pytest.raises(rr.BadInputError):
        rr.linearize(MODEL, q, q, q_ref=q)
    with pytest.raises(rr.BadInputError):
        rr.linearize(MODEL, [0.0, np.nan, 0.0], q)
    with pytest.raises(rr.BadInputError):
        rr.linearize(MODEL, np.zeros((2, 3)), q)
    with pytest.raises(rr.BadInputError):
        rr.linearize("model", q, q)  # type: ignore[arg-type]
    with pytest.raises(rr.BadInputError):
        rr.linearize(MODEL, q, q, gains="gains")  # type: ignore[arg-type]


@pytest.mark.parametrize("n", [1, 5, 600])
def test_a_batch_is_its_rows_bit_for_bit(n: int) -> None:
    rng = np.random.default_rng(252)
    q, qd = rng.uniform(-3, 3, (n, 3)), rng.uniform(-2, 2, (n, 3))
    u = rng.uniform(-15, 15, (n, 3))
    batch = MODEL.plant_jacobian(q, qd, u)
    assert batch[0].shape == (n, 3) and batch[1].shape == (n, 3, 9)
    for i in range(n):
        for a, b in zip(batch, MODEL.plant_jacobian(q[i], qd[i], u[i]), strict=True):
            assert a[i].tobytes() == b.tobytes()
    args = (q, qd, rng.uniform(-3, 3, (n, 3)), q + 0.01, qd - 0.02)
    for gains in (GAINS, rr.CtcGains((5.0, 0.0, 1e6), (0.5, 2.0, 0.0), False)):
        batch = MODEL.ctc_jacobian(gains, *args)
        assert [b.shape for b in batch] == [(n, 3), (n, 3, 15), (n, 3, 15)]
        for i in range(n):
            for a, b in zip(batch, MODEL.ctc_jacobian(gains, *[x[i] for x in args]),
                            strict=True):
                assert a[i].tobytes() == b.tobytes()
    # and the refusals name the function and the row
    bad = q.copy()
    bad[n - 1, 1] = np.nan
    with pytest.raises(rr.BadInputError, match=rf"rrr_plant_jacobian failed .*sample {n - 1}"):
        MODEL.plant_jacobian(bad, qd, u)
