"""The bench's default bus name (light: the command line reads it without loading numpy).

:data:`DEFAULT_CHANNEL` is the socketcand bus name the C nodes use without ``--channel``
(c_src/hil/nodes/hil_node.c) and the Python side's default: ``rrr hil ... --channel``,
:class:`rrr_robot.hil.dbc.sides.Connection` and :func:`rrr_robot.hil.nodes.open_bus`.
"""

from __future__ import annotations

__all__ = ["DEFAULT_CHANNEL"]

#: The socketcand bus name of the CAN bench (the C nodes' default, hil_node.c).
DEFAULT_CHANNEL = "bench0"
