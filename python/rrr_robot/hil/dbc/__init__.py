"""The DBC profile of the CAN bench (``rrr hil bench|controller|plant``, docs/dbc.md): one DBC
describes every frame, E2E-protected; the C nodes in lockstep or real time, or either FMU under
FMPy over python-can against the other C node. The modules: ``protocol``, ``bench``,
``controller``, ``plant`` (with ``_supervisor``), ``sides``, ``results``."""
