"""The CAN bench (hardware in the loop) from Python, with python-can, cantools and canopen; the
command line (``rrr hil``) is :mod:`rrr_robot.cli.hil`.

One folder per CAN profile, the profiles of the C nodes (:data:`PROFILES`, read from
``RRR_HIL_PROFILES``); each package's ``busload`` gives its schedule to ``rrr hil busload``
(:func:`rrr_robot.hil.busload.profile_load`):

- ``dbc/``: the DBC profile (``rrr hil bench|controller|plant``): ``protocol`` (the DBC, its
  E2E-protected frames, their codec and quantisation), ``bench`` (both C nodes; the quantised
  co-simulation), ``controller`` and ``plant`` (the controller FMU and the plant FMU under FMPy
  against the other C node; ``_supervisor``: the C supervisor the Python plant calls through
  ctypes), ``sides`` (each side as one library call), ``results`` (its files);
- ``canopen/``: the CANopen profile (``rrr hil canopen``): ``drives`` (the C plant node as
  three CiA 402 drives: EDS, PDO units, schedule), ``master`` (the canopen package's master),
  ``c_master`` (the C controller node as master), ``realtime``, ``results``.

``lsbus/`` (``rrr ls-bus``) runs the DBC profile's two nodes as FMI-LS-BUS network FMUs in an
fmucontainer under FMPy, and writes its results with ``dbc.results``.

Shared by both: ``logs/`` (``frames``: the nodes' frame logs as ASC/BLF; ``specs``: the nodes'
CSV logs, column by column; ``mcap``: a run as MCAP), ``nodes`` (the C nodes as processes,
python-can buses, the bench's period), ``results`` (a run against its reference, summary.json),
``figures``, ``busload`` (frame lengths and the load of a schedule) and ``channel`` (the default
bus name). The errors are in :mod:`rrr_robot.errors` (``HilError`` and its subclasses).
"""

from __future__ import annotations

from ..core._package import PACKAGE_DIR

__all__ = ["PROFILES", "PROFILES_FILE"]

#: The list of the CAN profiles, one name a line, the default first: ``RRR_HIL_PROFILES`` of
#: c_src/hil/CMakeLists.txt, which the build writes and installs beside the C nodes.
PROFILES_FILE = PACKAGE_DIR / "bin" / "hil_profiles.txt"


def _profiles() -> dict[str, str]:
    try:
        names = PROFILES_FILE.read_text(encoding="utf-8").split()
    except FileNotFoundError:  # a package folder that was not built: rrr hil busload says so
        return {}
    return {name: f"{__name__}.{name}" for name in names}


#: The CAN profiles (``rrr hil busload --profile``), by name: the package of each, imported when
#: used. A new profile is its folder in c_src/hil and its word in ``RRR_HIL_PROFILES``, its
#: package here, its page of the manual and its test (CONTRIBUTING.md).
PROFILES: dict[str, str] = _profiles()
