"""The URDF export (rrr_robot.core.urdf, ``rrr urdf``) against two independent URDF readers.

- Pinocchio's ``buildModelFromUrdf``: rnea + J_m qdd (the rotor inertias, which URDF cannot hold)
  equals our inverse dynamics to 1e-10 on random states, for the default robot and random robot
  files (random DH lengths, gravity, masses, centres of mass and principal moments); its ``tool``
  frame equals our forward kinematics (position and orientation); continuous joints give the same
  dynamics through Pinocchio's cos/sin joints.
- yourdfpy loads the file; its tool pose equals our FK, its masses are the robot file's.
- MuJoCo (the file's <mujoco> compiler element keeps the fixed `tool` link a body) and Drake
  (base_link welded to the world): their tool pose equals our FK, their inverse dynamics with
  the rotor inertias (MuJoCo: armature; Drake: + J_m qdd) equal ours.
- A robot file with [base_parameters] only is refused with a clear error (API and CLI).
"""

from __future__ import annotations

import copy
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import rrr_robot as rr
import yourdfpy
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.core.robot import RobotFile, read_robot_file
from rrr_robot.core.urdf import robot_urdf, write_urdf

DEFAULT = tomllib.loads(DEFAULT_ROBOT_TOML.read_text())
RTOL = 1e-10


def random_robot(seed: int) -> RobotFile:
    """The default robot file with random geometry, gravity and link tables."""
    rng = np.random.default_rng(seed)
    doc = copy.deepcopy(DEFAULT)
    doc["kinematics"] = {"d1": float(rng.uniform(-0.6, 0.6)), "a2": float(rng.uniform(0.15, 0.6)),
                         "a3": float(rng.uniform(0.15, 0.6)), "d2": float(rng.uniform(-0.4, 0.4)),
                         "d3": float(rng.uniform(-0.4, 0.4))}
    doc["gravity"] = {"g": float(rng.uniform(1.0, 20.0))}
    for i in range(1, 4):
        s = rng.uniform(0.001, 0.05, 3)          # principal moments from second moments s
        doc[f"link{i}"] = {"mass": float(rng.uniform(0.5, 10.0)),
                           "com": rng.uniform(-0.3, 0.3, 3).tolist(),
                           "inertia_com": [float(s[1] + s[2]), float(s[0] + s[2]),
                                           float(s[0] + s[1])]}
    doc["motors"]["rotor_inertia"] = rng.uniform(0.0, 0.05, 3).tolist()
    return read_robot_file(doc, f"random robot {seed}")


def pinocchio_of(robot: RobotFile, tmp_path: Path, continuous: bool = False) -> pin.Model:
    path = write_urdf(tmp_path / "robot.urdf", robot, continuous=continuous)
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, 0.0, -robot.model.g])
    return model


def states(seed: int, n: int = 50) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1000 + seed)
    return (rng.uniform(-np.pi, np.pi, (n, 3)), rng.uniform(-3.0, 3.0, (n, 3)),
            rng.uniform(-10.0, 10.0, (n, 3)))


def assert_close(actual: np.ndarray, expected: np.ndarray, what: str) -> None:
    scale = max(1.0, float(np.max(np.abs(expected))))
    err = float(np.max(np.abs(actual - expected)))
    assert err <= RTOL * scale, f"{what}: max error {err:.3g} (scale {scale:.3g})"


ROBOTS = {"default": lambda: rr.read_robot_file(), **{
    f"random{s}": (lambda s=s: random_robot(s)) for s in range(6)}}


@pytest.mark.parametrize("name", list(ROBOTS))
def test_pinocchio_dynamics_and_tool_frame(name: str, tmp_path: Path) -> None:
    robot = ROBOTS[name]()
    model = pinocchio_of(robot, tmp_path)
    assert (model.nq, model.nv) == (3, 3)
    assert list(model.names) == ["universe", "joint1", "joint2", "joint3"]
    data = model.createData()
    tool = model.getFrameId("tool")
    rotor = np.asarray(robot.rotor_inertia)
    q, qd, qdd = states(hash(name) % 1000)
    ours = robot.model.inverse_dynamics(q, qd, qdd)
    x, rot = robot.model.fk(q)
    for k in range(q.shape[0]):
        tau = pin.rnea(model, data, q[k], qd[k], qdd[k]) + rotor * qdd[k]
        assert_close(tau, ours[k], f"{name} state {k}: rnea + J_m qdd")
        pin.framesForwardKinematics(model, data, q[k])
        np.testing.assert_allclose(data.oMf[tool].translation, x[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(data.oMf[tool].rotation, rot[k], rtol=0, atol=1e-12)


def test_continuous_joints_give_the_same_dynamics(tmp_path: Path) -> None:
    robot = random_robot(7)
    model = pinocchio_of(robot, tmp_path, continuous=True)
    assert (model.nq, model.nv) == (6, 3)  # cos and sin per joint
    data = model.createData()
    q, qd, qdd = states(7, 20)
    ours = robot.model.inverse_dynamics(q, qd, qdd)
    rotor = np.asarray(robot.rotor_inertia)
    for k in range(q.shape[0]):
        q_cs = np.ravel(np.column_stack([np.cos(q[k]), np.sin(q[k])]))
        tau = pin.rnea(model, data, q_cs, qd[k], qdd[k]) + rotor * qdd[k]
        assert_close(tau, ours[k], f"continuous, state {k}")


def test_file_says_what_urdf_cannot_hold(tmp_path: Path) -> None:
    robot = rr.read_robot_file()
    text = robot_urdf(robot)
    assert "Rotor inertias J_m = [0.02 0.02 0.01] kg m^2 are NOT in this file" in text
    assert f"Gravity g = {robot.model.g!r}" in text
    # revolute joints on the DH axes, limits stated; effort = k_t u_max
    assert text.count('type="revolute"') == 3 and text.count('<axis xyz="0 0 1" />') == 3
    assert 'effort="120.0"' in text and 'upper="6.283185307179586"' in text


def test_yourdfpy_loads_it_and_agrees(tmp_path: Path) -> None:
    robot = random_robot(3)
    path = write_urdf(tmp_path / "robot.urdf", robot)
    urdf = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    assert urdf.validate()
    assert list(urdf.actuated_joint_names) == ["joint1", "joint2", "joint3"]
    assert set(urdf.link_map) == {"base_link", "link1", "link2", "link3", "tool"}
    for i, link in enumerate(robot.links or ()):
        assert urdf.link_map[f"link{i + 1}"].inertial.mass == link.mass
    q, _, _ = states(3, 10)
    x, rot = robot.model.fk(q)
    for k in range(q.shape[0]):
        urdf.update_cfg(q[k])
        pose = urdf.get_transform("tool", "base_link")
        np.testing.assert_allclose(pose[:3, 3], x[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(pose[:3, :3], rot[k], rtol=0, atol=1e-12)


def _base_parameter_robot(tmp_path: Path) -> Path:
    """The default robot written with [base_parameters] (as rrr identify writes robots)."""
    path = tmp_path / "bp.toml"
    rr.Model.default().to_toml(path)
    assert rr.read_robot_file(path).links is None
    return path


def test_base_parameters_only_is_refused(tmp_path: Path) -> None:
    path = _base_parameter_robot(tmp_path)
    with pytest.raises(rr.BadInputError, match=r"only \[base_parameters\].*link tables"):
        rr.write_urdf(tmp_path / "x.urdf", path)
    assert not (tmp_path / "x.urdf").exists()
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "urdf", "--robot", str(path),
                           "--out", str(tmp_path / "x.urdf")], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("rrr: error: ") and len(proc.stderr.splitlines()) == 1
    assert "[base_parameters]" in proc.stderr
    assert not (tmp_path / "x.urdf").exists()


def test_cli_writes_the_default_robot(tmp_path: Path) -> None:
    out = tmp_path / "rrr.urdf"
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "urdf", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert out.read_text() == robot_urdf(rr.read_robot_file())
    assert [p.name for p in tmp_path.iterdir()] == ["rrr.urdf"]  # no temporary left


def test_bad_limits_and_names_are_refused() -> None:
    robot = rr.read_robot_file()
    for options in ({"position_limit": float("nan")}, {"velocity_limit": 0.0},
                    {"name": "a b"}, {"name": ""}):
        with pytest.raises(rr.BadInputError):
            robot_urdf(robot, **options)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["default", "random2"])
def test_mujoco_keeps_the_tool_frame_and_the_dynamics(name: str, tmp_path: Path) -> None:
    """MuJoCo's URDF import (which merges fixed links into their parent unless the file's
    <mujoco><compiler fusestatic="false"/> says otherwise) keeps the `tool` body: its pose
    equals our FK; with the rotor inertias as armature and the model's gravity, its inverse
    dynamics (mj_inverse) equal Model.inverse_dynamics."""
    import mujoco

    robot = ROBOTS[name]()
    path = write_urdf(tmp_path / "robot.urdf", robot)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert m.nq == 3 and m.nv == 3
    tool = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "tool")
    assert tool >= 0, "MuJoCo fused the tool frame away"
    m.dof_armature[:] = robot.rotor_inertia
    m.opt.gravity[:] = (0.0, 0.0, -robot.model.g)
    d = mujoco.MjData(m)
    q, qd, qdd = states(7, 20)
    x, rot = robot.model.fk(q)
    tau = robot.model.inverse_dynamics(q, qd, qdd)
    for k in range(q.shape[0]):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        np.testing.assert_allclose(d.xpos[tool], x[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(d.xmat[tool].reshape(3, 3), rot[k], rtol=0, atol=1e-12)
        assert_close(d.qfrc_inverse, tau[k], f"mj_inverse, state {k}")


@pytest.mark.parametrize("name", ["default", "random4"])
def test_drake_keeps_the_tool_frame_and_the_dynamics(name: str, tmp_path: Path) -> None:
    """Drake's MultibodyPlant from the URDF, base_link welded to the world (a URDF root is a
    free body in Drake): the `tool` frame's pose equals our FK, and CalcInverseDynamics with the
    force elements (gravity) plus J_m qdd equals Model.inverse_dynamics."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import MultibodyForces

    robot = ROBOTS[name]()
    path = write_urdf(tmp_path / "robot.urdf", robot)
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(path))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link"))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -robot.model.g])
    plant.Finalize()
    assert plant.num_positions() == plant.num_velocities() == 3
    ctx = plant.CreateDefaultContext()
    tool = plant.GetFrameByName("tool")
    q, qd, qdd = states(11, 20)
    x, rot = robot.model.fk(q)
    tau = robot.model.inverse_dynamics(q, qd, qdd)
    rotor = np.asarray(robot.rotor_inertia)
    for k in range(q.shape[0]):
        plant.SetPositions(ctx, q[k])
        plant.SetVelocities(ctx, qd[k])
        pose = plant.CalcRelativeTransform(ctx, plant.world_frame(), tool)
        np.testing.assert_allclose(pose.translation(), x[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(pose.rotation().matrix(), rot[k], rtol=0, atol=1e-12)
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, forces)
        assert_close(plant.CalcInverseDynamics(ctx, qdd[k], forces) + rotor * qdd[k], tau[k],
                     f"Drake, state {k}")
