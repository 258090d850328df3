"""The independent numeric reference of the paper's Figs 5 and 6: MuJoCo, a rigid-body engine we
did not write, on a model of the same robot built from its DH geometry and link tables. Fig 5:
its forward kinematics and Jacobian of the tip, solved for the joint angles by MuJoCo's own
least-squares solver (``mujoco.minimize.least_squares``), each row seeded with the previous
solution; Fig 6: its inverse dynamics (``mj_inverse``, the rotor inertias as armature).
:func:`numeric_references` computes both (figure_worker computes them in a forked process while
the co-simulations run).

MuJoCo's core (``mujoco-core``, about 30 MB, numpy its only dependency) is a dependency of the
package; Pinocchio (:func:`pinocchio_model`), the Robotics Toolbox and Drake check the same
quantities in the tests and benchmarks (the ``test`` and ``bench`` extras).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core._arrays import FloatArray
from ..core.inertial import Inertial, dh_links, dh_transform, inertial_from_robot
from ..core.model import Model
from ..core.robot import RobotFile
from ..errors import NumericError
from .trajectory import Reference

__all__ = ["Inertial", "NumericReferences", "inertial_from_robot", "mujoco_inverse_dynamics",
           "mujoco_mjcf", "numeric_ik_path", "numeric_references", "pinocchio_model"]


def _nums(values: ArrayLike) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def mujoco_mjcf(dh: Mapping[str, float], g: float, inertial: Inertial | None) -> str:
    """The arm as MJCF: revolute-z joints placed by the DH transforms, link inertias moved from
    DH frame i into joint i's frame, rotor inertias as armature, the tip a site ``tip`` at DH
    frame 3. Without ``inertial`` (a robot file with base parameters only) every link is a unit
    point mass: enough for the kinematics (Fig 5), not for the dynamics."""
    body = ""
    close = ""
    placement: tuple[FloatArray, FloatArray] = (np.eye(3), np.zeros(3))
    for i, (d, a, alpha) in enumerate(dh_links(dh)):
        rot0, pos0 = placement
        rot, pos = dh_transform(d, a, alpha)
        if inertial is None:
            mass, com, inertia, rotor = 1.0, pos, 1e-3 * np.eye(3), 0.0
        else:
            mass = float(inertial.masses[i])
            com = pos + rot @ inertial.coms[i]
            inertia = rot @ inertial.inertias_com[i] @ rot.T
            rotor = float(inertial.rotor[i])
        full = (inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
                inertia[1, 2])
        body += (f'<body name="link{i + 1}" pos="{_nums(pos0)}" '
                 f'xyaxes="{_nums(rot0[:, 0])} {_nums(rot0[:, 1])}">'
                 f'<joint name="joint{i + 1}" type="hinge" axis="0 0 1" '
                 f'armature="{rotor!r}"/>'
                 f'<inertial pos="{_nums(com)}" mass="{mass!r}" fullinertia="{_nums(full)}"/>')
        close += "</body>"
        placement = (rot, pos)
    rot, pos = placement
    tip = f'<site name="tip" pos="{_nums(pos)}" xyaxes="{_nums(rot[:, 0])} {_nums(rot[:, 1])}"/>'
    return ('<mujoco model="rrr"><compiler angle="radian" autolimits="true"/>'
            f'<option gravity="0 0 {-g!r}"><flag contact="disable"/></option>'
            f"<worldbody>{body}{tip}{close}</worldbody></mujoco>")


def _mujoco() -> Any:
    import mujoco

    return mujoco


def mujoco_inverse_dynamics(dh: Mapping[str, float], g: float, inertial: Inertial,
                            q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
    """Motor torque (rigid body + rotor inertia) by MuJoCo's mj_inverse, one row per sample."""
    mj = _mujoco()
    model = mj.MjModel.from_xml_string(mujoco_mjcf(dh, g, inertial))
    data = mj.MjData(model)
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[k], qd[k], qdd[k]
        mj.mj_inverse(model, data)
        out[k] = data.qfrc_inverse
    return out


def pinocchio_model(dh: Mapping[str, float], g: float, inertial: Inertial) -> Any:
    """A Pinocchio model of the arm, built as :func:`mujoco_mjcf` builds MuJoCo's: the tests'
    and benchmarks' reference (``pin``, in the ``test`` and ``bench`` extras)."""
    import pinocchio as pin

    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -g])
    parent, placement = 0, pin.SE3.Identity()
    for i, (d, a, alpha) in enumerate(dh_links(dh)):
        joint = model.addJoint(parent, pin.JointModelRZ(), placement, f"joint{i + 1}")
        rot, pos = dh_transform(d, a, alpha)
        com = pos + rot @ inertial.coms[i]
        inertia = rot @ inertial.inertias_com[i] @ rot.T
        model.appendBodyToJoint(joint, pin.Inertia(inertial.masses[i], com, inertia),
                                pin.SE3.Identity())
        parent, placement = joint, pin.SE3(rot, pos)
    model.armature = np.asarray(inertial.rotor, dtype=float)
    return model


def numeric_ik_path(model: Model, x: ArrayLike, q_seed: ArrayLike,
                    tol: float = 1e-13) -> FloatArray:
    """Numeric IK of every row of x (n, 3): MuJoCo's forward kinematics and tip Jacobian
    (``mj_kinematics``, ``mj_comPos``, ``mj_jacSite``) of the model's DH chain, solved by MuJoCo's
    Levenberg-Marquardt least squares, each row seeded with the previous solution. A row whose
    tip misses its target by more than ``tol`` m raises NumericError."""
    mj = _mujoco()
    from mujoco import minimize

    mjm = mj.MjModel.from_xml_string(mujoco_mjcf(model.dh, model.g, None))
    data = mj.MjData(mjm)
    jac = np.empty((3, mjm.nv))
    targets = np.atleast_2d(np.asarray(x, dtype=float))
    target = targets[0]

    def tip(q: FloatArray) -> FloatArray:
        data.qpos[:] = q
        mj.mj_kinematics(mjm, data)
        return np.asarray(data.site_xpos[0], dtype=float)

    def residual(qs: FloatArray) -> FloatArray:
        return np.stack([tip(qs[:, j]) - target for j in range(qs.shape[1])], axis=1)

    def jacobian(q: FloatArray, _r: FloatArray) -> FloatArray:
        tip(q[:, 0])
        mj.mj_comPos(mjm, data)  # mj_jacSite reads the joint axes it computes
        mj.mj_jacSite(mjm, data, jac, None, 0)
        return jac.copy()

    q = np.asarray(q_seed, dtype=float).copy()
    out = np.empty_like(targets)
    for i, target in enumerate(targets):
        q, _ = minimize.least_squares(q, residual, jacobian=jacobian, xtol=1e-15, gtol=1e-20,
                                      verbose=0)
        miss = float(np.linalg.norm(tip(q) - target))
        if not miss <= tol:
            raise NumericError(f"MuJoCo's IK did not converge at row {i}, x = "
                               f"{target.tolist()} (tip {miss:.1e} m off)", "mujoco ik")
        out[i] = q
    return out


@dataclass(frozen=True)
class NumericReferences:
    """The numeric references of Figs 5 and 6 along a writing reference: MuJoCo's IK of its tip
    path and MuJoCo's inverse dynamics of its joint motion (None, with the reason, for a robot
    file without link tables)."""

    ik: FloatArray
    tau: FloatArray | None
    tau_skipped: str = ""


def numeric_references(model: Model, robot: RobotFile, ref: Reference) -> NumericReferences:
    """Compute both references in this process."""
    ik = numeric_ik_path(model, ref.x, ref.q[0])
    inertial = inertial_from_robot(robot)
    if inertial is None:
        return NumericReferences(ik, None,
                                 "the robot file gives base parameters, not link inertias")
    tau = mujoco_inverse_dynamics(model.dh, model.g, inertial, ref.q, ref.qd, ref.qdd)
    return NumericReferences(ik, tau)
