"""The robot as a URDF file, for Pinocchio, ROS (robot_state_publisher, RViz, MoveIt) and every
other URDF tool: ``rrr urdf --out FILE`` and :func:`robot_urdf` / :func:`write_urdf`.

Built from a robot file's link tables and DH geometry (docs/conventions.md):

* ``base_link`` is DH frame 0 (z up along the waist axis); ``link<i>`` turns with ``joint<i>``
  about z_(i-1), so its frame is frame i-1 turned by q_i; the next joint (and the ``tool``
  frame) sits at the fixed part of the DH transform, Tz(d_i) Tx(a_i) Rx(alpha_i), which makes
  the joint angles of the URDF the DH angles q_i of the model, with no offset.
* Link i's inertial block is its COM and inertia tensor about the COM given in DH frame i (as the
  robot file gives them), placed there by the same transform (``origin xyz rpy``): the numbers of
  ``<inertia>`` are the tensor's entries on the axes of DH frame i (URDF's ``ixy`` is the tensor
  entry, minus the product of inertia written as an integral in docs/conventions.md).
* ``tool`` is DH frame 3, the pen tip: its pose is the forward kinematics (``Model.fk``).
* Rotor inertias J_m have no place in URDF (it describes rigid links; a tool adds an armature
  of its own, Pinocchio ``model.armature``): the file says so and gives their values in a
  comment; the model's motor torque is the URDF's rigid-body torque plus J_m qdd. Gravity is not
  part of URDF either (the file names the model's g in a comment).
* The joints turn without limit (slip rings). ``revolute`` joints need position limits: they
  get +-``position_limit`` (default 2 pi: one turn either way from any IK solution, which lies
  in (-pi, pi]); ``continuous=True`` writes ``continuous`` joints instead (no position limit;
  Pinocchio then represents each joint by cos and sin, nq = 6). Effort limits are the saturated
  motor torques k_t u_max; the velocity limit is a stated value (the model has none).

A robot file that gives only ``[base_parameters]`` cannot be exported: 16 base parameters do
not determine the links' masses and inertias (BadInputError).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import BadInputError
from ._arrays import FloatArray
from .inertial import Inertial, dh_links, dh_transform, inertial_from_robot
from .model import DEFAULT_ROBOT_TOML
from .outputs import atomic_write_text
from .robot import RobotFile, read_robot_file

__all__ = ["DEFAULT_POSITION_LIMIT", "DEFAULT_VELOCITY_LIMIT", "robot_urdf", "write_urdf"]

#: Position limits of revolute joints, rad (the real joints have none).
DEFAULT_POSITION_LIMIT = 2.0 * math.pi
#: Velocity limit of every joint, rad/s: the fastest speed of the identification's friction
#: sweep, where the friction model is known (the model itself has no limit).
DEFAULT_VELOCITY_LIMIT = 4.0
_LINK_RADIUS = 0.03          # m, the cylinders drawn for the links (visual only)


def _num(value: float) -> str:
    """A number with every bit (the shortest text that reads back to the same double; -0
    written as 0)."""
    return repr(float(value) + 0.0)


def _nums(values: Sequence[float] | FloatArray) -> str:
    return " ".join(_num(v) for v in values)


def _rpy(rot: FloatArray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw of a rotation, R = Rz(yaw) Ry(pitch) Rx(roll)."""
    pitch = math.atan2(-rot[2, 0], math.hypot(rot[0, 0], rot[1, 0]))
    roll = math.atan2(rot[2, 1], rot[2, 2])
    yaw = math.atan2(rot[1, 0], rot[0, 0])
    return roll, pitch, yaw


def _origin(parent: ET.Element, xyz: Sequence[float] | FloatArray,
            rpy: Sequence[float]) -> None:
    ET.SubElement(parent, "origin", xyz=_nums(xyz), rpy=_nums(rpy))


def _cylinder(link: ET.Element, start: FloatArray, end: FloatArray) -> None:
    """A visual cylinder from ``start`` to ``end`` (link frame), if they differ."""
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length < 1e-9:
        return
    u = axis / length
    pitch = math.acos(max(-1.0, min(1.0, float(u[2]))))    # z of the cylinder onto u
    yaw = math.atan2(float(u[1]), float(u[0]))
    visual = ET.SubElement(link, "visual")
    _origin(visual, 0.5 * (start + end), (0.0, pitch, yaw))
    geometry = ET.SubElement(visual, "geometry")
    ET.SubElement(geometry, "cylinder", radius=_num(_LINK_RADIUS), length=_num(length))


def _link(robot: ET.Element, i: int, inertial: Inertial, dh: tuple[float, float, float]) -> None:
    rot, pos = dh_transform(*dh)
    link = ET.SubElement(robot, "link", name=f"link{i + 1}")
    link.append(ET.Comment(f" COM {_nums(inertial.coms[i])} m and inertia about the COM in DH "
                           f"frame {i + 1}, placed by Tz(d{i + 1}) Tx(a{i + 1}) "
                           f"Rx(alpha{i + 1}) "))
    block = ET.SubElement(link, "inertial")
    _origin(block, pos + rot @ inertial.coms[i], _rpy(rot))
    ET.SubElement(block, "mass", value=_num(inertial.masses[i]))
    tensor = inertial.inertias_com[i]
    ET.SubElement(block, "inertia", ixx=_num(tensor[0, 0]), ixy=_num(tensor[0, 1]),
                  ixz=_num(tensor[0, 2]), iyy=_num(tensor[1, 1]), iyz=_num(tensor[1, 2]),
                  izz=_num(tensor[2, 2]))
    # the link drawn from its joint's axis to the next joint's: along z by d_i, then along x
    corner = np.array([0.0, 0.0, dh[0]])
    _cylinder(link, np.zeros(3), corner)
    _cylinder(link, corner, pos)


def _joint(robot: ET.Element, name: str, kind: str, parent: str, child: str,
           placement: tuple[FloatArray, FloatArray] | None) -> ET.Element:
    joint = ET.SubElement(robot, "joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    if placement is None:
        _origin(joint, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    else:
        _origin(joint, placement[1], _rpy(placement[0]))
    return joint


def robot_urdf(robot: RobotFile, name: str = "rrr", continuous: bool = False,
               position_limit: float = DEFAULT_POSITION_LIMIT,
               velocity_limit: float = DEFAULT_VELOCITY_LIMIT) -> str:
    """The URDF text of a checked robot file (see the module doc); BadInputError for a robot
    file without link tables or a limit that is not a positive finite number."""
    inertial = inertial_from_robot(robot)
    if inertial is None:
        raise BadInputError(
            f"{robot.source} gives only [base_parameters]: a URDF needs each link's mass, centre "
            "of mass and inertia, which 16 base parameters do not determine; export a robot "
            "file with the link tables [link1..3] (mass, com, inertia_com) and [motors] "
            "rotor_inertia")
    for what, value in (("position_limit", position_limit), ("velocity_limit", velocity_limit)):
        if not (math.isfinite(value) and value > 0.0):
            raise BadInputError(f"{what} must be a positive finite number, got {value!r}")
    if not name or not all(ch.isalnum() or ch in "_-." for ch in name):
        raise BadInputError(f"robot name must be letters, digits, _ - ., got {name!r}")
    model = robot.model
    kt, u_max = model.kt, model.u_max
    root = ET.Element("robot", name=name)
    root.append(ET.Comment(
        f" Generated by rrr_robot (rrr urdf) from {Path(robot.source).name}. Frames: base_link = "
        "DH frame 0 (z up, the waist axis); link<i> turns with joint<i> about z(i-1); the next "
        "joint and the tool frame sit at Tz(d_i) Tx(a_i) Rx(alpha_i); tool = DH frame 3, the "
        "pen tip. Joint angles are the model's DH angles. "))
    root.append(ET.Comment(
        f" Rotor inertias J_m = [{_nums(inertial.rotor)}] kg m^2 are NOT in this file: URDF has "
        "no rotor (armature) inertia. The model's motor torque is this file's rigid-body torque "
        "plus J_m qdd (Pinocchio: model.armature = J_m). "))
    root.append(ET.Comment(
        f" Gravity g = {_num(model.g)} m/s^2 along -z of base_link (set it in your tool). The "
        f"joints turn without limit; {'continuous joints' if continuous else 'revolute limits '}"
        f"{'' if continuous else '+-' + _num(position_limit) + ' rad'}; effort limits "
        f"k_t u_max; velocity limits {_num(velocity_limit)} rad/s (not a model limit). "))
    # MuJoCo's URDF import merges bodies joined by fixed joints into their parent unless told
    # not to: keep `tool` (and base_link) as bodies of their own; other URDF readers ignore it
    mujoco = ET.SubElement(root, "mujoco")
    ET.SubElement(mujoco, "compiler", fusestatic="false", discardvisual="false")
    ET.SubElement(root, "link", name="base_link")
    parent = "base_link"
    placement: tuple[FloatArray, FloatArray] | None = None
    for i, dh in enumerate(dh_links(model.dh)):
        child = f"link{i + 1}"
        joint = _joint(root, f"joint{i + 1}", "continuous" if continuous else "revolute",
                       parent, child, placement)
        ET.SubElement(joint, "axis", xyz="0 0 1")
        limits = {"effort": _num(float(kt[i]) * u_max), "velocity": _num(velocity_limit)}
        if not continuous:
            limits |= {"lower": _num(-position_limit), "upper": _num(position_limit)}
        ET.SubElement(joint, "limit", limits)
        _link(root, i, inertial, dh)
        parent, placement = child, dh_transform(*dh)
    _joint(root, "tool_joint", "fixed", parent, "tool", placement)
    ET.SubElement(root, "link", name="tool")
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_urdf(path: str | Path, robot: RobotFile | str | Path = DEFAULT_ROBOT_TOML,
               name: str = "rrr", continuous: bool = False,
               position_limit: float = DEFAULT_POSITION_LIMIT,
               velocity_limit: float = DEFAULT_VELOCITY_LIMIT) -> Path:
    """Write :func:`robot_urdf` of ``robot`` (a RobotFile or a robot file's path) to ``path``,
    atomically (the old file or the new one, never a part); returns the path."""
    robot_file = robot if isinstance(robot, RobotFile) else read_robot_file(robot)
    text = robot_urdf(robot_file, name=name, continuous=continuous,
                      position_limit=position_limit, velocity_limit=velocity_limit)
    return atomic_write_text(path, text)
