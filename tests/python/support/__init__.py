"""Helpers of the pytest suite, importable from every test folder (tests/python is on sys.path:
tests/python/conftest.py). ``REPO``: the checkout's root, for tests that read its files;
``default_signals``: the ``preexec_fn`` of a child that must stop on Ctrl-C or SIGTERM."""

import signal
from pathlib import Path

#: The root of the checkout (tests/python/support/ is three folders below it).
REPO = Path(__file__).resolve().parents[3]


def default_signals() -> None:
    """In the child: Ctrl-C and SIGTERM as in a terminal, even when pytest itself runs with
    SIGINT ignored (a background job of a non-interactive shell, a pytest-xdist worker), which
    the child would inherit (and Python respect)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
