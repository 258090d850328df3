"""The DBC profile of the CAN bench (``rrr hil bench|controller|plant``, docs/dbc.md): one DBC
describes every frame, E2E-protected; the C nodes in lockstep or real time, or either FMU under
FMPy over python-can against the other C node. The modules: ``protocol``, ``bench``,
``controller``, ``plant`` (with ``_supervisor``), ``sides``, ``results``; :func:`busload`: its
schedule (``rrr hil busload``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..busload import BusLoad, BusloadOptions


def busload(options: BusloadOptions) -> BusLoad:
    """The load of the DBC's schedule (periods from its ``GenMsgCycleTime``; ``options.dbc``:
    another DBC; ``options.lockstep``: with the lockstep-only frames) on the bus of
    ``options``; BadInputError for ``sync_period_ms`` or a DBC that cantools cannot read."""
    import cantools

    from ...errors import BadInputError, one_line
    from ..busload import schedule_load
    from .protocol import DBC_PATH, database

    if options.sync_period_ms is not None:
        raise BadInputError("--sync-period-ms applies to --profile canopen only (the DBC's "
                            "periods are its GenMsgCycleTime)")
    if options.dbc is not None:
        try:
            db = cantools.database.load_file(str(options.dbc))
        except (cantools.database.errors.Error, ValueError, KeyError) as exc:
            raise BadInputError(f"--dbc {options.dbc}: not a DBC cantools reads: "
                                f"{one_line(exc)}") from exc
    else:
        db = database()
    return schedule_load(db, options.bitrate, options.data_bitrate, lockstep=options.lockstep,
                         dbc_name=str(options.dbc or DBC_PATH))
