"""The links as an independent reference needs them (Pinocchio's model, the URDF export): the
full inertial data of a robot file's link tables as arrays, beyond the 16 base parameters, and
the fixed part Tz(d_i) Tx(a_i) Rx(alpha_i) of each DH transform (docs/conventions.md)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._arrays import FloatArray
from .robot import RobotFile

__all__ = ["DH_ALPHA", "Inertial", "dh_links", "dh_transform", "inertial_from_robot"]

#: The DH twists alpha_i of the arm (rad): fixed by its design, not parameters.
DH_ALPHA = (math.pi / 2, 0.0, 0.0)


@dataclass(frozen=True)
class Inertial:
    """Full inertial data of a robot file: masses (3,), COMs in DH frame i (3, 3), inertia
    tensors about the COM on the axes of DH frame i (3, 3, 3), rotor inertias (3,)."""

    masses: FloatArray
    coms: FloatArray
    inertias_com: FloatArray
    rotor: FloatArray


def inertial_from_robot(robot: RobotFile) -> Inertial | None:
    """The link tables of a checked robot file, or None when it gives base parameters."""
    if robot.links is None or robot.rotor_inertia is None:
        return None
    return Inertial(
        masses=np.array([link.mass for link in robot.links]),
        coms=np.array([link.com for link in robot.links], dtype=float),
        inertias_com=np.array([np.diag(link.inertia_com) for link in robot.links], dtype=float),
        rotor=np.asarray(robot.rotor_inertia, dtype=float),
    )


def dh_links(dh: Mapping[str, float]) -> list[tuple[float, float, float]]:
    """(d_i, a_i, alpha_i) of the three DH transforms, from ``Model.dh``."""
    return [(dh["d1"], 0.0, DH_ALPHA[0]), (dh["d2"], dh["a2"], DH_ALPHA[1]),
            (dh["d3"], dh["a3"], DH_ALPHA[2])]


def dh_transform(d: float, a: float, alpha: float) -> tuple[FloatArray, FloatArray]:
    """Rotation and translation of Tz(d) Tx(a) Rx(alpha): frame i in the frame of joint i
    turned by q_i."""
    ca, sa = math.cos(alpha), math.sin(alpha)
    rot = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    return rot, np.array([a, 0.0, d])
