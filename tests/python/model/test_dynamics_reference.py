"""The closed-form dynamics of librrr against two independent references.

Random, physically consistent robots (random DH lengths and gravity, masses, centres of mass,
positive definite inertia tensors satisfying the triangle inequality, rotor inertias) are built
three ways: as an ``rrr_robot.Model`` with p = eq 12 (``bps_from_inertia``), as a Pinocchio model
(``JointModelRZ`` joints placed by the DH transforms Tz(d) Tx(a) Rx(alpha), ``armature = J_m``)
and as a Robotics Toolbox ``DHRobot`` (``Jm = J_m``, ``G = 1``). Then

- tau = R p equals Pinocchio's rnea and RTB's rne (rotor inertia included: motor torque),
- D equals crba, h equals computeGeneralizedGravity, c equals nonLinearEffects - h,
- forward dynamics equals aba,
- R p equals tau, and R stacked over many random states has rank 16 (eq 12 is a minimal BPS).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin
import pytest
import rrr_robot as rr
from rrr_robot.writing.references import Inertial
from rrr_robot.writing.references import pinocchio_model as pinocchio_model_of

FloatArray = npt.NDArray[np.float64]

ALPHA = (np.pi / 2, 0.0, 0.0)
N_ROBOTS = 12
N_STATES = 25
RTOL = 1e-10


@dataclass(frozen=True)
class Robot:
    """One random robot: the rrr_robot model and its inertial data for the references."""

    model: rr.Model
    dh: dict[str, float]
    g: float
    masses: FloatArray
    coms: FloatArray  # (3, 3): COM of link i in DH frame i
    inertias: FloatArray  # (3, 3, 3): tensor about the COM, frame-i axes
    rotor: FloatArray  # (3,): J_m

    @property
    def a(self) -> tuple[float, float, float]:
        return (0.0, self.dh["a2"], self.dh["a3"])

    @property
    def d(self) -> tuple[float, float, float]:
        return (self.dh["d1"], self.dh["d2"], self.dh["d3"])


def _rotation(rng: np.random.Generator) -> FloatArray:
    quat = rng.normal(size=4)
    w, x, y, z = quat / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def random_robot(seed: int) -> Robot:
    """Inertia about the COM I = tr(S) E - S, S = Q diag(s) Q' with s > 0: positive definite,
    principal moments (s2 + s3, s1 + s3, s1 + s2) satisfy the triangle inequality."""
    rng = np.random.default_rng(seed)
    dh = {
        "d1": float(rng.uniform(-0.6, 0.6)),
        "a2": float(rng.uniform(0.15, 0.6)),
        "a3": float(rng.uniform(0.15, 0.6)),
        "d2": float(rng.uniform(-0.4, 0.4)),
        "d3": float(rng.uniform(-0.4, 0.4)),
    }
    g = float(rng.uniform(1.0, 20.0))
    masses = rng.uniform(0.5, 10.0, 3)
    coms = rng.uniform(-0.3, 0.3, (3, 3))
    inertias = np.empty((3, 3, 3))
    for i in range(3):
        rot = _rotation(rng)
        second = rot @ np.diag(rng.uniform(0.001, 0.05, 3) * masses[i]) @ rot.T
        inertias[i] = np.trace(second) * np.eye(3) - second
    rotor = rng.uniform(0.0, 0.05, 3)
    p = rr.bps_from_inertia(dh, masses, coms, inertias, rotor)
    model = rr.Model.default().with_params(p=p, g=g, **dh)
    return Robot(model, dh, g, masses, coms, inertias, rotor)


def pinocchio_model(robot: Robot) -> tuple[pin.Model, pin.Data]:
    """The package's Pinocchio builder (also behind the writing task's Fig 6): revolute-z joints
    placed by Tz(d) Tx(a) Rx(alpha), link i (given in DH frame i) hung on joint i, J_m as
    armature."""
    inertial = Inertial(robot.masses, robot.coms, robot.inertias, robot.rotor)
    model = pinocchio_model_of(robot.dh, robot.g, inertial)
    return model, model.createData()


def random_states(seed: int, n: int = N_STATES) -> tuple[FloatArray, FloatArray, FloatArray]:
    rng = np.random.default_rng(10_000 + seed)
    return (
        rng.uniform(-np.pi, np.pi, (n, 3)),
        rng.uniform(-3.0, 3.0, (n, 3)),
        rng.uniform(-10.0, 10.0, (n, 3)),
    )


def assert_close(actual: FloatArray, expected: FloatArray, what: str) -> None:
    """Relative to the size of the reference (componentwise near-zeros use that scale)."""
    scale = max(1.0, float(np.max(np.abs(expected))))
    err = float(np.max(np.abs(actual - expected)))
    assert err <= RTOL * scale, f"{what}: max error {err:.3g} (scale {scale:.3g})"


@pytest.fixture(scope="module", params=range(N_ROBOTS), ids=lambda s: f"robot{s}")
def robot_seed(request: pytest.FixtureRequest) -> int:
    return int(request.param)


@pytest.fixture(scope="module")
def robot(robot_seed: int) -> Robot:
    return random_robot(robot_seed)


@pytest.fixture(scope="module")
def pin_model(robot: Robot) -> tuple[pin.Model, pin.Data]:
    return pinocchio_model(robot)


def test_inverse_dynamics_equals_rnea(
    robot: Robot, robot_seed: int, pin_model: tuple[pin.Model, pin.Data]
) -> None:
    model, data = pin_model
    qs, qds, qdds = random_states(robot_seed)
    tau = robot.model.inverse_dynamics(qs, qds, qdds)
    for k in range(len(qs)):
        ref = pin.rnea(model, data, qs[k], qds[k], qdds[k])
        assert_close(tau[k], ref, f"tau vs rnea, state {k}")


def test_mass_matrix_equals_crba(
    robot: Robot, robot_seed: int, pin_model: tuple[pin.Model, pin.Data]
) -> None:
    model, data = pin_model
    qs, _, _ = random_states(robot_seed)
    for q in qs:
        upper = pin.crba(model, data, q)
        ref = np.triu(upper) + np.triu(upper, 1).T
        mass = robot.model.mass_matrix(q)
        assert_close(mass, ref, f"D vs crba at q = {q}")
        np.testing.assert_array_equal(mass, mass.T)


def test_gravity_and_coriolis_equal_pinocchio(
    robot: Robot, robot_seed: int, pin_model: tuple[pin.Model, pin.Data]
) -> None:
    model, data = pin_model
    qs, qds, _ = random_states(robot_seed)
    for q, qd in zip(qs, qds, strict=True):
        grav = pin.computeGeneralizedGravity(model, data, q)
        assert_close(robot.model.gravity(q), grav, f"h vs computeGeneralizedGravity at {q}")
        nle = pin.nonLinearEffects(model, data, q, qd)
        assert_close(robot.model.coriolis(q, qd), nle - grav, f"c vs nle - g at {q}, {qd}")


def test_forward_dynamics_equals_aba(
    robot: Robot, robot_seed: int, pin_model: tuple[pin.Model, pin.Data]
) -> None:
    model, data = pin_model
    qs, qds, qdds = random_states(robot_seed)
    taus = robot.model.inverse_dynamics(qs, qds, qdds)
    for k in range(len(qs)):
        ref = pin.aba(model, data, qs[k], qds[k], taus[k])
        assert_close(robot.model.forward_dynamics(qs[k], qds[k], taus[k]), ref, f"aba {k}")
        assert_close(ref, qdds[k], f"aba inverts rnea {k}")


def test_regressor_times_p_is_tau(robot: Robot, robot_seed: int) -> None:
    qs, qds, qdds = random_states(robot_seed)
    reg = robot.model.regressor(qs, qds, qdds)
    assert reg.shape == (len(qs), 3, 16)
    tau = robot.model.inverse_dynamics(qs, qds, qdds)
    assert_close(reg @ robot.model.p, tau, "R p vs tau")


def test_stacked_regressor_has_rank_16() -> None:
    robot = random_robot(123)
    qs, qds, qdds = random_states(123, n=200)
    stacked = robot.model.regressor(qs, qds, qdds).reshape(-1, 16)
    sv = np.linalg.svd(stacked, compute_uv=False)
    assert sv[-1] > 1e-6 * sv[0], f"singular values {sv}"
    assert np.linalg.matrix_rank(stacked) == 16


def test_default_model_matches_pinocchio_with_default_inertia() -> None:
    """The default robot of data/default_robot.toml, built from its inertial data."""
    default = rr.Model.default()
    dh = default.dh
    masses = np.array([8.0, 6.0, 2.5])
    coms = np.array([[0.0, -0.15, 0.0], [-0.20, 0.0, 0.05], [-0.15, 0.0, 0.02]])
    inertias = np.array(
        [np.diag([0.12, 0.20, 0.12]), np.diag([0.02, 0.10, 0.10]), np.diag([0.005, 0.03, 0.03])]
    )
    rotor = np.array([0.02, 0.02, 0.01])
    robot = Robot(default, dh, default.g, masses, coms, inertias, rotor)
    p = rr.bps_from_inertia(dh, masses, coms, inertias, rotor)
    np.testing.assert_allclose(p, default.p, rtol=1e-13, atol=1e-15)
    model, data = pinocchio_model(robot)
    qs, qds, qdds = random_states(7)
    tau = default.inverse_dynamics(qs, qds, qdds)
    for k in range(len(qs)):
        assert_close(tau[k], pin.rnea(model, data, qs[k], qds[k], qdds[k]), f"default {k}")


def test_inverse_dynamics_equals_rtb_rne() -> None:
    import roboticstoolbox as rtb
    for seed in range(4):
        robot = random_robot(500 + seed)
        links = [
            rtb.RevoluteDH(
                d=robot.d[i],
                a=robot.a[i],
                alpha=ALPHA[i],
                m=float(robot.masses[i]),
                r=robot.coms[i],
                I=robot.inertias[i],
                Jm=float(robot.rotor[i]),
                G=1.0,
                B=0.0,
                Tc=[0.0, 0.0],
            )
            for i in range(3)
        ]
        dh_robot = rtb.DHRobot(links, gravity=[0.0, 0.0, -robot.g])
        qs, qds, qdds = random_states(500 + seed, n=10)
        tau = robot.model.inverse_dynamics(qs, qds, qdds)
        for k in range(len(qs)):
            ref = np.asarray(dh_robot.rne(qs[k], qds[k], qdds[k]), dtype=float)
            assert_close(tau[k], ref, f"tau vs RTB rne, robot {seed} state {k}")


def test_plant_jacobian_equals_aba_derivatives(
    robot: Robot, robot_seed: int, pin_model: tuple[pin.Model, pin.Data]
) -> None:
    """The rigid-body part of librrr's exact d qdd / d(q, qd, u) (rrr_plant_jacobian, generated
    from the SymPy derivation) against Pinocchio's computeABADerivatives: with k_t = 1, no
    friction and no voltage limit in reach the plant's input is the motor torque."""
    model, data = pin_model
    rigid = robot.model.with_params(kt=[1.0, 1.0, 1.0], f=np.zeros((3, 3)), b=[0.0, 0.0, 0.0],
                                    u_max=1e9)
    qs, qds, qdds = random_states(robot_seed)
    taus = rigid.inverse_dynamics(qs, qds, qdds)
    for k in range(len(qs)):
        pin.computeABADerivatives(model, data, qs[k], qds[k], taus[k])
        minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
        qdd, jac = rigid.plant_jacobian(qs[k], qds[k], taus[k])
        assert_close(qdd, data.ddq, f"qdd vs aba {k}")
        assert_close(jac[:, :3], data.ddq_dq, f"d qdd / d q vs ddq_dq {k}")
        assert_close(jac[:, 3:6], data.ddq_dv, f"d qdd / d qd vs ddq_dv {k}")
        assert_close(jac[:, 6:], minv, f"d qdd / d u vs Minv {k}")
