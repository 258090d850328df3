"""The statuses of librrr (``rrr_status``, c_src/rrr/include/rrr/rrr_status.h) and the package's
exception for each: the compiled binding (``_ext``) reads these tables when it is imported and
builds its exceptions from them; the Python callers of a status it returns (``_lib``, the plant's
rollout, the closed loop in parts) raise through :func:`raise_for`, with the same messages.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NoReturn

from ..errors import (
    BadInputError,
    ModelError,
    NumericError,
    RrrError,
    SingularError,
    UnreachableError,
)

#: ``rrr_status`` names by value (``rrr_status_str``)
STATUS_NAMES = (
    "RRR_OK",
    "RRR_BAD_INPUT",
    "RRR_BAD_MODEL",
    "RRR_NOT_POSITIVE_DEFINITE",
    "RRR_UNREACHABLE",
    "RRR_SINGULAR",
    "RRR_NUMERIC",
    "RRR_TOO_STIFF",
)

#: the exception class of each non-OK status (RrrError for any other value)
ERRORS: dict[int, type[RrrError]] = {
    1: BadInputError,
    2: ModelError,
    3: ModelError,
    4: UnreachableError,
    5: SingularError,
    6: NumericError,
    7: ModelError,
}

#: what each non-OK status means, in the messages
MEANING: dict[int, str] = {
    1: "bad input (NULL, NaN/Inf or out-of-range argument)",
    2: "invalid model parameter",
    3: "inertia matrix D(q) is not positive definite",
    4: "target is outside the workspace",
    5: "singular configuration",
    6: "result would be non-finite",
    7: "the plant is too stiff for its integrator at a bounded cost",
}


def raise_for(name: str, status: int, context: str | Callable[[], str] = "") -> NoReturn:
    """Raise the exception for a non-OK status of C function ``name``; ``context`` (a string, or
    a callable building it) is appended to the message."""
    cls = ERRORS.get(status, RrrError)
    sname = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
    text = context() if callable(context) else context
    detail = f": {text}" if text else ""
    raise cls(f"{name} failed with {sname} ({MEANING.get(status, '?')}){detail}", name, sname)
