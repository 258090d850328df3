"""The CAN bench (hardware in the loop) from Python, with python-can and cantools.

protocol (the DBC, E2E-protected frames, encode / decode, the DBC's quantisation), nodes (the C
nodes as processes, python-can buses), bench (runs: both C nodes, the controller FMU against the
C plant node, the quantised co-simulation), plant (the plant FMU behind the C supervisor over
python-can), _hil_lib (ctypes binding of the C supervisor and frame decoder). The command line
(``rrr hil``) is in :mod:`rrr_robot.cli.hil`.
"""
