"""unit/: the fast tests (a module takes a few seconds at most, in this process): the model,
its files and tables, the batch kernels and the binding, the CLI's help and argument checks,
the API, the version, the generated tables (DBC codec, CANopen object dictionary, FMU
variables). No marker: ``python -m pytest -m "not slow" tests/python`` runs them."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__)
