"""A CAN bench run as MCAP (``rrr hil bench|controller|plant --mcap``, docs/viewing.md): the
writing task's topics of the bench's signals (:func:`rrr_robot.core.mcap_log.write_mcap`) and

* ``/can/frames`` (``can_msgs/msg/Frame``): every frame of the node's frame log, its
  ``header.frame_id`` ``tx`` or ``rx`` (the logging node's direction);
* ``/can/decoded/<Message>`` (``std_msgs/msg/Float64MultiArray``): the physical values of each
  frame of a message of the profile's database (cantools), one layout dimension per signal,
  labelled with its name;
* ``/bench/faults`` (``std_msgs/msg/UInt32``): the plant's latched fault bits of each period
  (the DBC profile's ``PlantStatus.Faults``: timeout 1, crc 2, counter 4, range 8, format 16,
  sync 32, bus 64).

Every time is on the simulation clock: a frame's is the start of the period it was logged in,
the periods counted by the frames of one identifier the plant sends once per period (the DBC
profile's ``JointState1``; the frames before the first belong to period 0). The nodes' own clock
times stay in the frame log (``.blf``/``.asc``). The profile comes in as arguments (its
database, that identifier, its number of fault bits): this module knows none.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...core.mcap_log import SCHEMAS, CdrLayout, Topic, write_mcap
from ...core.robot import RobotFile
from ...errors import HilError

__all__ = ["FRAME_SCHEMA", "UINT32_SCHEMA", "bench_topics", "frame_periods", "write_bench_mcap"]

_SEP = "=" * 80 + "\n"
#: The ros2msg text of can_msgs/msg/Frame (ROS 2's ros2_canopen / ros-industrial can_msgs).
FRAME_SCHEMA = (
    "std_msgs/Header header\nuint32 id\nbool is_rtr\nbool is_extended\nbool is_error\n"
    "uint8 dlc\nuint8[8] data\n" + _SEP + SCHEMAS["sensor_msgs/msg/JointState"].split(_SEP, 1)[1])
UINT32_SCHEMA = "uint32 data\n"
_EXTENDED = 0x80000000


def frame_periods(records: np.ndarray, periods: int, period_id: int) -> np.ndarray:
    """The period index of each frame: the number of frames of ``period_id`` (one per period)
    up to it, less one (clipped to 0 .. periods - 1)."""
    is_state = (records["id"] & 0x1FFFFFFF) == period_id
    period: np.ndarray = np.clip(np.cumsum(is_state) - 1, 0, max(0, periods - 1))
    return period


def _frames_topic(records: np.ndarray, ns: np.ndarray) -> Topic:
    layout = CdrLayout()
    layout.header("tx", key="frame_id").field("id", "<u4").field("rtr", "u1").field("ext", "u1")
    layout.field("err", "u1").field("dlc", "u1").raw("data", 8)
    n = records.shape[0]
    direction = np.where(records["dir"][:, None] == 1, np.frombuffer(b"tx", np.uint8),
                         np.frombuffer(b"rx", np.uint8))
    data = np.zeros((n, 8), dtype=np.uint8)
    data[:] = records["data"]
    data[np.arange(8)[None, :] >= records["dlc"][:, None]] = 0
    msgs = layout.encode(n, {
        "sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000,
        "frame_id": direction, "id": records["id"] & 0x1FFFFFFF,
        "rtr": 0, "ext": (records["id"] & _EXTENDED) != 0, "err": 0, "dlc": records["dlc"],
        "data": data})
    return Topic("/can/frames", "can_msgs/msg/Frame", ns.astype(np.uint64), msgs, FRAME_SCHEMA)


def _decoded_topics(records: np.ndarray, ns: np.ndarray, db: Any) -> list[Topic]:
    ids = records["id"] & 0x1FFFFFFF
    topics = []
    for msg in db.messages:
        rows = np.flatnonzero((ids == msg.frame_id) & ((records["id"] & _EXTENDED) == 0))
        if rows.size == 0:
            continue
        names = [s.name for s in msg.signals]
        values = np.full((rows.size, len(names)), np.nan)
        for k, r in enumerate(rows):
            payload = bytes(records["data"][r][: int(records["dlc"][r])])
            try:
                decoded = msg.decode(payload, decode_choices=False)
            except Exception:  # a frame the DBC cannot decode (wrong DLC): NaN values
                continue
            values[k] = [float(decoded[name]) for name in names]
        layout = CdrLayout().u32(len(names))
        for name in names:
            layout.string(name).u32(1).u32(1)
        layout.u32(0).f64s([f"v{i}" for i in range(len(names))])
        msgs = layout.encode(rows.size, {f"v{i}": values[:, i] for i in range(len(names))})
        topics.append(Topic(f"/can/decoded/{msg.name}", "std_msgs/msg/Float64MultiArray",
                            ns[rows].astype(np.uint64), msgs))
    return topics


def bench_topics(records: np.ndarray, faults: FloatArray, t: FloatArray, db: Any, *,
                 period_id: int, fault_bits: int) -> list[Topic]:
    """The bench's extra topics of a run with rows at times ``t``: its frames (``records`` of a
    node's frame log), their signals decoded with ``db`` (a cantools database), and the plant's
    fault bits (one per row, each below 2 ** ``fault_bits``); ``period_id``: the identifier
    the plant sends once per period (:func:`frame_periods`)."""
    row_ns = np.rint(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64)
    ns = row_ns[frame_periods(records, row_ns.size, period_id)] if records.size else \
        np.zeros(0, dtype=np.int64)
    bits = np.asarray(faults, dtype=np.float64)
    if bits.shape != row_ns.shape or not np.all(
            np.isfinite(bits) & (bits >= 0) & (bits == np.rint(bits))
            & (bits < 2 ** fault_bits)):
        raise HilError("the plant log's faults are not fault bits, one per period")
    fault = CdrLayout().field("data", "<u4").encode(row_ns.size, {"data": bits.astype(np.uint32)})
    topics = [Topic("/bench/faults", "std_msgs/msg/UInt32", row_ns.astype(np.uint64), fault,
                    UINT32_SCHEMA)]
    if records.size:
        topics.append(_frames_topic(records, ns))
        topics.extend(_decoded_topics(records, ns, db))
    return topics


def write_bench_mcap(path: Path, columns: dict[str, FloatArray], robot: RobotFile,
                     records: np.ndarray, faults: FloatArray, db: Any, *, period_id: int,
                     fault_bits: int, metadata: dict[str, str] | None = None) -> Path:
    """The bench run's MCAP: the signal table's topics and :func:`bench_topics`."""
    extra: Sequence[Topic] = bench_topics(records, faults, columns["t"], db,
                                          period_id=period_id, fault_bits=fault_bits)
    meta: dict[str, Any] = dict(metadata or {})
    return write_mcap(path, columns, robot, metadata=meta, extra=extra)
