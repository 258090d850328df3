"""Independent numeric references for the paper's Figs 5 and 6: Pinocchio's recursive
Newton-Euler inverse dynamics on the same robot and the Robotics Toolbox's numeric IK
(trajectory.numeric_ik_path); :func:`numeric_references` computes both (figure_worker computes
them in a forked process while the co-simulations run).

Optional dependencies: ``pip install 'rrr_robot[verify]'`` (pin, roboticstoolbox-python).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.inertial import Inertial, dh_links, dh_transform, inertial_from_robot
from ..core.model import Model
from ..core.robot import RobotFile
from .trajectory import Reference, numeric_ik_path

__all__ = ["Inertial", "NumericReferences", "inertial_from_robot", "numeric_references",
           "pinocchio_inverse_dynamics", "pinocchio_model"]


def pinocchio_model(dh: Mapping[str, float], g: float, inertial: Inertial) -> Any:
    """A Pinocchio model of the arm: revolute-z joints placed by the DH transforms, link inertias
    moved from DH frame i into joint i's frame, rotor inertias as armature."""
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


def pinocchio_inverse_dynamics(dh: Mapping[str, float], g: float, inertial: Inertial,
                               q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
    """Motor torque (rigid body + rotor inertia) by Pinocchio's rnea, one row per sample."""
    import pinocchio as pin

    model = pinocchio_model(dh, g, inertial)
    data = model.createData()
    return np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(q.shape[0])])


@dataclass(frozen=True)
class NumericReferences:
    """The numeric references of Figs 5 and 6 along a writing reference: the Robotics Toolbox's
    IK of its tip path and Pinocchio's inverse dynamics of its joint motion; None where one
    could not be computed, with the reason (a missing optional package, a robot file without
    link tables)."""

    ik: FloatArray | None
    tau: FloatArray | None
    ik_skipped: str = ""
    tau_skipped: str = ""


def numeric_references(model: Model, robot: RobotFile, ref: Reference) -> NumericReferences:
    """Compute both references in this process (imports roboticstoolbox and pinocchio)."""
    ik: FloatArray | None = None
    tau: FloatArray | None = None
    ik_skipped = tau_skipped = ""
    try:
        ik = numeric_ik_path(model, ref.x, ref.q[0])
    except ImportError:
        ik_skipped = ("roboticstoolbox-python is not installed (pip install "
                      "'rrr_robot[verify]')")
    inertial = inertial_from_robot(robot)
    if inertial is None:
        tau_skipped = "the robot file gives base parameters, not link inertias"
    else:
        try:
            tau = pinocchio_inverse_dynamics(model.dh, model.g, inertial, ref.q, ref.qd, ref.qdd)
        except ImportError:
            tau_skipped = "Pinocchio is not installed (pip install 'rrr_robot[verify]')"
    return NumericReferences(ik, tau, ik_skipped, tau_skipped)

