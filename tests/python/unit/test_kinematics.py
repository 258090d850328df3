"""Kinematics through the Python binding: every IK branch round-trips, the generating
configuration comes back, the Robotics Toolbox numeric IK agrees (the paper's Fig 5), and bad
targets raise clear errors."""

from __future__ import annotations

import numpy as np
import pytest
import rrr_robot as rr
import spatialmath as sm

RNG = np.random.default_rng(20261121)


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def test_fk_batch_matches_single(model: rr.Model) -> None:
    qs = RNG.uniform(-np.pi, np.pi, (50, 3))
    xs, rots = model.fk(qs, simd="scalar")  # bit for bit the rows; the batch kernels: 1e-13
    assert xs.shape == (50, 3) and rots.shape == (50, 3, 3)
    assert np.abs(model.fk(qs)[1] - rots).max() <= 1e-13
    for k in (0, 17, 49):
        x, rot = model.fk(qs[k])
        np.testing.assert_array_equal(x, xs[k])
        np.testing.assert_array_equal(rot, rots[k])


def test_ik_round_trip_whole_range(model: rr.Model) -> None:
    """FK(IK(x)) < 1e-12 m on every branch; the generating q comes back to < 1e-10 rad."""
    qs = RNG.uniform(-np.pi, np.pi, (3000, 3))
    xs, _ = model.fk(qs)
    worst_fk, worst_q = 0.0, 0.0
    for q, x in zip(qs, xs, strict=True):
        sols = model.ik(x)
        assert 1 <= len(sols) <= 4
        back, _ = model.fk(sols)
        worst_fk = max(worst_fk, float(np.abs(back - x).max()))
        if model.singularity(q).elbow_margin > 1e-3:
            worst_q = max(worst_q, float(np.abs(wrap(sols - q)).max(axis=1).min()))
    assert worst_fk < 1e-12
    assert worst_q < 1e-10


def test_branch_names_and_explicit_posture(model: rr.Model) -> None:
    q = np.array([2.5, 0.4, -1.0])  # cos q1 < 0: where the paper's asin form fails
    x, _ = model.fk(q)
    r = model.dh["a2"] * np.cos(q[1]) + model.dh["a3"] * np.cos(q[1] + q[2])
    shoulder = "front" if r >= 0 else "back"
    elbow = "up" if np.sin(q[2]) <= 0 else "down"
    assert (shoulder, elbow) in model.ik_branches(x)
    np.testing.assert_allclose(model.ik_branch(x, shoulder, elbow), q, atol=1e-12)
    with pytest.raises(rr.BadInputError, match="posture"):
        model.ik_branch(x, "left", "up")


def test_ik_agrees_with_robotics_toolbox(model: rr.Model) -> None:
    """Numeric IK (Levenberg-Marquardt, tight tolerance) seeded near each closed-form branch
    converges to it within 1e-9 rad."""
    import roboticstoolbox as rtb

    dh = model.dh
    links = [
        rtb.RevoluteDH(d=dh["d1"], a=0.0, alpha=np.pi / 2),
        rtb.RevoluteDH(d=dh["d2"], a=dh["a2"], alpha=0.0),
        rtb.RevoluteDH(d=dh["d3"], a=dh["a3"], alpha=0.0),
    ]
    ets = rtb.DHRobot(links).ets()
    mask = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    worst, compared = 0.0, 0
    for q in RNG.uniform(-np.pi, np.pi, (40, 3)):
        x, _ = model.fk(q)
        if model.workspace_margin(x) < 0.02 or model.singularity(q).elbow_margin < 0.05:
            continue
        for sol in model.ik(x):
            seed = sol + RNG.normal(0.0, 0.02, 3)
            res = ets.ik_LM(sm.SE3(*x).A, q0=seed, mask=mask, tol=1e-24, ilimit=200, slimit=1,
                            joint_limits=False)
            assert res.success, f"numeric IK did not converge: {res.reason}"
            worst = max(worst, float(np.abs(wrap(np.asarray(res.q) - sol)).max()))
            compared += 1
    assert compared > 40
    assert worst < 1e-9, worst


def test_ik_nearest_path_is_continuous_and_unwrapped(model: rr.Model) -> None:
    t = np.linspace(0.0, 1.0, 2001)
    q_true = np.stack([0.3 + 5 * np.pi * t, 0.2 + 0.3 * np.sin(6 * t), 1.0 + 0.2 * t], axis=1)
    xs, _ = model.fk(q_true)
    q = model.ik_nearest(xs, q_true[0])
    np.testing.assert_allclose(q, q_true, atol=1e-10)


def test_joint_motion_inverts_tip_motion(model: rr.Model) -> None:
    q = np.array([0.4, 0.3, 1.1])
    qd = np.array([0.5, -0.4, 0.9])
    qdd = np.array([-1.0, 2.0, 0.5])
    xd, xdd = model.tip_motion(q, qd, qdd)
    qd2, qdd2 = model.joint_motion(q, xd, xdd)
    np.testing.assert_allclose(qd2, qd, atol=1e-12)
    np.testing.assert_allclose(qdd2, qdd, atol=1e-11)
    with pytest.raises(rr.SingularError, match="singular"):
        model.joint_motion([0.4, 0.3, 0.0], xd, xdd)


@pytest.mark.parametrize(
    "target",
    [[2.0, 0.0, 0.5], [0.01, 0.01, 0.9], [0.0, 0.0, 0.5]],
    ids=["beyond reach", "inside shoulder cylinder", "on the axis"],
)
def test_unreachable_targets_raise(model: rr.Model, target: list[float]) -> None:
    with pytest.raises(rr.UnreachableError, match="outside the workspace"):
        model.ik(target)
    with pytest.raises(rr.UnreachableError):
        model.ik_nearest(target, [0.0, 0.0, 0.0])
    assert model.workspace_margin(target) < 0


@pytest.mark.parametrize("bad", [[np.nan, 0.3, 0.5], [0.3, np.inf, 0.5]])
def test_non_finite_inputs_raise(model: rr.Model, bad: list[float]) -> None:
    with pytest.raises(rr.BadInputError):
        model.ik(bad)
    with pytest.raises(rr.BadInputError):
        model.fk(bad)
    with pytest.raises(rr.BadInputError):
        model.inverse_dynamics(bad, [0, 0, 0], [0, 0, 0])
    with pytest.raises(rr.BadInputError, match="shape"):
        model.fk([0.0, 1.0])


def test_singularity_classification(model: rr.Model) -> None:
    s = model.singularity([0.1, 0.2, 0.0])
    assert s.stretched and not s.folded and s.elbow_margin == 0.0
    s = model.singularity([0.1, 0.2, np.pi])
    assert s.folded
    s = model.singularity([0.1, 0.4, 1.2])
    assert not (s.stretched or s.folded or s.shoulder) and s.det_jacobian != 0.0


def test_ik_nearest_refuses_what_it_cannot_unwrap(model: rr.Model) -> None:
    x, _ = model.fk([0.1, 0.2, 0.3])
    with pytest.raises(rr.BadInputError, match="q_prev must have shape"):
        model.ik_nearest(np.array([x, x]), np.zeros((3, 3)))
    # beyond 1e6 rad a double cannot hold the unwrapped angle: refused, never a wrong answer
    with pytest.raises(rr.BadInputError):
        model.ik_nearest(x, [1e7, 0.0, 0.0])
    q = model.ik_nearest(x, [1e6, 0.0, 0.0])
    np.testing.assert_allclose(model.fk(q)[0], x, atol=1e-9)


@pytest.mark.parametrize("bad", [np.array([1j, 0, 0]), ["a", "b", "c"], [[1, 2], [3]]])
def test_non_numeric_inputs_raise(model: rr.Model, bad: object) -> None:
    with pytest.raises(rr.BadInputError):
        model.fk(bad)
