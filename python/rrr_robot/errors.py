"""Exceptions of rrr_robot: one root, split by what went wrong."""

from __future__ import annotations

__all__ = [
    "ArchiveError",
    "BadInputError",
    "BusLost",
    "CosimError",
    "EmcyError",
    "FrameError",
    "HilError",
    "ModelError",
    "NumericError",
    "OutputError",
    "RobotFileError",
    "RrrError",
    "ScenarioError",
    "SingularError",
    "SweepSpecError",
    "TamperedError",
    "UnreachableError",
]


def without_traceback(text: str) -> str:
    """``text`` up to a traceback written into it (python-can's socketcand bus writes one into
    its CanError's message, and into its log line, when its peer goes away)."""
    return text.partition("Traceback (most recent call last)")[0].rstrip(" :")


def one_line(exc: BaseException, limit: int = 0) -> str:
    """An exception's message on one line, for an error line of the CLI or a row of results
    (the package's own helper, not in ``__all__``): white space collapsed (an FMU's or a
    parser's message may span lines), an embedded traceback cut off (``without_traceback``),
    the exception's type name when nothing is left; at most ``limit`` characters when ``limit``
    > 0."""
    text = " ".join(without_traceback(str(exc)).split()).rstrip(" :")
    text = text or type(exc).__name__
    return text if limit <= 0 or len(text) <= limit else text[:limit - 3] + "..."


class RrrError(Exception):
    """Root of every error raised by rrr_robot.

    ``function`` names the C function (or FMU call) that failed, ``status`` its status name.
    ``exit_status``: what ``rrr`` returns for it (2; docs/outputs.md).
    """

    exit_status = 2

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


class OutputError(RrrError, OSError):
    """A file or folder of the results could not be written (a full disk, a used-up quota, a
    read-only file system, no permission): the message names it and what to do; ``errno`` is
    the system's (an OSError, so code that handles a failed write still does)."""


class SingularError(RrrError, ValueError):
    """A singular configuration where the requested quantity does not exist."""


class NumericError(RrrError, ArithmeticError):
    """A result would be non-finite (e.g. the integration diverged)."""


class CosimError(RrrError):
    """An FMU call failed during co-simulation (names the FMU and the time)."""


# ---- the CAN bench (rrr hil) ----------------------------------------------------------------


class HilError(RrrError):
    """A bench node failed, or the bench protocol was violated (names the node and period)."""


class FrameError(HilError, ValueError):
    """Decoding: a frame that is not a valid bench frame; ``reason`` is 'unknown id', 'wrong
    DLC' or 'E2E CRC mismatch'."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


class TamperedError(HilError):
    """During a run: a frame the other node never sends came (a second TPDO of a drive in one
    SYNC, a TPDO whose length is not its mapping's, a JointState twice in one lockstep period):
    the inputs were tampered with, or a node is broken. The message names the node and the
    frame; ``rrr`` returns 8 for it (the C controller's RRR_HIL_EXIT_TAMPERED)."""

    exit_status = 8


class BusLost(HilError):
    """During a run: the bus failed, or the other node went silent, at ``period``."""

    def __init__(self, message: str, period: int) -> None:
        super().__init__(message)
        self.period = period


class EmcyError(HilError):
    """During a run: a CANopen drive sent an EMCY (``node``, its error ``code``) at SYNC
    ``sync``."""

    def __init__(self, sync: int, node: int, code: int) -> None:
        super().__init__(f"SYNC {sync}: EMCY 0x{code:04X} from drive {node}")
        self.sync, self.node, self.code = sync, node, code
