"""A run's signal table as an MCAP file with ROS 2 messages (rosbag2's storage format), for
Foxglove, Lichtblick, Rerun, RViz and ``ros2 bag``: :func:`write_mcap` (docs/viewing.md).

Topics, on the simulation clock (log time = header stamp = the table's ``t`` in ns):

* ``/robot_description`` (std_msgs/msg/String, once, latched): the URDF of :func:`robot_urdf`;
* ``/tf_static`` (tf2_msgs/msg/TFMessage, once, latched): the fixed transforms ``link<k>`` ->
  ``dh_frame<k>`` (k = 1, 2) and ``link3`` -> ``tool`` (DH frame 3, the pen tip);
* ``/tf`` (tf2_msgs/msg/TFMessage): ``base_link`` -> ``link1`` -> ``link2`` -> ``link3``, the
  URDF's joints at the table's q (so base_link is DH frame 0 and every DH frame is in the tree);
* ``/joint_states`` (sensor_msgs/msg/JointState): q, qd and the motor torque
  k_t (sat(u) - u_f(qd)) (``Model.torque_from_voltage``) as effort;
  ``/joint_accelerations`` (std_msgs/msg/Float64MultiArray): qdd;
* ``/reference/joint_states`` (JointState: q_ref, qd_ref), ``/reference/tip`` and ``/tip``
  (geometry_msgs/msg/PointStamped in ``base_link``): the reference and the pen's path;
* ``/control/u``, ``/control/u_n``, ``/control/u_c`` (Float64MultiArray): the voltages;
* any other column group ``name[1..3]`` as ``/signals/name`` (Float64MultiArray).

Only the topics whose columns the table has are written (``t`` and ``q[1..3]`` are required).
The messages are encoded as CDR for a whole column at once with numpy (each topic's messages
have one fixed layout, so a run's rows become one byte matrix), and laid into the MCAP container
the same way (:mod:`.mcap_bulk`, with the ``mcap`` package's record classes). Values are
written as they are: a diverged run's NaN stays NaN, as in its CSV.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BadInputError
from . import fmu_vars
from ._arrays import FloatArray
from .inertial import dh_links, dh_transform
from .mcap_bulk import Block, Stream, write_container
from .outputs import atomic_open
from .robot import RobotFile, read_robot_file
from .urdf import robot_urdf

__all__ = ["SCHEMAS", "TOPICS", "CdrLayout", "Topic", "require_mcap", "write_mcap"]

JOINTS = ("joint1", "joint2", "joint3")
_SEP = "=" * 80 + "\n"
_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
_HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
_POINT = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
#: The ros2msg schema text of every message type written (main definition, then dependencies).
SCHEMAS: dict[str, str] = {
    "std_msgs/msg/String": "string data\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n" + _SEP + _HEADER + _SEP + _TIME),
    "geometry_msgs/msg/PointStamped": (
        "std_msgs/Header header\ngeometry_msgs/Point point\n" + _SEP + _HEADER + _SEP + _TIME
        + _SEP + _POINT),
    "std_msgs/msg/Float64MultiArray": (
        "std_msgs/MultiArrayLayout layout\nfloat64[] data\n" + _SEP
        + "MSG: std_msgs/MultiArrayLayout\nstd_msgs/MultiArrayDimension[] dim\n"
          "uint32 data_offset\n" + _SEP
        + "MSG: std_msgs/MultiArrayDimension\nstring label\nuint32 size\nuint32 stride\n"),
    "tf2_msgs/msg/TFMessage": (
        "geometry_msgs/TransformStamped[] transforms\n" + _SEP
        + "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\n"
          "geometry_msgs/Transform transform\n" + _SEP
        + "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\n"
          "geometry_msgs/Quaternion rotation\n" + _SEP
        + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n" + _SEP
        + "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n" + _SEP
        + _HEADER + _SEP + _TIME),
}
#: The fixed topics and their types (``/signals/<name>`` are Float64MultiArray too).
TOPICS: dict[str, str] = {
    "/robot_description": "std_msgs/msg/String",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/joint_accelerations": "std_msgs/msg/Float64MultiArray",
    "/reference/joint_states": "sensor_msgs/msg/JointState",
    "/reference/tip": "geometry_msgs/msg/PointStamped",
    "/tip": "geometry_msgs/msg/PointStamped",
    "/control/u": "std_msgs/msg/Float64MultiArray",
    "/control/u_n": "std_msgs/msg/Float64MultiArray",
    "/control/u_c": "std_msgs/msg/Float64MultiArray",
}
# rosbag2's QoS of a latched topic (transient local durability): players and viewers that read
# offered_qos_profiles give late subscribers the one message
_LATCHED_QOS = (
    "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 1\n  deadline:\n"
    "    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n"
    "    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n"
    "    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false\n")
_GROUPS = ("q", "qd", "qdd", "q_ref", "qd_ref", "u", "u_n", "u_c")


def require_mcap() -> None:
    """BadInputError naming the extra to install when the ``mcap`` package is missing."""
    try:
        import mcap.records  # noqa: F401
        import zstandard  # noqa: F401
    except ImportError:
        raise BadInputError("MCAP output needs the mcap package: pip install "
                            "'rrr_robot[mcap]'") from None


class CdrLayout:
    """One message layout in little-endian CDR: fixed bytes and named per-row fields.

    Offsets align relative to the end of the 4-byte encapsulation header, as CDR does."""

    def __init__(self) -> None:
        self.buf = bytearray(b"\x00\x01\x00\x00")
        self.fields: list[tuple[str, int, str]] = []

    def _align(self, n: int) -> None:
        self.buf += b"\x00" * (-(len(self.buf) - 4) % n)

    def u32(self, value: int) -> CdrLayout:
        self._align(4)
        self.buf += struct.pack("<I", value)
        return self

    def string(self, text: str) -> CdrLayout:
        data = text.encode() + b"\x00"
        self.u32(len(data))
        self.buf += data
        return self

    def header(self, frame_id: str, key: str | None = None) -> CdrLayout:
        """std_msgs/Header: the stamp's fields ``sec`` and ``nanosec`` per row; the frame id
        fixed, or per row as field ``key`` (bytes of the length of ``frame_id``)."""
        self._align(4)
        self.fields += [("sec", len(self.buf), "<i4"), ("nanosec", len(self.buf) + 4, "<u4")]
        self.buf += bytes(8)
        if key is None:
            return self.string(frame_id)
        self.u32(len(frame_id.encode()) + 1)
        self.raw(key, len(frame_id.encode()))
        self.buf += b"\x00"
        return self

    def field(self, key: str, dtype: str) -> CdrLayout:
        """A number per row (``<u4``, ``u1``, ...), aligned to its size."""
        size = np.dtype(dtype).itemsize
        self._align(size)
        self.fields.append((key, len(self.buf), dtype))
        self.buf += bytes(size)
        return self

    def raw(self, key: str, size: int) -> CdrLayout:
        """``size`` bytes per row (a fixed uint8[size] array, or a string's characters)."""
        self.fields.append((key, len(self.buf), f"V{size}"))
        self.buf += bytes(size)
        return self

    def f64(self, key: str) -> CdrLayout:
        self._align(8)
        self.fields.append((key, len(self.buf), "<f8"))
        self.buf += bytes(8)
        return self

    def f64s(self, keys: Sequence[str]) -> CdrLayout:
        self.u32(len(keys))
        for key in keys:
            self.f64(key)
        return self

    def encode(self, n: int, values: Mapping[str, ArrayLike]) -> np.ndarray:
        """The n messages as an (n, size) byte matrix; ``values`` maps each field to n values
        (or a scalar)."""
        out = np.empty((n, len(self.buf)), dtype=np.uint8)
        out[:] = np.frombuffer(bytes(self.buf), dtype=np.uint8)
        for key, offset, dtype in self.fields:
            width = np.dtype(dtype).itemsize
            if dtype.startswith("V"):
                out[:, offset:offset + width] = values[key]
            else:
                out[:, offset:offset + width].view(dtype)[:, 0] = values[key]
        return out


def _float_array(label: str) -> CdrLayout:
    cdr = CdrLayout().u32(1).string(label).u32(3).u32(1).u32(0)   # one dimension: 3 joints
    return cdr.f64s(("0", "1", "2"))


def _joint_state(with_effort: bool) -> CdrLayout:
    cdr = CdrLayout().header("").u32(len(JOINTS))
    for name in JOINTS:
        cdr.string(name)
    cdr.f64s(("p0", "p1", "p2")).f64s(("v0", "v1", "v2"))
    return cdr.f64s(("e0", "e1", "e2") if with_effort else ())


def _tf_layout(frames: Sequence[tuple[str, str]], prefix: str) -> CdrLayout:
    cdr = CdrLayout().u32(len(frames))
    for k, (parent, child) in enumerate(frames):
        cdr.header(parent).string(child)
        for axis in ("tx", "ty", "tz", "rx", "ry", "rz", "rw"):
            cdr.f64(f"{prefix}{k}.{axis}")
    return cdr


def _quat(rot: FloatArray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation matrix (the DH placements: rotations about x)."""
    w = 0.5 * math.sqrt(max(0.0, 1.0 + rot[0, 0] + rot[1, 1] + rot[2, 2]))
    x = math.copysign(0.5 * math.sqrt(max(0.0, 1.0 + rot[0, 0] - rot[1, 1] - rot[2, 2])),
                      rot[2, 1] - rot[1, 2])
    y = math.copysign(0.5 * math.sqrt(max(0.0, 1.0 - rot[0, 0] + rot[1, 1] - rot[2, 2])),
                      rot[0, 2] - rot[2, 0])
    z = math.copysign(0.5 * math.sqrt(max(0.0, 1.0 - rot[0, 0] - rot[1, 1] + rot[2, 2])),
                      rot[1, 0] - rot[0, 1])
    return x, y, z, w


def _joint_transforms(dh: Mapping[str, float], q: FloatArray) -> dict[str, FloatArray]:
    """The fields of /tf: link<k-1> -> link<k> is the DH placement of frame k-1 (the URDF
    joint's origin) turned by q_k about z: translation fixed, rotation quat(placement) * (0, 0,
    sin(q_k / 2), cos(q_k / 2))."""
    values: dict[str, FloatArray] = {}
    placements = [(np.eye(3), np.zeros(3))] + [dh_transform(*link) for link in dh_links(dh)]
    for k in range(3):
        rot, pos = placements[k]
        px, py, pz, pw = _quat(rot)
        sz, cz = np.sin(0.5 * q[:, k]), np.cos(0.5 * q[:, k])
        values |= {f"j{k}.tx": np.full(q.shape[0], pos[0]), f"j{k}.ty": np.full(q.shape[0], pos[1]),
                   f"j{k}.tz": np.full(q.shape[0], pos[2]),
                   f"j{k}.rx": px * cz + py * sz, f"j{k}.ry": py * cz - px * sz,
                   f"j{k}.rz": pw * sz + pz * cz, f"j{k}.rw": pw * cz - pz * sz}
    return values


def _static_transforms(dh: Mapping[str, float]) -> tuple[list[tuple[str, str]],
                                                         dict[str, float]]:
    frames = [("link1", "dh_frame1"), ("link2", "dh_frame2"), ("link3", "tool")]
    values: dict[str, float] = {}
    for k, link in enumerate(dh_links(dh)):
        rot, pos = dh_transform(*link)
        quat = _quat(rot)
        for axis, v in zip(("tx", "ty", "tz", "rx", "ry", "rz", "rw"), (*pos, *quat),
                           strict=True):
            values[f"s{k}.{axis}"] = float(v)
    return frames, values


def _column(columns: Mapping[str, ArrayLike], name: str, n: int) -> FloatArray:
    arr = np.asarray(columns[name], dtype=np.float64)
    if arr.shape != (n,):
        raise BadInputError(f"column {name!r} has shape {arr.shape}, the table has {n} rows")
    return arr


def _groups(columns: Mapping[str, ArrayLike], n: int) -> dict[str, FloatArray]:
    """Every column group name[1], name[2], name[3] as an (n, 3) array."""
    out: dict[str, FloatArray] = {}
    for key in columns:
        if key.endswith("[1]"):
            name = key[:-3]
            parts = [f"{name}[{i}]" for i in fmu_vars.JOINTS]
            if all(p in columns for p in parts):
                out[name] = np.stack([_column(columns, p, n) for p in parts], axis=1)
    for name in ("x_ref", "tip"):
        parts = fmu_vars.axis_names(name)
        if all(p in columns for p in parts):
            out[name] = np.stack([_column(columns, p, n) for p in parts], axis=1)
    return out


def _stamps(t: FloatArray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    if t.size == 0:
        raise BadInputError("the table has no rows")
    if not np.all(np.isfinite(t)) or t.min() < 0.0 or t.max() > 2.0**31:
        raise BadInputError("column 't' must be finite times in [0, 2^31) s (the simulation "
                            "clock of the MCAP's messages)")
    if np.any(np.diff(t) < 0):
        raise BadInputError("column 't' must not decrease (the rows are the run's samples)")
    ns = np.rint(t * 1e9).astype(np.int64)
    return ns, {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


@dataclass(frozen=True)
class Topic:
    """Messages of one more topic: ``data`` (n, size) CDR messages (e.g. ``CdrLayout.encode``)
    at the log times ``ns`` (n,) (uint64 ns, non-decreasing) of the simulation clock;
    ``schema``: its ros2msg text when the type is not one of ``SCHEMAS``."""

    name: str
    msgtype: str
    ns: np.ndarray
    data: np.ndarray
    schema: str = ""
    latched: bool = False


def write_mcap(path: str | Path, columns: Mapping[str, ArrayLike],
               robot: RobotFile | str | Path | None = None, *,
               metadata: Mapping[str, str] | None = None, extra: Sequence[Topic] = ()) -> Path:
    """Write a result table (name -> column, e.g. ``CosimResult.columns()`` or
    ``read_csv_table``) as MCAP with the topics of the module doc, atomically; ``robot`` (default:
    the packaged robot) gives the URDF, the DH placements and the motor model; ``metadata`` is
    written as an MCAP metadata record ``rrr_robot``; ``extra``: more topics on their own times
    (the CAN bench's frames and faults). Returns the path."""
    for more in extra:
        if more.msgtype not in SCHEMAS and not more.schema:
            raise BadInputError(f"topic {more.name}: no schema for {more.msgtype}")
        if more.ns.shape[0] != more.data.shape[0] or np.any(np.diff(more.ns.astype(
                np.int64)) < 0):
            raise BadInputError(f"topic {more.name}: one non-decreasing time per message")
    require_mcap()
    robot_file = robot if isinstance(robot, RobotFile) else \
        read_robot_file(robot) if robot is not None else read_robot_file()
    if "t" not in columns:
        raise BadInputError("the table has no column 't'")
    t = np.asarray(columns["t"], dtype=np.float64)
    n = t.shape[0] if t.ndim == 1 else -1
    if n < 0:
        raise BadInputError(f"column 't' must be one-dimensional, got shape {t.shape}")
    ns, stamp = _stamps(t)
    groups = _groups(columns, n)
    if "q" not in groups:
        raise BadInputError("the table has no joint angles q[1], q[2], q[3]")
    urdf = robot_urdf(robot_file)
    model = robot_file.model
    dh = model.dh
    streams: list[tuple[str, np.ndarray]] = []   # (topic, (n, size) messages)
    tf = [("base_link", "link1"), ("link1", "link2"), ("link2", "link3")]
    streams.append(("/tf", _tf_layout(tf, "j").encode(n, stamp | _joint_transforms(dh,
                                                                                    groups["q"]))))
    zeros = np.zeros((n, 3))
    q, qd = groups["q"], groups.get("qd", zeros)
    state: dict[str, Any] = dict(stamp)
    state |= {f"p{i}": q[:, i] for i in range(3)} | {f"v{i}": qd[:, i] for i in range(3)}
    effort = np.full((n, 3), np.nan)   # a row whose qd or u is not finite: NaN
    if "u" in groups:
        ok = np.all(np.isfinite(qd), axis=1) & np.all(np.isfinite(groups["u"]), axis=1)
        if np.any(ok):
            effort[ok] = model.torque_from_voltage(qd[ok], groups["u"][ok])
    state |= {f"e{i}": effort[:, i] for i in range(3)}
    streams.append(("/joint_states", _joint_state("u" in groups).encode(n, state)))
    if "q_ref" in groups:
        ref = dict(stamp) | {f"p{i}": groups["q_ref"][:, i] for i in range(3)}
        ref |= {f"v{i}": groups.get("qd_ref", zeros)[:, i] for i in range(3)}
        streams.append(("/reference/joint_states", _joint_state(False).encode(n, ref)))
    for group, topic in (("x_ref", "/reference/tip"), ("tip", "/tip")):
        if group in groups:
            point = CdrLayout().header("base_link").f64("x").f64("y").f64("z")
            xyz = groups[group]
            streams.append((topic, point.encode(n, stamp | {"x": xyz[:, 0], "y": xyz[:, 1],
                                                              "z": xyz[:, 2]})))
    arrays = {"qdd": "/joint_accelerations", "u": "/control/u", "u_n": "/control/u_n",
              "u_c": "/control/u_c"}
    for group, values in groups.items():
        if group in ("q", "qd", "q_ref", "qd_ref", "x_ref", "tip"):
            continue
        topic = arrays.get(group, f"/signals/{group}")
        streams.append((topic, _float_array("joint").encode(n, {str(i): values[:, i]
                                                                for i in range(3)})))
    frames, static = _static_transforms(dh)
    first_stamp: dict[str, Any] = {"sec": stamp["sec"][:1], "nanosec": stamp["nanosec"][:1]}
    static_msg = _tf_layout(frames, "s").encode(1, first_stamp | static)
    description = CdrLayout().string(urdf).encode(1, {})
    t0 = ns[:1]
    topics: list[Topic] = [
        Topic("/robot_description", "std_msgs/msg/String", t0, description, latched=True),
        Topic("/tf_static", "tf2_msgs/msg/TFMessage", t0, static_msg, latched=True),
        *(Topic(topic, TOPICS.get(topic, "std_msgs/msg/Float64MultiArray"), ns, msgs)
          for topic, msgs in streams), *extra]
    schema_ids: dict[str, int] = {}
    channels = []
    for cid, tp in enumerate(topics, start=1):
        schema_ids.setdefault(tp.msgtype, len(schema_ids) + 1)
        channels.append((cid, tp.name, "cdr", schema_ids[tp.msgtype],
                         {"offered_qos_profiles": _LATCHED_QOS} if tp.latched else {}))
    texts = SCHEMAS | {t.msgtype: t.schema for t in topics if t.schema}
    schemas = [(sid, kind, "ros2msg", texts[kind].encode()) for kind, sid in schema_ids.items()]
    # the latched messages, then the run's rows, then each extra topic: equal times keep this
    # order in the file
    blocks = [Block(topics[0].ns, [Stream(1, topics[0].data)]),
              Block(topics[1].ns, [Stream(2, topics[1].data)]),
              Block(ns, [Stream(3 + k, msgs) for k, (_, msgs) in enumerate(streams)]),
              *(Block(t.ns, [Stream(3 + len(streams) + k, t.data)])
                for k, t in enumerate(extra))]
    meta = {"rrr_robot": {str(k): str(v) for k, v in metadata.items()}} if metadata else {}
    with atomic_open(path, "wb") as fh:
        write_container(fh, profile="ros2", library=f"rrr_robot {_version()}", schemas=schemas,
                        channels=channels, blocks=blocks, metadata=meta)
    return Path(path)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rrr_robot")
    except PackageNotFoundError:  # run from a source tree
        return "(source)"
