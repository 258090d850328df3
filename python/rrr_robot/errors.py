"""Exceptions of rrr_robot: one root, split by what went wrong."""

from __future__ import annotations

__all__ = [
    "ArchiveError",
    "BadInputError",
    "CosimError",
    "ModelError",
    "NumericError",
    "RobotFileError",
    "RrrError",
    "ScenarioError",
    "SingularError",
    "SweepSpecError",
    "UnreachableError",
]


class RrrError(Exception):
    """Root of every error raised by rrr_robot.

    ``function`` names the C function (or FMU call) that failed, ``status`` its status name.
    """

    def __init__(self, message: str, function: str = "", status: str = "") -> None:
        super().__init__(message)
        self.function = function
        self.status = status


class BadInputError(RrrError, ValueError):
    """An argument is NaN/Inf, has the wrong shape or is out of range."""


class ArchiveError(BadInputError):
    """A zip archive (an SSP, an FMU) refused before anything in it is used: an entry name that
    could leave the extraction folder, a link, a duplicate, sizes or a compression ratio beyond
    the bounds of ``rrr_robot.core.archives``, or data that does not match its headers."""


class ModelError(RrrError, ValueError):
    """Model parameters are invalid (non-finite, k_t <= 0, D(q) not positive definite...)."""


class RobotFileError(ModelError, BadInputError):
    """A robot file (TOML) that cannot be read or breaks its schema (a ModelError and a
    BadInputError). The message names the file, the table and the key (and the index in an
    array); ``source``, ``table`` and ``key`` hold them ("" where they do not apply)."""

    def __init__(self, message: str, source: str = "", table: str = "", key: str = "") -> None:
        super().__init__(message)
        self.source, self.table, self.key = source, table, key


class ScenarioError(BadInputError):
    """A scenario file (TOML) of the writing task that cannot be read or breaks its schema, or a
    set of scenarios whose names collide; named like :class:`RobotFileError`."""

    def __init__(self, message: str, source: str = "", table: str = "", key: str = "") -> None:
        super().__init__(message)
        self.source, self.table, self.key = source, table, key


class SweepSpecError(BadInputError):
    """A sweep spec (TOML, ``rrr sweep``) that cannot be read or breaks its schema; named like
    :class:`RobotFileError`."""

    def __init__(self, message: str, source: str = "", table: str = "", key: str = "") -> None:
        super().__init__(message)
        self.source, self.table, self.key = source, table, key


class UnreachableError(RrrError, ValueError):
    """An inverse kinematics target lies outside the workspace."""


class SingularError(RrrError, ValueError):
    """A singular configuration where the requested quantity does not exist."""


class NumericError(RrrError, ArithmeticError):
    """A result would be non-finite (e.g. the integration diverged)."""


class CosimError(RrrError):
    """An FMU call failed during co-simulation (names the FMU and the time)."""
