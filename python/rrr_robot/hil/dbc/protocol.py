"""The DBC profile's protocol: the DBC, the E2E-protected frames, and their codec (cantools).

One DBC, ``data/rrr_bench.dbc``, describes every frame; the C nodes' pack/unpack is generated
from the same file (``c_src/hil/dbc/gen``). Frames carry AUTOSAR E2E profile 2 protection: CRC-8/
AUTOSAR over bytes 1..7 and the message's DataID in byte 0, a 4-bit alive counter in byte 1.

Lockstep protocol (deterministic): the controller sends its heartbeat; the plant answers with the
state of period 0; then per period k the controller sends VoltageCmd(k) and Sync(k), and the
plant advances exactly one period and answers with the state of k + 1.

:func:`encode` and :func:`decode` build and check frames, :func:`frame_id` reads a message's
identifier from the DBC; :func:`quantise_state` and :func:`quantise_command` are what the DBC's
scaling does to the values a frame carries.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...core._package import DATA_DIR
from ...errors import FrameError

__all__ = [
    "DATA_IDS",
    "DBC_PATH",
    "EXIT_SAFETY",
    "FAULT_BITS",
    "database",
    "decode",
    "encode",
    "frame_id",
    "quantise_command",
    "quantise_state",
]

#: The bench's CAN database (DBC) shipped with the package.
DBC_PATH = DATA_DIR / "rrr_bench.dbc"
#: E2E DataIDs (also in the DBC's comment and c_src/hil/dbc/hil_codec.h).
DATA_IDS = {"VoltageCmd": 0x10, "StopCmd": 0x11, "JointState1": 0x21, "JointState2": 0x22,
            "JointState3": 0x23, "PlantStatus": 0x30}
#: Exit status of a bench run that completed while the safety policy fired (a fault latched, even
#: if reset later, or 0 V forced for a period): the C nodes' RRR_HIL_EXIT_SAFETY, also the status
#: of ``rrr hil bench|controller|plant`` (docs/can-bench.md, "Exit statuses").
EXIT_SAFETY = 7
#: Latched fault bits of PlantStatus.Faults.
FAULT_BITS = {"timeout": 1, "crc": 2, "counter": 4, "range": 8, "format": 16, "sync": 32,
              "bus": 64}


# ---- codec ----------------------------------------------------------------------------------


@functools.cache
def database() -> Any:
    """The bench's cantools database (loaded once)."""
    import cantools

    return cantools.database.load_file(str(DBC_PATH))


@functools.cache
def frame_id(name: str) -> int:
    """The identifier of the DBC's message ``name`` (KeyError for a name the DBC lacks)."""
    return int(database().get_message_by_name(name).frame_id)


def _crc(payload: bytes, name: str) -> int:
    from cantools.autosar.end_to_end import compute_profile2_crc

    crc = compute_profile2_crc(payload, DATA_IDS[name])
    if crc is None:  # cantools: payload too short for profile 2
        raise FrameError(f"{name}: no E2E CRC for {len(payload)} bytes", "wrong DLC")
    return crc


def encode(name: str, signals: Mapping[str, float], *, corrupt_crc: bool = False) -> Any:
    """A ``can.Message`` of message ``name`` with E2E CRC (strict: out-of-range values raise).

    ``corrupt_crc`` flips the CRC (fault injection).
    """
    import can

    msg = database().get_message_by_name(name)
    values = {"Crc": 0, **signals} if name in DATA_IDS else dict(signals)
    data = bytearray(msg.encode(values, strict=True))
    if name in DATA_IDS:
        data[0] = _crc(bytes(data), name) ^ (0xFF if corrupt_crc else 0)
    return can.Message(arbitration_id=msg.frame_id, data=data, is_extended_id=False)


def decode(message: Any) -> tuple[str, dict[str, float]]:
    """Name and physical signal values of a received frame; raises FrameError."""
    import cantools

    try:
        msg = database().get_message_by_frame_id(message.arbitration_id)
    except KeyError:
        raise FrameError(f"id 0x{message.arbitration_id:X} is not a bench frame",
                         "unknown id") from None
    if message.is_extended_id:
        raise FrameError(f"extended id 0x{message.arbitration_id:X}", "unknown id")
    data = bytes(message.data)
    if len(data) != msg.length:
        raise FrameError(f"{msg.name}: {len(data)} bytes, the DBC says {msg.length}", "wrong DLC")
    if msg.name in DATA_IDS and data[0] != _crc(data, msg.name):
        raise FrameError(f"{msg.name}: E2E CRC mismatch", "E2E CRC mismatch")
    try:
        values = msg.decode(data, decode_choices=False)
    except cantools.database.DecodeError as exc:
        raise FrameError(f"{msg.name}: {exc}", "wrong DLC") from exc
    return msg.name, values


def _quantise(name: str, signals: Mapping[str, float]) -> dict[str, float]:
    msg = database().get_message_by_name(name)
    values: dict[str, float] = msg.decode(msg.encode({"Crc": 0, **signals}, strict=True),
                                          decode_choices=False)
    return values


def quantise_state(q_qd: FloatArray) -> FloatArray:
    """(q, qd) as the controller reads them from the JointState frames (the DBC's scaling)."""
    meas = [_quantise(f"JointState{j + 1}", {"AliveCounter": 0, "Q": q_qd[j], "Qd": q_qd[3 + j]})
            for j in range(3)]
    return np.array([m["Q"] for m in meas] + [m["Qd"] for m in meas])


def quantise_command(u: FloatArray) -> FloatArray:
    """u as the plant reads it from a VoltageCmd frame (the DBC's scaling)."""
    cmd = _quantise("VoltageCmd", {"AliveCounter": 0, "Enable": 1, "ResetFault": 0,
                                   **{f"U{i + 1}": float(u[i]) for i in range(3)}})
    return np.array([cmd[f"U{i + 1}"] for i in range(3)])
