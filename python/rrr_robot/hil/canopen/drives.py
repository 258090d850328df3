"""The CANopen profile's drives (docs/canopen.md): the C plant node as three CiA 402 drives
(:func:`start_drives`), their EDS ``data/rrr_cia402.eds`` (generated with the C object
dictionary by tools/gen_canopen_od.py), the PDO mapping and units a master decodes, and the
periodic frames of the schedule the EDS implies for three drives, read from its default PDO
mapping and heartbeat time (the standard library's INI reader: the EDS is an INI file, CiA 306).

The PDO units (docs/canopen.md, "Units"): position and velocity in increments (2^20 per
revolution, 0x608F), target torque in per mille of the rated torque 0x6076 (mN m), computed as
the drive computes them. The same quantisation as co-simulation hooks
(:func:`pdo_quantisation`) gives a run's exact reference.

One SYNC period of the bench: the master's SYNC (0x80, no data), each drive's RPDO1 (master to
drive) and its TPDOs of transmission type n (1 to 240: one every n SYNCs); every 0x1017 ms each
drive's heartbeat and the master's (1 byte). SDO, EMCY and NMT frames are sent on events.
:func:`canopen_load` is that schedule's load on a bus (``rrr hil busload --profile canopen``).
"""

from __future__ import annotations

import configparser
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core import fmu_vars as fv
from ...core._arrays import FloatArray
from ...core._package import DATA_DIR
from ...errors import BadInputError
from ..busload import MAX_NOMINAL_BITRATE, BusLoad, check_bitrates, schedule_load
from ..nodes import NodeProcess, start_plant

__all__ = ["DEFAULT_NODE_IDS", "EDS_PATH", "EXPECTED_MAPPING", "NODE_FRAMES", "DriveInfo",
           "ScheduledFrame", "canopen_load", "canopen_schedule", "inc_to_rad",
           "pdo_quantisation", "plant_idle_ms", "rad_to_inc", "start_drives",
           "torque_per_mille"]

#: The EDS of one drive (shipped in the package; installed by CMake in share/rrr/).
EDS_PATH = DATA_DIR / "rrr_cia402.eds"
#: The node ids of the three axes (rrr_hil_plant --profile canopen's default): node i drives
#: joint i.
DEFAULT_NODE_IDS: tuple[int, ...] = fv.JOINTS
#: The master's own node id for its heartbeat (0x700 + id; CiA 301 leaves 0x7F to no slave
#: here): refused as a drive's in real time.
MASTER_NODE_ID = 0x7F
#: CiA 402 mode of operation: cyclic synchronous torque.
MODE_CST = 10
#: The PDO mapping the master expects (read back by SDO): RPDO1, TPDO1, TPDO2 as (index, bits).
EXPECTED_MAPPING = {"RPDO1": [(0x6040, 16), (0x6071, 16)],
                    "TPDO1": [(0x6041, 16), (0x6064, 32), (0x6061, 8)],
                    "TPDO2": [(0x606C, 32), (0x6077, 16)]}
#: The plant node's own frame log (hil_framelog.h: every frame it sent and received), and the
#: standard frame log written from it.
NODE_FRAMES = "frames.rrrcan"
CAN_LOG = "frames.blf"
#: Over SocketCAN there is no hang-up: the plant ends this long (ms) after the master's last
#: frame once the master has taken every drive out of NMT operational (--end-after-stop-ms).
STOP_END_MS_SOCKETCAN = 1000
#: The plant takes a master silent for its idle timeout for lost (over socketcand the server also
#: ends the session): at least this much longer than the master's own longest silent wait
#: (--timeout: a boot-up, an SDO answer, a SYNC's TPDOs), so that the master's timeout, which
#: names the drive, always comes first (python-can's socketcand client cannot read the server's
#: "< error idle timeout >"), and never below the nodes' default (5 s).
IDLE_MARGIN_MS = 2000
IDLE_MS_DEFAULT = 5000
IDLE_MS_MAX = 3_600_000


def plant_idle_ms(timeout: float) -> int:
    """The plant's --idle-timeout-ms for a master that waits ``timeout`` s."""
    return min(IDLE_MS_MAX, max(IDLE_MS_DEFAULT, round(timeout * 1000) + IDLE_MARGIN_MS))


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


def canopen_load(bitrate: int = MAX_NOMINAL_BITRATE, data_bitrate: int | None = None,
                 period_ms: float = 1.0) -> BusLoad:
    """The load of the CANopen profile's schedule (three CiA 402 drives of the EDS, one SYNC
    every ``period_ms``: :func:`canopen_schedule`)."""
    from types import SimpleNamespace

    check_bitrates(bitrate, data_bitrate)
    schedule = SimpleNamespace(messages=canopen_schedule(period_ms))
    load = schedule_load(schedule, bitrate, data_bitrate, dbc_name=str(EDS_PATH))
    return BusLoad(load.dbc, load.bitrate, load.data_bitrate, load.lockstep, load.frames,
                   ("SDO, EMCY and NMT: sent on events",))


def _lround(x: float) -> int:
    """C's lround: halves away from zero (Python's round goes to even)."""
    a = abs(x)
    r = math.floor(a)
    if a - r >= 0.5:
        r += 1
    return int(r) if x >= 0 else -int(r)


def rad_to_inc(x: float, increments: int) -> int:
    """rad (or rad/s) to increments (per s) as the drive computes them (rrr_co_rad_to_inc)."""
    v = x * float(increments) / (2.0 * math.pi)
    if v != v:
        return 0
    return max(-(1 << 31), min((1 << 31) - 1, _lround(v)))


def inc_to_rad(n: int, increments: int) -> float:
    """Increments (per s) to rad (rad/s): n 2 pi / increments."""
    return n * (2.0 * math.pi) / float(increments)


def torque_per_mille(u: float, kt: float, rated_mNm: int) -> int:
    """The target torque 0x6071 of the voltage ``u``: tau = k_t u (N m), in per mille of the
    rated torque (mN m), rounded, within -1000..1000."""
    return max(-1000, min(1000, _lround(kt * u * 1e6 / float(rated_mNm))))


def pdo_quantisation(kt_master: Sequence[float], kt_plant: Sequence[float],
                     rated_mNm: Sequence[int], increments: int = 1 << 20,
                     ) -> tuple[Callable[[FloatArray], FloatArray],
                                Callable[[FloatArray], FloatArray]]:
    """(measure, actuate) of a co-simulation (CosimOptions) with the PDOs' resolutions: the
    master sees q, qd through increments; the plant applies u = t rated 1e-6 / k_t of the
    target torque t the master computes from its u (the drive's arithmetic)."""

    def measure(x: FloatArray) -> FloatArray:
        return np.array([inc_to_rad(rad_to_inc(float(v), increments), increments) for v in x])

    def actuate(u: FloatArray) -> FloatArray:
        return np.array([torque_per_mille(float(u[i]), kt_master[i], rated_mNm[i])
                         * float(rated_mNm[i]) * 1e-6 / kt_plant[i] for i in range(3)])

    return measure, actuate


@dataclass(frozen=True)
class DriveInfo:
    """What the master read of one drive by SDO."""

    node_id: int
    rated_torque_mNm: int
    increments: int  # per revolution (0x608F sub 1 / sub 2)
    mapping: dict[str, list[tuple[int, int]]]


def start_drives(q_ref: FloatArray, qd_ref: FloatArray, work: Path,
                 socketcan: str | None, fifo: int | None = None, *,
                 timeout: float = 5.0) -> NodeProcess:
    """``rrr_hil_plant --profile canopen`` at (q_ref[0], qd_ref[0]), logging ``work``/plant.csv
    and NODE_FRAMES; on the SocketCAN interface ``socketcan`` (it ends STOP_END_MS_SOCKETCAN
    after the master's NMT stop) or as socketcand server; the idle timeout :func:`plant_idle_ms`
    of the master's ``timeout`` either way.
    ``fifo`` (real time): ``--realtime --mlock`` and SCHED_FIFO ``fifo`` (0: none)."""
    ending = ["--idle-timeout-ms", str(plant_idle_ms(timeout)),
              *(["--end-after-stop-ms", str(STOP_END_MS_SOCKETCAN)] if socketcan else [])]
    rt = [] if fifo is None else ["--realtime", "--mlock", *(["--fifo", str(fifo)] if fifo
                                                             else [])]
    return start_plant(q0=q_ref[0], qd0=qd_ref[0], log_csv=work / "plant.csv",
                       frame_log=work / NODE_FRAMES, socketcan=socketcan,
                       extra=["--profile", "canopen", *ending, *rt])
