"""Where the package's files are: the data files, and what CMake installs beside them.

CMake installs ``librrr.so``, ``librrr_hil_supervisor.so``, ``bin/`` (the CAN bench nodes) and
``fmus/`` into the package folder ``rrr_robot/`` (``install(... DESTINATION rrr_robot)``), and the
data files live in ``rrr_robot/data/``; modules in the subpackages find them from here.
"""

from __future__ import annotations

from pathlib import Path

#: The installed package folder ``rrr_robot/``.
PACKAGE_DIR = Path(__file__).parent.parent
#: ``rrr_robot/data/``: default_robot.toml, rrr_bench.dbc, scenarios/.
DATA_DIR = PACKAGE_DIR / "data"
