"""A robot file read once: :func:`read_robot_file` gives a frozen :class:`RobotFile` with the
:class:`Model` and the checked tables ([control], [writing], the link tables, ...). Every reader
of robot files in the package goes through here (or through :mod:`.robot_file`, which checks).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import RobotFileError
from .model import DEFAULT_ROBOT_TOML, Model
from .robot_file import ControlGains, LinkInertia, RobotData, parse_robot, read_robot_data

__all__ = ["RobotFile", "read_robot_file", "robot_file_from_dict"]


@dataclass(frozen=True)
class RobotFile:
    """A checked robot file and the model built from it.

    ``model``: the validated :class:`~rrr_robot.core.model.Model`; ``control``: the [control]
    gains and sample period (None without a [control] table); ``sample_time``: the sample
    period of the writing task's reference and of the co-simulation (s); ``writing``: the
    checked [writing] values, built into a WritingSpec by ``rrr_robot.writing``
    (``WritingSpec.from_robot``); ``links``, ``rotor_inertia``: the link tables (None when the
    file gives [base_parameters]); ``data``: everything, as
    :class:`~rrr_robot.core.robot_file.RobotData` (``data.tables()`` writes it back)."""

    source: str
    model: Model
    data: RobotData

    @property
    def control(self) -> ControlGains | None:
        return self.data.control

    @property
    def sample_time(self) -> float:
        return self.data.sample_time

    @property
    def writing(self) -> Mapping[str, Any]:
        return self.data.writing

    @property
    def links(self) -> tuple[LinkInertia, LinkInertia, LinkInertia] | None:
        return self.data.links

    @property
    def rotor_inertia(self) -> tuple[float, float, float] | None:
        return self.data.rotor_inertia

    def require_control(self) -> ControlGains:
        """[control], or RobotFileError naming the file when it has none."""
        if self.data.control is None:
            raise RobotFileError(f"{self.source}: missing table [control] (kp, kd; the writing "
                                 "task's PD gains)", self.source, "control", "")
        return self.data.control

    @classmethod
    def from_data(cls, data: RobotData) -> RobotFile:
        return cls(data.source, Model(data.raw_model(), validate=False), data)


def read_robot_file(path: str | Path = DEFAULT_ROBOT_TOML) -> RobotFile:
    """Read and check a robot file once (default: the packaged default robot); raises
    RobotFileError naming the file, the table and the key."""
    return RobotFile.from_data(read_robot_data(path))


def robot_file_from_dict(data: Mapping[str, Any], source: str = "robot data") -> RobotFile:
    """The same checks on the parsed tables of a robot file."""
    return RobotFile.from_data(parse_robot(data, source))
