"""Argument types of the ``rrr`` command line: a malformed value is an argparse error (one line,
exit 2) before the command runs, so nothing is read, simulated or written."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["host_port", "nonnegative_int", "output_path", "positive_int"]


def output_path(text: str) -> Path:
    """A file or folder to write: not empty (an empty path would mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an output path must not be empty")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"not a path: {text!r}")
    return Path(text)


def _integer(text: str, least: int, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} expected, got {text!r}") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"{what} expected, got {value}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _integer(text, 1, "an integer >= 1")


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    return _integer(text, 0, "an integer >= 0")


def host_port(text: str) -> str:
    """``HOST:PORT`` with a host and a port from 1 to 65535; returned as given."""
    host, sep, port = text.rpartition(":")
    if not sep or not host.strip() or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(f"HOST:PORT expected (port 1 to 65535), got {text!r}")
    return text
