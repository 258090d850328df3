"""Helpers of the pytest suite, importable from every test folder (tests/python is on sys.path:
tests/python/conftest.py). ``REPO``: the checkout's root, for tests that read its files."""

from pathlib import Path

#: The root of the checkout (tests/python/support/ is three folders below it).
REPO = Path(__file__).resolve().parents[3]
