"""The CANopen profile's drives (docs/canopen.md): the EDS ``data/rrr_cia402.eds`` (generated
with the C object dictionary by tools/gen_canopen_od.py) and the periodic frames of the
schedule it implies for three drives, read from the EDS's default PDO mapping and heartbeat
time (the standard library's INI reader: the EDS is an INI file, CiA 306).

One SYNC period of the bench: the master's SYNC (0x80, no data), each drive's RPDO1 (master to
drive) and its TPDOs of transmission type n (1 to 240: one every n SYNCs); every 0x1017 ms each
drive's heartbeat and the master's (1 byte). SDO, EMCY and NMT frames are sent on events.
"""

from __future__ import annotations

import configparser
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..core import fmu_vars as fv
from ..core._package import DATA_DIR
from ..errors import BadInputError

__all__ = ["DEFAULT_NODE_IDS", "EDS_PATH", "ScheduledFrame", "canopen_schedule"]

#: The EDS of one drive (shipped in the package; installed by CMake in share/rrr/).
EDS_PATH = DATA_DIR / "rrr_cia402.eds"
#: The node ids of the three axes (rrr_hil_plant --profile canopen's default): node i drives
#: joint i.
DEFAULT_NODE_IDS: tuple[int, ...] = fv.JOINTS
#: The master's node id for its heartbeat (0x700 + id).
MASTER_NODE_ID = 0x7F


@dataclass(frozen=True)
class ScheduledFrame:
    """A periodic frame, with the attributes busload.schedule_load reads of a DBC message."""

    frame_id: int
    name: str
    length: int
    cycle_time: float  # ms
    is_extended_frame: bool = False


def _value(eds: configparser.ConfigParser, section: str, node_id: int = 0) -> int:
    try:
        text = eds[section]["DefaultValue"].strip()
    except KeyError as exc:
        raise BadInputError(f"the EDS has no [{section}] DefaultValue") from exc
    plus = 0
    if text.upper().startswith("$NODEID"):
        plus, text = node_id, text[len("$NODEID"):].lstrip("+ ") or "0"
    try:
        return int(text, 0) + plus
    except ValueError as exc:
        raise BadInputError(f"the EDS's [{section}] DefaultValue {text!r} is not a number") \
            from exc


def _mapped_bytes(eds: configparser.ConfigParser, index: int) -> int:
    n = _value(eds, f"{index:04X}sub0")
    bits = sum(_value(eds, f"{index:04X}sub{i:X}") & 0xFF for i in range(1, n + 1))
    if bits % 8 or bits > 64:
        raise BadInputError(f"the EDS maps {bits} bits into PDO 0x{index:04X}: not whole bytes "
                            "within 8")
    return bits // 8


def canopen_schedule(period_ms: float = 1.0, node_ids: Sequence[int] = DEFAULT_NODE_IDS,
                     eds_path: Path = EDS_PATH) -> list[ScheduledFrame]:
    """The periodic frames of ``node_ids`` drives of the EDS with one SYNC every ``period_ms``
    ms, each with its period; the master's heartbeat at the drives' 0x1017."""
    if not period_ms > 0:
        raise BadInputError(f"the SYNC period must be > 0 ms, not {period_ms}")
    eds = configparser.ConfigParser(interpolation=None)
    eds.optionxform = str  # type: ignore[assignment,method-assign]
    if not eds.read(eds_path, encoding="utf-8"):
        raise BadInputError(f"cannot read the EDS {eds_path}")
    frames = [ScheduledFrame(0x080, "SYNC", 0, period_ms)]
    hb_ms = float(_value(eds, "1017"))
    for node in node_ids:
        for comm, mapping, name in ((0x1400, 0x1600, "RPDO1"), (0x1800, 0x1A00, "TPDO1"),
                                    (0x1801, 0x1A01, "TPDO2")):
            if f"{comm:04X}" not in eds:
                continue
            cob = _value(eds, f"{comm:04X}sub1", node)
            kind = _value(eds, f"{comm:04X}sub2")
            if cob & 0x80000000:
                continue  # not valid
            every = kind if 1 <= kind <= 240 else 1  # RPDO type 0 or 254/255: sent each period
            frames.append(ScheduledFrame(cob & 0x7FF, f"{name} node {node}",
                                         _mapped_bytes(eds, mapping), period_ms * every))
        if hb_ms > 0:
            frames.append(ScheduledFrame(0x700 + node, f"heartbeat {node}", 1, hb_ms))
    if hb_ms > 0:
        frames.append(ScheduledFrame(0x700 + MASTER_NODE_ID, "heartbeat master", 1, hb_ms))
    return sorted(frames, key=lambda f: (f.frame_id, f.name))
