"""Shared fixtures of the pytest suite, and the markers of its folders.

tests/python is in folders by area, each with a ``conftest.py`` that names the markers
(registered in pyproject.toml) of the modules saved in it (support/markers.py), so that a new
module is classified by where it is saved (a test module in a folder that names none fails the
run; CONTRIBUTING.md, "Where a new test module goes"):

- ``unit/`` and ``docs/``: no marker, the fast subset (``python -m pytest -m "not slow"
  tests/python``, CONTRIBUTING.md); with ``-m``, the modules of a folder the expression excludes
  are not even imported;
- ``slow``: the module runs whole simulations, FMUs, sweeps, the manual's blocks or processes
  (``model/``, ``fmu/``, ``jobs/``, ``docs/blocks/``, ``can/``);
- ``bus``: it starts CAN bench nodes or a socketcand server (``can/``);
- ``vm``: the test uses the QEMU guest (SocketCAN on a Linux kernel CAN stack): the cases of
  ``can/`` over the socketcan transport or that use the ``guest`` fixture.

Helpers used by one folder are saved in it; those of several in ``support/`` (a package:
``from support.fmu_support import ...``, ``from support import REPO``).
"""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest
import rrr_robot as rr

HERE = Path(__file__).resolve().parent
# support/ (the helpers of several folders) imports from every folder, whatever the import mode
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from support.markers import mark_items  # noqa: E402

# the writing task's plan cache (rrr_robot.writing.plan_cache) of this session: its own folder,
# shared by the processes the tests start, never the user's ~/.cache; removed at the end
_PLAN_CACHE = tempfile.mkdtemp(prefix="rrr-test-plan-cache-")
os.environ["RRR_CACHE_DIR"] = _PLAN_CACHE
os.environ.pop("RRR_NO_CACHE", None)
atexit.register(shutil.rmtree, _PLAN_CACHE, ignore_errors=True)


@pytest.hookimpl(tryfirst=True)  # before pytest's own -m deselection
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    mark_items(items, HERE)


@pytest.fixture(scope="session")
def model() -> rr.Model:
    """The default robot's model (immutable: shared by every test that reads it)."""
    return rr.Model.default()


@pytest.fixture
def cache_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder of this test's own (RRR_CACHE_DIR, the cache not turned off)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("RRR_CACHE_DIR", str(folder))
    monkeypatch.delenv("RRR_NO_CACHE", raising=False)
    return folder
