"""Fast start: ``rrr --help``, ``rrr fmus`` and ``import rrr_robot`` load none of the heavy
libraries (each subcommand imports its library modules when it runs), while the re-exported
names (``rr.Model``, ...) still work. A correctness test of sys.modules in a fresh interpreter,
not a timing test (bench/bench_startup.py measures the time)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numpy", "scipy", "matplotlib", "fmpy", "cantools", "can", "pandas", "pyarrow",
         "dask", "distributed")


def _loaded_after(code: str, tmp_path) -> list[str]:
    """The heavy top-level packages in sys.modules after running ``code`` in a new interpreter
    (started in an empty folder, so the installed rrr_robot is the one imported)."""
    script = (f"{code}\nimport json, sys\n"
              f"print('LOADED:' + json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, check=True,
                         capture_output=True, text=True, timeout=120).stdout
    line = [x for x in out.splitlines() if x.startswith("LOADED:")][-1]
    return json.loads(line.removeprefix("LOADED:"))


@pytest.mark.parametrize("code", [
    "import rrr_robot",
    "import rrr_robot.cli",
    "import rrr_robot.core, rrr_robot.core.outputs, rrr_robot.sim.fmus",
    "import rrr_robot.identify, rrr_robot.writing, rrr_robot.sim, rrr_robot.hil",
    "from rrr_robot.cli import build_parser; build_parser()",
])
def test_import_loads_nothing_heavy(code, tmp_path):
    assert _loaded_after(code, tmp_path) == []


@pytest.mark.parametrize("argv", [
    ["--help"], ["--version"], ["fmus"], ["writing", "--help"], ["identify", "--help"],
    ["identify-experiment", "--help"], ["hil", "--help"], ["urdf", "--help"],
])
def test_cli_start_loads_nothing_heavy(argv, tmp_path):
    code = ("from rrr_robot.cli import main\n"
            f"try:\n    status = main({argv!r})\nexcept SystemExit as exc:\n"
            "    status = exc.code\nassert status in (0, None), status")
    assert _loaded_after(code, tmp_path) == []


def test_rrr_fmus_lists_the_fmus_without_numpy(tmp_path):
    code = ("import contextlib, io\nfrom rrr_robot.cli import main\nbuf = io.StringIO()\n"
            "with contextlib.redirect_stdout(buf):\n    assert main(['fmus']) == 0\n"
            "assert 'rrr_plant.fmu' in buf.getvalue(), buf.getvalue()")
    assert _loaded_after(code, tmp_path) == []


def test_lazy_names_resolve(tmp_path):
    """Every name a package's __all__ promises can be imported, and an unknown one is an
    AttributeError (not a KeyError or an import of something else)."""
    code = """
import importlib
for pkg in ("rrr_robot", "rrr_robot.core", "rrr_robot.identify"):
    mod = importlib.import_module(pkg)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, (pkg, name)
        assert name in dir(mod), (pkg, name)
    try:
        mod.no_such_name
    except AttributeError:
        pass
    else:
        raise AssertionError(pkg)
import rrr_robot as rr
from rrr_robot import Model, read_robot_file
from rrr_robot.core import DEFAULT_SAMPLE_TIME
from rrr_robot.identify import Log
assert rr.Model is Model and Model.default().p.shape == (16,)
assert rr.read_robot_file is read_robot_file and DEFAULT_SAMPLE_TIME > 0
assert Log.__module__ == "rrr_robot.identify.logs"
"""
    loaded = _loaded_after(code, tmp_path)
    assert "numpy" in loaded and "scipy" in loaded  # the names were really imported


def test_python_m_rrr_robot_help(tmp_path):
    out = subprocess.run([sys.executable, "-m", "rrr_robot", "--help"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "writing" in out.stdout


@pytest.mark.parametrize("argv", [
    ["identify", "--log", "missing.csv", "--out", "robot.toml"],
    ["identify-experiment", "--robot", "missing.toml", "--out", "logs"],
])
def test_an_identification_input_error_comes_before_the_solvers(argv, tmp_path):
    """A missing input of ``rrr identify`` (-experiment) is reported before SciPy's signal
    filters, optimisers and integrators are imported (the slow part of its start): they load
    when a log is filtered, a curve fitted or an experiment designed."""
    code = ("import sys\nfrom rrr_robot.cli import main\n"
            f"assert main({argv!r}) == 2\n"
            "slow = ('scipy.signal', 'scipy.optimize', 'scipy.integrate')\n"
            "assert not [m for m in slow if m in sys.modules], [m for m in slow if m in "
            "sys.modules]")
    assert "numpy" in _loaded_after(code, tmp_path)  # the library was imported, the solvers not
