"""The data log of an fmucontainer run (``-datalog``: ``<name>-datalog.csv``, one row per
container step and event iteration, each Binary value as hex) read back as the bus operations
every network FMU sent, and written as the bench's frame log and as a pcap.

A Tx_Data value is a new transmission in a row whose Tx_Clock column is ``1`` and whose value
differs from the column's previous transmission (the container logs a row per step, and a clock
stays ``1`` in the rows until the next event); the value of the first row is one too (the
initialization event's, released before the container logs its first row, which shows its clock
reset). Every value the network FMUs send differs from their previous one (alive counters).
Every value is walked by the operations' ``length`` (FMI-LS-BUS 1.0: several concatenated per
value, little-endian ``u32 opCode, u32 length``);
``datalog2pcap`` of fmu_manipulation_toolbox decodes the first operation of each value only
(and skips the initialization rows), :func:`write_pcap` writes every CAN Transmit.
"""

from __future__ import annotations

import csv
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core.outputs import atomic_path
from ...errors import HilError
from ..logs.frames import MAGIC, RECORD

__all__ = ["CAN_TRANSMIT", "CONFIGURATION", "FORMAT_ERROR", "Operation", "Transmission",
           "operations", "read_datalog", "write_node_log", "write_pcap"]

FORMAT_ERROR = 0x0001
CAN_TRANSMIT = 0x0010
CONFIGURATION = 0x0040
#: pcap link type of SocketCAN frames (what datalog2pcap writes, and Wireshark decodes)
LINKTYPE_CAN_SOCKETCAN = 227
_EXTENDED = 0x80000000


@dataclass(frozen=True)
class Operation:
    """One bus operation: its OP Code and its bytes (header included); of a CAN Transmit the
    identifier, the extended flag and the data."""

    opcode: int
    raw: bytes
    can_id: int = -1
    extended: bool = False
    data: bytes = b""


@dataclass(frozen=True)
class Transmission:
    """One Tx_Data value a network FMU released: the time, the sender (the column's FMU name)
    and its operations."""

    time: float
    sender: str
    ops: tuple[Operation, ...]


def operations(value: bytes) -> tuple[Operation, ...]:
    """The operations of one Binary value, walked by ``length``; HilError for a length below
    the header or past the end (the FMUs of this package never send one)."""
    ops: list[Operation] = []
    pos = 0
    while pos < len(value):
        if len(value) - pos < 8:
            raise HilError(f"a bus operation cut off after {len(value) - pos} bytes")
        opcode, length = struct.unpack_from("<II", value, pos)
        if length < 8 or pos + length > len(value):
            raise HilError(f"a bus operation (OP Code 0x{opcode:04x}) of length {length} at "
                           f"byte {pos} of a {len(value)}-byte value")
        raw = value[pos:pos + length]
        if opcode == CAN_TRANSMIT and length >= 16:
            can_id, ide, _rtr, n = struct.unpack_from("<IBBH", raw, 8)
            ops.append(Operation(opcode, raw, can_id, bool(ide), raw[16:16 + n]))
        else:
            ops.append(Operation(opcode, raw))
        pos += length
    return tuple(ops)


def read_datalog(path: Path) -> list[Transmission]:
    """Every transmission of the data log, in order (HilError when it is not one)."""
    try:
        with open(path, encoding="utf-8", newline="") as fh:
            reader = csv.DictReader(fh)
            fields = reader.fieldnames or []
            data_cols = [f for f in fields if f.endswith(".Tx_Data")]
            if "time" not in fields or not data_cols:
                raise HilError(f"{path}: not a data log of an LS-BUS container (no time and "
                               "*.Tx_Data columns)")
            out: list[Transmission] = []
            first = True
            last = dict.fromkeys(data_cols, "")
            for row in reader:
                for col in data_cols:
                    value = row.get(col) or ""
                    clock = row.get(col[: -len("Data")] + "Clock") == "1"
                    fresh = first or (clock and value != last[col])
                    if fresh:
                        last[col] = value
                    if fresh and value:
                        sender = col[: -len(".Tx_Data")]
                        out.append(Transmission(float(row["time"]), sender,
                                                operations(bytes.fromhex(value))))
                first = False
            return out
    except (OSError, UnicodeError, ValueError, csv.Error) as exc:
        raise HilError(f"cannot read the data log {path}: {exc}") from exc


def _frames(log: list[Transmission]) -> list[tuple[float, str, Operation]]:
    return [(tr.time, tr.sender, op) for tr in log for op in tr.ops if op.opcode == CAN_TRANSMIT]


def write_node_log(log: list[Transmission], tx: str, rx: str, path: Path) -> Path:
    """The bench's frame log (hil.logs.frames: RRRCAN1 records) of one node's view: the CAN
    Transmits of sender ``tx`` (its terminal, e.g. ``controller.CAN``) as Tx, those of ``rx``
    (the other node's terminal, or the bus simulation's terminal of this node) as Rx,
    timestamped with the simulation time."""
    frames = [f for f in _frames(log) if f[1] in (tx, rx)]
    rec = np.zeros(len(frames), dtype=RECORD)
    for i, (t, sender, op) in enumerate(frames):
        rec[i]["t_ns"] = round(t * 1e9)
        rec[i]["id"] = op.can_id | (_EXTENDED if op.extended else 0)
        rec[i]["dlc"] = len(op.data)
        rec[i]["dir"] = 1 if sender == tx else 0
        rec[i]["data"][: len(op.data)] = np.frombuffer(op.data, dtype=np.uint8)
    with atomic_path(path) as tmp:
        tmp.write_bytes(MAGIC + rec.tobytes())
    return path


def write_pcap(log: list[Transmission], path: Path, senders: tuple[str, ...] | None = None,
               ) -> int:
    """Every CAN Transmit of the senders (None: all) as a pcap of SocketCAN frames (link type
    227, the layout datalog2pcap writes: big-endian can_id with the EFF flag, length, 3 bytes
    of padding, data), timestamped with the simulation time; returns the frame count."""
    frames = [f for f in _frames(log) if senders is None or f[1] in senders]
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(struct.pack(">IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 0xFFFF,
                             LINKTYPE_CAN_SOCKETCAN))
        for t, _sender, op in frames:
            sec, usec = divmod(round(t * 1e6), 1_000_000)
            can_id = op.can_id | (_EXTENDED if op.extended else 0)
            packet = struct.pack(">IB3x", can_id, len(op.data)) + op.data
            fh.write(struct.pack(">IIII", sec, usec, len(packet), len(packet)) + packet)
    return len(frames)
