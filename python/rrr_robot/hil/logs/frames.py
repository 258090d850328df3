"""Frame logs of the CAN bench: the C nodes' compact log read back, written as a standard CAN
log (Vector ASC or BLF, through python-can's writers) and read back with ``can.LogReader``.

A C node started with ``--frame-log FILE`` (``c_src/hil/transport/hil_framelog.h``) records every
frame its transport sent (Tx) and received (Rx), each with the CLOCK_REALTIME time at which the
transport call returned, as 24-byte records after the magic ``RRRCAN1\\n``. The bench's view is
that node's: the C controller's in ``rrr hil bench`` and ``rrr hil plant``, the C plant's in
``rrr hil controller``. :func:`read_node_log` reads such a file, :func:`write_can_log` converts it
to ``.asc`` or ``.blf`` (the files CANalyzer, CANoe, SavvyCAN, asammdf and python-can open), and
:func:`compare` checks a standard log against the node's frame by frame.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...core.outputs import atomic_path
from ...errors import BadInputError, HilError

__all__ = [
    "CAN_LOG_FORMATS",
    "MAGIC",
    "RECORD",
    "check_can_log_path",
    "compare",
    "frames",
    "messages",
    "read_can_log",
    "read_node_log",
    "traffic",
    "write_can_log",
]

MAGIC = b"RRRCAN1\n"
#: One record of the node's log (hil_framelog.h).
RECORD = np.dtype([("t_ns", "<i8"), ("id", "<u4"), ("dlc", "u1"), ("dir", "u1"),
                   ("pad", "u1", (2,)), ("data", "u1", (8,))])
#: The standard formats written, by suffix.
CAN_LOG_FORMATS = (".asc", ".blf")
_EXTENDED = 0x80000000
#: s: the timestamps of a written log agree with the node's to this (ASC prints microseconds)
TIME_TOLERANCE = 1.5e-6


def check_can_log_path(path: Path) -> Path:
    """A standard log to write: suffix .asc or .blf (BadInputError otherwise)."""
    if path.suffix.lower() not in CAN_LOG_FORMATS:
        raise BadInputError(f"--can-log {path}: the frame log is .asc or .blf (Vector ASC or "
                            "BLF, read by python-can's can.LogReader and CAN analysis tools)")
    return path


def read_node_log(path: Path) -> np.ndarray:
    """The records of a node's frame log (structured array of RECORD); HilError when the file
    is not one, or ends inside a record."""
    raw = Path(path).read_bytes()
    if not raw.startswith(MAGIC):
        raise HilError(f"{path}: not a frame log of a bench node (no {MAGIC!r} header)")
    body = raw[len(MAGIC):]
    if len(body) % RECORD.itemsize:
        raise HilError(f"{path}: {len(body)} bytes of records, not a multiple of "
                       f"{RECORD.itemsize}: the log was cut off")
    records = np.frombuffer(body, dtype=RECORD)
    if np.any(records["dlc"] > 8) or np.any(records["dir"] > 1):
        raise HilError(f"{path}: a record with DLC > 8 or an unknown direction")
    return records


def messages(records: np.ndarray) -> Iterator[Any]:
    """The records as ``can.Message`` objects (channel 0; is_rx from the direction)."""
    import can

    for r in records:
        raw_id = int(r["id"])
        dlc = int(r["dlc"])
        yield can.Message(timestamp=int(r["t_ns"]) * 1e-9, arbitration_id=raw_id & 0x1FFFFFFF,
                          is_extended_id=bool(raw_id & _EXTENDED), dlc=dlc,
                          data=bytes(r["data"][:dlc]), is_rx=not bool(r["dir"]), channel=0)


def frames(records: np.ndarray, direction: int | None = None) -> list[tuple[int, bytes, bool]]:
    """(identifier, data, extended) of the records, of one direction (0 Rx, 1 Tx) or all."""
    sel = records if direction is None else records[records["dir"] == direction]
    return [(int(r["id"]) & 0x1FFFFFFF, bytes(r["data"][:int(r["dlc"])]),
             bool(int(r["id"]) & _EXTENDED)) for r in sel]


def write_can_log(records: np.ndarray, path: Path) -> Path:
    """Write the records as a Vector ASC (``.asc``) or BLF (``.blf``) log with python-can's
    writers, atomically (core.outputs)."""
    import can

    path = check_can_log_path(Path(path))
    writer_type = can.ASCWriter if path.suffix.lower() == ".asc" else can.BLFWriter
    with atomic_path(path) as tmp:
        writer = writer_type(str(tmp))
        try:
            for msg in messages(records):
                writer.on_message_received(msg)
        finally:
            writer.stop()
    return path


def read_can_log(path: Path) -> list[Any]:
    """Every message of a standard log, through ``can.LogReader``."""
    import can

    return list(can.LogReader(str(path)))


def compare(records: np.ndarray, read_back: Sequence[Any]) -> str | None:
    """None when ``read_back`` (messages of a standard log) holds the records frame for frame:
    same count, and per frame the identifier, format, DLC, data and direction, and the time
    since the first frame within TIME_TOLERANCE; otherwise what differs first."""
    if len(read_back) != len(records):
        return f"{len(read_back)} frames read back, the node logged {len(records)}"
    if not len(records):
        return None
    t0_node = int(records["t_ns"][0]) * 1e-9
    t0_log = float(read_back[0].timestamp)
    for k, (want, got) in enumerate(zip(messages(records), read_back, strict=True)):
        fields = [("arbitration_id", want.arbitration_id, got.arbitration_id),
                  ("is_extended_id", want.is_extended_id, got.is_extended_id),
                  ("dlc", want.dlc, got.dlc), ("data", bytes(want.data), bytes(got.data)),
                  ("is_rx", want.is_rx, got.is_rx)]
        for name, a, b in fields:
            if a != b:
                return f"frame {k}: {name} {b!r}, the node logged {a!r}"
        dt = abs((want.timestamp - t0_node) - (float(got.timestamp) - t0_log))
        if dt > TIME_TOLERANCE:
            return f"frame {k}: time differs by {dt:.3g} s"
    return None


def traffic(records: np.ndarray, periods: int, realtime: bool) -> dict[str, Any]:
    """Frames of a log in total, per direction and per identifier, and per control period of
    the ``periods`` the run had. In real time also per second of the log's wall-clock span
    (``duration_s``): there the periods are 1 ms apart. A lockstep run has no rate per second: its
    periods follow each other as fast as the nodes compute, so frames per wall-clock second
    would measure the machine, not the bus."""
    n = len(records)
    span = (int(records["t_ns"][-1]) - int(records["t_ns"][0])) * 1e-9 if n > 1 else 0.0

    def per_s(count: int) -> float | None:
        return count / span if span > 0 else None

    ids, counts = np.unique(records["id"] & 0x1FFFFFFF, return_counts=True)
    out: dict[str, Any] = {
        "frames": n, "frames_per_period": n / periods if periods > 0 else None,
        "tx": int(np.count_nonzero(records["dir"] == 1)),
        "rx": int(np.count_nonzero(records["dir"] == 0)),
    }
    by_id: dict[str, dict[str, Any]] = {}
    for i, c in zip(ids, counts, strict=True):
        entry: dict[str, Any] = {"frames": int(c),
                                 "per_period": int(c) / periods if periods > 0 else None}
        if realtime:
            entry["per_second"] = per_s(int(c))
        by_id[f"0x{int(i):03X}"] = entry
    if realtime:
        out |= {"duration_s": span, "frames_per_second": per_s(n)}
    out["by_id"] = by_id
    return out
