"""The CANopen profile of the CAN bench (``rrr hil canopen``, docs/canopen.md): the C plant node
as three CiA 402 drives, mastered by the canopen package or by the C controller node, in
lockstep or real time. The modules: ``drives``, ``master``, ``c_master``, ``realtime``,
``results``; :func:`busload`: its schedule (``rrr hil busload --profile canopen``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..busload import BusLoad, BusloadOptions


def busload(options: BusloadOptions) -> BusLoad:
    """The load of the drives' schedule (:func:`rrr_robot.hil.canopen.drives.canopen_load`: the
    EDS's PDOs, one SYNC every ``options.sync_period_ms``, default 1 ms) on the bus of
    ``options``; BadInputError for ``dbc`` or ``lockstep``, which do not apply."""
    from ...errors import BadInputError
    from .drives import canopen_load

    if options.dbc is not None or options.lockstep:
        raise BadInputError("--profile canopen: the schedule is the EDS's (SYNC always "
                            "included): --dbc and --lockstep do not apply")
    period = options.sync_period_ms if options.sync_period_ms is not None else 1.0
    return canopen_load(options.bitrate, options.data_bitrate, period_ms=period)
