"""Shared fixtures and the markers of the pytest suite.

Markers (registered in pyproject.toml), given here per module so that a new module must be
classified (collection fails otherwise):

- ``slow``: the module runs whole simulations, FMUs, sweeps, the manual's blocks or processes;
  ``python -m pytest -m "not slow" tests/python`` is the fast subset (CONTRIBUTING.md);
- ``bus``: it starts CAN bench nodes or a socketcand server;
- ``vm``: it boots a QEMU guest (SocketCAN on a Linux kernel CAN stack).
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest
import rrr_robot as rr

# the writing task's plan cache (rrr_robot.writing.plan_cache) of this session: its own folder,
# shared by the processes the tests start, never the user's ~/.cache; removed at the end
_PLAN_CACHE = tempfile.mkdtemp(prefix="rrr-test-plan-cache-")
os.environ["RRR_CACHE_DIR"] = _PLAN_CACHE
os.environ.pop("RRR_NO_CACHE", None)
atexit.register(shutil.rmtree, _PLAN_CACHE, ignore_errors=True)

#: The modules of the fast subset: the model, its files and tables, the CLI's argument checks,
#: the API and version checks (each a few seconds at most).
FAST = frozenset({
    "test_api_docs", "test_batch", "test_batch_out", "test_cli_help", "test_default_robot",
    "test_docs_map",
    "test_ext_binding",
    "test_fk_frames", "test_hil_codec", "test_identify_errors", "test_kinematics",
    "test_linearize", "test_model_api", "test_plant_api", "test_robot_file",
    "test_scenario_file", "test_startup_imports", "test_sweep_spec", "test_tables",
    "test_trajectory", "test_version", "test_habits", "test_fmu_vars", "test_log_formats",
    "test_canopen_od",
})
#: The modules that start CAN bench nodes or a socketcand server.
BUS = frozenset({
    "test_hil_bench", "test_hil_busload", "test_hil_cli", "test_hil_faults",
    "test_hil_python_plant", "test_hil_results", "test_hostile_inputs", "test_mcap",
    "test_socketcan_guest", "test_hil_canopen", "test_hil_canopen_master",
    "test_hil_canopen_realtime", "test_canopen_conformance", "test_node_launchers",
    "test_lsbus",
})
#: The modules that boot a QEMU guest.
VM = frozenset({"test_socketcan_guest"})
#: Every other module is slow; these are named so that an unclassified new module is noticed.
SLOW = frozenset({
    "test_animation", "test_bench_extra", "test_c_exports", "test_cli_errors", "test_doc_blocks",
    "test_dynamics_reference", "test_figures", "test_fmu_derivatives", "test_fmu_error_routing",
    "test_fmu_errors", "test_fmu_libcosim", "test_fmu_reuse", "test_fmu_loop", "test_fmu_package",
    "test_fmu_reference", "test_fmu_start_values", "test_fmu_state",
    "test_fmu_variants", "test_lsbus_fmus",
    "test_friction_methods", "test_generated_code", "test_hostile_archives",
    "test_hostile_sweeps", "test_identify_pipeline", "test_identify_threads",
    "test_native_engine", "test_native_signals", "test_plan_cache", "test_notebook", "test_outputs",
    "test_plant_fmu", "test_plant_integrator", "test_progress", "test_ssp", "test_sweep_dask",
    "test_sweep_examples", "test_text_layout", "test_urdf", "test_view", "test_writing",
    "test_writing_engine",
}) | (BUS - FAST)


def _module_marks(name: str) -> set[str]:
    return ({"slow"} if name in SLOW else set()) | ({"bus"} if name in BUS else set()) | (
        {"vm"} if name in VM else set())


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """With ``-m``, a module whose markers (all given per module, above) the expression
    excludes is not even imported: ``-m "not slow"`` does not pay for the imports of the slow
    modules (Pinocchio, MuJoCo, Drake, FMPy's masters)."""
    expression = config.getoption("markexpr")
    name = collection_path.stem
    if not expression or collection_path.suffix != ".py" or name not in FAST | SLOW:
        return None
    from _pytest.mark.expression import Expression

    marks = _module_marks(name)
    return False if Expression.compile(expression).evaluate(marks.__contains__) else True


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    unclassified = set()
    for item in items:
        name = item.path.stem
        if name not in FAST and name not in SLOW:
            unclassified.add(name)
        for mark in sorted(_module_marks(name)):
            item.add_marker(getattr(pytest.mark, mark))
    if unclassified:
        raise pytest.UsageError(
            f"tests/python/conftest.py: classify {sorted(unclassified)} as FAST or SLOW")


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
