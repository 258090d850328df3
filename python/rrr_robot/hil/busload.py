"""Bus load of the CAN bench's schedule: frame lengths in bits and the share of a bus they take.

Classical CAN (ISO 11898-1, data frames): a frame with n data bytes has 47 + 8 n bits without
stuff bits (standard 11-bit identifier; 67 + 8 n extended), the 3-bit intermission included:
SOF 1, identifier 11, RTR 1, IDE 1, r0 1, DLC 4, data 8 n, CRC 15, CRC delimiter 1, ACK slot
and delimiter 2, EOF 7, IFS 3. Bit stuffing covers SOF to the end of the CRC, g + 8 n bits with
g = 34 (standard) or 54 (extended), and adds at most floor((g + 8 n - 1) / 4) bits (the
worst-case bound of Davis, Burns, Bril and Lukkien, Real-Time Systems 35(3), 2007): 135 bits for
an 8-byte standard frame, 111 without stuffing.

CAN FD (ISO 11898-1:2015, FD base or extended format, with bit-rate switch): the arbitration
phase at the nominal bit rate is SOF, identifier, RRS, IDE, FDF, res, BRS (17 bits standard, 36
extended) plus ACK, EOF and IFS (12 bits); the data phase at the data bit rate is ESI 1, DLC 4,
data 8 n, stuff count 4, CRC 17 (n <= 16) or 21, its fixed stuff bits (one before the stuff
count and one after every 4 bits: 6 or 7) and the CRC delimiter. Dynamic stuffing covers SOF to
the end of the data field (at most floor((L - 1) / 4) bits for its L bits); for the worst case
the stuff bits the arbitration bits can carry (floor((17 - 1) / 4) = 4 standard) are counted at
the slower nominal rate, the rest in the data phase.

:func:`stuffed_length` counts the stuff bits of an actual classical frame exactly (its CRC-15
computed, then stuffed): what a frame log really puts on a bus (:func:`measured_load`).

Periods come from the DBC's ``GenMsgCycleTime`` (ms); a frame with the attribute
``RrrLockstepOnly`` = 1 (Sync) is sent in lockstep only, and one without a cycle time (StopCmd)
once per run: neither is part of the real-time schedule.

Each CAN profile gives its own schedule: ``busload(options)`` in its package (``dbc``,
``canopen``), a :class:`BusLoad` from :class:`BusloadOptions`; :func:`profile_load` calls it
(``rrr hil busload --profile NAME``).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import BadInputError
from .nodes import PERIOD

__all__ = [
    "FD_DATA_BITRATE",
    "MAX_DATA_BITRATE",
    "MAX_NOMINAL_BITRATE",
    "BusLoad",
    "BusloadOptions",
    "FrameLoad",
    "bus_loads",
    "can_crc15",
    "check_bitrates",
    "classical_bits",
    "fd_bits",
    "fd_bus_loads",
    "format_loads",
    "format_report",
    "measured_fd_load",
    "measured_load",
    "profile_load",
    "schedule_load",
    "schedule_name",
    "stuffed_length",
]

#: bit/s: classical CAN's highest bit rate (ISO 11898-2), also the highest nominal rate here
MAX_NOMINAL_BITRATE = 1_000_000
#: bit/s: the highest CAN FD data bit rate accepted (transceivers reach 5 to 8 Mbit/s)
MAX_DATA_BITRATE = 20_000_000
#: bit/s: the data bit rate the bench's CAN FD figures assume (summary.json ``bus``)
FD_DATA_BITRATE = 5_000_000
#: CAN FD data lengths (DLC 9..15 stand for 12, 16, 20, 24, 32, 48, 64 bytes)
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


def _check_bytes(n: int, fd: bool) -> None:
    if fd and n not in FD_LENGTHS:
        raise BadInputError(f"a CAN FD frame has 0-8, 12, 16, 20, 24, 32, 48 or 64 data bytes, "
                            f"not {n}")
    if not fd and not 0 <= n <= 8:
        raise BadInputError(f"a classical CAN frame has 0 to 8 data bytes, not {n}")


def classical_bits(n: int, *, extended: bool = False, stuffing: bool = True) -> int:
    """Bits of a classical CAN data frame with ``n`` data bytes, intermission included: the
    worst case of bit stuffing, or none (``stuffing=False``)."""
    _check_bytes(n, fd=False)
    g = 54 if extended else 34
    bits = g + 8 * n + 13  # + CRC delimiter, ACK slot and delimiter, EOF, IFS
    return bits + ((g + 8 * n - 1) // 4 if stuffing else 0)


def fd_bits(n: int, *, extended: bool = False, stuffing: bool = True) -> tuple[int, int]:
    """(bits at the nominal rate, bits at the data rate) of a CAN FD data frame with bit-rate
    switch and ``n`` data bytes, intermission included; the worst case of dynamic stuffing (its
    share in the arbitration phase counted at the nominal rate), or none. The fixed stuff bits
    of the CRC field are always there."""
    _check_bytes(n, fd=True)
    arbitration = 36 if extended else 17           # SOF .. BRS
    nominal = arbitration + 2 + 7 + 3               # + ACK slot and delimiter, EOF, IFS
    crc = 17 if n <= 16 else 21
    fixed_stuff = 1 + (4 + crc - 1) // 4            # before the stuff count, then every 4 bits
    data = 1 + 4 + 8 * n + 4 + crc + fixed_stuff + 1  # ESI, DLC, data, count, CRC, FSB, delim.
    if stuffing:
        dynamic = (arbitration + 5 + 8 * n - 1) // 4  # SOF .. end of the data field
        in_arbitration = min(dynamic, (arbitration - 1) // 4)
        nominal += in_arbitration
        data += dynamic - in_arbitration
    return nominal, data


# ---- exact stuffing of an actual classical frame ---------------------------------------------


def can_crc15(bits: Iterable[int]) -> int:
    """CRC-15/CAN (polynomial 0x4599, initial value 0) of a bit sequence, as the CAN controller
    computes it over SOF .. data."""
    crc = 0
    for b in bits:
        top = ((crc >> 14) & 1) ^ (b & 1)
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= 0x4599
    return crc


def _bits(value: int, width: int) -> list[int]:
    return [(value >> (width - 1 - i)) & 1 for i in range(width)]


def stuffed_length(can_id: int, data: bytes, *, extended: bool = False) -> int:
    """Bits on the bus of this classical data frame, intermission included: its stuff bits
    counted exactly (a complementary bit after five equal bits, from SOF to the end of the
    CRC; the stuff bits count towards the next run)."""
    _check_bytes(len(data), fd=False)
    dlc = len(data)
    if extended:
        head = [0, *_bits(can_id >> 18, 11), 1, 1, *_bits(can_id & 0x3FFFF, 18), 0, 0, 0]
    else:
        head = [0, *_bits(can_id, 11), 0, 0, 0]  # SOF, identifier, RTR, IDE, r0
    stream = head + _bits(dlc, 4) + [b for byte in data for b in _bits(byte, 8)]
    stream += _bits(can_crc15(stream), 15)
    stuff, run, last = 0, 0, -1
    for b in stream:
        if b == last:
            run += 1
        else:
            run, last = 1, b
        if run == 5:  # a stuff bit of the other level follows and starts the next run
            stuff += 1
            run, last = 1, 1 - b
    return len(stream) + stuff + 13


# ---- the schedule of a DBC --------------------------------------------------------------------


@dataclass(frozen=True)
class FrameLoad:
    """One periodic frame of the schedule and its share of the bus."""

    frame_id: int
    name: str
    length: int                 # data bytes
    extended: bool
    period_ms: float
    bits_worst: float           # bit times at the nominal rate (FD: the data phase scaled)
    bits_nominal: float         # no dynamic stuffing
    time_worst_us: float        # on the bus, one frame
    time_nominal_us: float

    @property
    def rate_hz(self) -> float:
        return 1000.0 / self.period_ms


@dataclass(frozen=True)
class BusLoad:
    """The load of a schedule on one bus."""

    dbc: str
    bitrate: int
    data_bitrate: int | None     # CAN FD with bit-rate switch; None: classical CAN
    lockstep: bool               # the lockstep-only frames (Sync) included
    frames: tuple[FrameLoad, ...]
    excluded: tuple[str, ...]    # frames outside the periodic schedule, and why

    @property
    def frames_per_second(self) -> float:
        return sum(f.rate_hz for f in self.frames)

    @property
    def worst_percent(self) -> float:
        return 100.0 * sum(f.time_worst_us * 1e-6 * f.rate_hz for f in self.frames)

    @property
    def nominal_percent(self) -> float:
        return 100.0 * sum(f.time_nominal_us * 1e-6 * f.rate_hz for f in self.frames)

    def as_dict(self) -> dict[str, Any]:
        return {
            "dbc": self.dbc, "bitrate": self.bitrate, "data_bitrate": self.data_bitrate,
            "lockstep": self.lockstep, "frames_per_second": self.frames_per_second,
            "load_worst_percent": self.worst_percent,
            "load_no_stuffing_percent": self.nominal_percent,
            "frames": [{"id": f.frame_id, "name": f.name, "bytes": f.length,
                        "period_ms": f.period_ms, "time_worst_us": f.time_worst_us,
                        "time_no_stuffing_us": f.time_nominal_us} for f in self.frames],
            "excluded": list(self.excluded),
        }


def check_bitrates(bitrate: int, data_bitrate: int | None) -> None:
    """BadInputError unless 0 < bitrate <= 1 Mbit/s and, for CAN FD, bitrate <= data bitrate
    <= MAX_DATA_BITRATE."""
    if not 0 < bitrate <= MAX_NOMINAL_BITRATE:
        raise BadInputError(f"--bitrate: a CAN bit rate in 1 .. {MAX_NOMINAL_BITRATE} bit/s, "
                            f"not {bitrate}")
    if data_bitrate is not None and not bitrate <= data_bitrate <= MAX_DATA_BITRATE:
        raise BadInputError(f"--fd: a data bit rate from the nominal {bitrate} to "
                            f"{MAX_DATA_BITRATE} bit/s, not {data_bitrate}")


@dataclass(frozen=True)
class BusloadOptions:
    """What ``rrr hil busload`` asks of a profile's schedule: the bus, and the options that
    apply to some profiles only (each profile refuses, in one line, those that do not apply)."""

    bitrate: int = MAX_NOMINAL_BITRATE
    data_bitrate: int | None = None   # CAN FD with bit-rate switch; None: classical CAN
    lockstep: bool = False            # the lockstep-only frames (DBC: Sync)
    dbc: Path | None = None           # another DBC than the bench's
    sync_period_ms: float | None = None  # CANopen: the SYNC period


def profile_load(profile: str, options: BusloadOptions) -> BusLoad:
    """The load of a CAN profile's schedule: ``busload(options)`` of its package
    (``rrr_robot.hil.<profile>``); BadInputError for a profile that is not in
    :data:`rrr_robot.hil.PROFILES` or whose package defines no ``busload``."""
    from . import PROFILES, PROFILES_FILE

    check_bitrates(options.bitrate, options.data_bitrate)  # before the profile's files are read
    if profile not in PROFILES:
        known = ", ".join(PROFILES) or f"none ({PROFILES_FILE} is missing: pip install .)"
        raise BadInputError(f"--profile {profile}: not a CAN profile of this installation: "
                            f"{known}")
    schedule = getattr(importlib.import_module(PROFILES[profile]), "busload", None)
    if schedule is None:
        raise BadInputError(f"--profile {profile}: the profile has no bus-load schedule "
                            f"({PROFILES[profile]} defines no busload)")
    load: BusLoad = schedule(options)
    return load


def _attribute(message: Any, name: str) -> Any:
    dbc = getattr(message, "dbc", None)
    attrs = getattr(dbc, "attributes", None) or {}
    return attrs[name].value if name in attrs else None


def schedule_load(db: Any, bitrate: int = MAX_NOMINAL_BITRATE, data_bitrate: int | None = None,
                  *, lockstep: bool = False, dbc_name: str = "") -> BusLoad:
    """The load of ``db``'s (a cantools database) periodic frames on a bus of ``bitrate``
    bit/s, classical CAN, or CAN FD with bit-rate switch to ``data_bitrate``; ``lockstep``
    includes the frames marked ``RrrLockstepOnly``."""
    check_bitrates(bitrate, data_bitrate)
    frames: list[FrameLoad] = []
    excluded: list[str] = []
    for msg in sorted(db.messages, key=lambda m: m.frame_id):
        if not msg.cycle_time:
            excluded.append(f"{msg.name}: no cycle time (sent on an event: once per run)")
            continue
        if not lockstep and _attribute(msg, "RrrLockstepOnly") == 1:
            excluded.append(f"{msg.name}: lockstep only")
            continue
        fd = data_bitrate is not None
        ext = bool(msg.is_extended_frame)
        times = []
        bit_counts = []
        for stuffing in (True, False):
            if fd:
                assert data_bitrate is not None
                nom, dat = fd_bits(msg.length, extended=ext, stuffing=stuffing)
                times.append(1e6 * (nom / bitrate + dat / data_bitrate))
                bit_counts.append(nom + dat * bitrate / data_bitrate)
            else:
                bits = classical_bits(msg.length, extended=ext, stuffing=stuffing)
                times.append(1e6 * bits / bitrate)
                bit_counts.append(float(bits))
        frames.append(FrameLoad(msg.frame_id, msg.name, msg.length, ext, float(msg.cycle_time),
                                bit_counts[0], bit_counts[1], times[0], times[1]))
    return BusLoad(dbc_name, bitrate, data_bitrate, lockstep, tuple(frames), tuple(excluded))


def measured_load(frames: Sequence[tuple[int, bytes, bool]], periods: int,
                  bitrate: int = MAX_NOMINAL_BITRATE, period_s: float = PERIOD,
                  ) -> dict[str, float]:
    """What a frame log puts on a classical bus: (identifier, data, extended) of every frame
    once; ``periods`` control periods of ``period_s``. Returns frames and exactly stuffed bits per
    period, and the load on a ``bitrate`` bus at one period per ``period_s``."""
    if periods <= 0:
        raise BadInputError(f"periods must be > 0, not {periods}")
    bits = sum(stuffed_length(i, d, extended=e) for i, d, e in frames)
    per_period = bits / periods
    return {"frames_per_period": len(frames) / periods, "bits_per_period": per_period,
            "load_percent": 100.0 * per_period / (period_s * bitrate)}


def measured_fd_load(frames: Sequence[tuple[int, bytes, bool]], periods: int,
                     bitrate: int = MAX_NOMINAL_BITRATE, data_bitrate: int = FD_DATA_BITRATE,
                     period_s: float = 1e-3) -> dict[str, float]:
    """What a frame log puts on a CAN FD bus with bit-rate switch: (identifier, data, extended)
    of every frame once; ``periods`` control periods of ``period_s``. Returns frames and data
    bytes per period and the bus time per period as :func:`fd_bits` counts it, with the worst
    case of dynamic stuffing and without it (the CRC's fixed stuff bits always), as a load
    of a ``bitrate`` / ``data_bitrate`` bus in percent."""
    if periods <= 0:
        raise BadInputError(f"periods must be > 0, not {periods}")
    check_bitrates(bitrate, data_bitrate)
    out = {"frames_per_period": len(frames) / periods,
           "bytes_per_period": sum(len(d) for _, d, _ in frames) / periods}
    for key, stuffing in (("load_worst_percent", True), ("load_no_stuffing_percent", False)):
        seconds = 0.0
        for _, data, ext in frames:
            nom, dat = fd_bits(len(data), extended=ext, stuffing=stuffing)
            seconds += nom / bitrate + dat / data_bitrate
        out[key] = 100.0 * seconds / (periods * period_s)
    return out


def schedule_name(load: BusLoad) -> str:
    """Which schedule ``load`` is, in words: the DBC's in real time or in lockstep (Sync
    included), or the CANopen profile's."""
    if load.dbc.endswith(".eds"):
        sync = next((f.period_ms for f in load.frames if f.frame_id == 0x080), 0.0)
        return f"three CiA 402 drives, SYNC every {sync:g} ms"
    return "lockstep (Sync included)" if load.lockstep else "real time"


def bus_loads(frames: Sequence[tuple[int, bytes, bool]], periods: int, schedule: BusLoad,
              realtime_schedule: BusLoad, period_s: float = PERIOD) -> dict[str, Any]:
    """The bus loads of a run on a classical bus of ``schedule.bitrate``, each named by what it
    is (summary.json ``bus.load``; docs/can-bench.md, "Which load is which"):

    - ``measured_percent``: the frames the run's frame log holds (``frames``: identifier, data,
      extended), each with its stuff bits counted exactly, per period of ``period_s`` (in
      lockstep: as if the periods were ``period_s`` apart);
    - ``schedule_worst_case_percent`` and ``schedule_no_stuffing_percent``: the periodic schedule
      of the run's mode (``schedule``; lockstep: Sync included), every frame with the worst case
      of stuffing, and with none;
    - ``realtime_schedule_worst_case_percent``: the real-time schedule's worst case, what ``rrr
      hil busload`` prints (the run's own schedule in real time)."""
    measured = measured_load(frames, periods, schedule.bitrate, period_s)
    return {
        "bitrate": schedule.bitrate, "period_s": period_s,
        "measured_percent": measured["load_percent"],
        "measured_bits_per_period": measured["bits_per_period"],
        "schedule": schedule_name(schedule),
        "schedule_worst_case_percent": schedule.worst_percent,
        "schedule_no_stuffing_percent": schedule.nominal_percent,
        "realtime_schedule_worst_case_percent": realtime_schedule.worst_percent,
    }


def fd_bus_loads(frames: Sequence[tuple[int, bytes, bool]], periods: int, schedule: BusLoad,
                 period_s: float = PERIOD) -> dict[str, Any]:
    """The same for CAN FD with bit-rate switch (``schedule``: the run's schedule on that bus;
    summary.json ``bus.load_fd``): the measured frames with the worst case of dynamic stuffing
    and with none (:func:`measured_fd_load`: an FD frame's stuffing is not counted exactly), and
    the schedule's worst case."""
    assert schedule.data_bitrate is not None
    measured = measured_fd_load(frames, periods, schedule.bitrate, schedule.data_bitrate,
                                period_s)
    return {
        "bitrate": schedule.bitrate, "data_bitrate": schedule.data_bitrate,
        "period_s": period_s, "bytes_per_period": measured["bytes_per_period"],
        "measured_worst_case_percent": measured["load_worst_percent"],
        "measured_no_stuffing_percent": measured["load_no_stuffing_percent"],
        "schedule": schedule_name(schedule),
        "schedule_worst_case_percent": schedule.worst_percent,
    }


def _mbit(bitrate: int) -> str:
    return f"{bitrate / 1e6:g} Mbit/s" if bitrate >= 1_000_000 else f"{bitrate / 1e3:g} kbit/s"


def format_loads(load: Mapping[str, Any], fd: Mapping[str, Any] | None = None) -> str:
    """One line of a run's bus loads (:func:`bus_loads`, and :func:`fd_bus_loads` on CAN FD),
    each named by what it is."""
    period = f"{1e3 * load['period_s']:g} ms"
    worst, realtime = load["schedule_worst_case_percent"], \
        load["realtime_schedule_worst_case_percent"]
    name = load["schedule"]
    if name.startswith("lockstep"):
        clock = " (lockstep has no clock: as if run at that rate)"
        schedules = (f"worst case of the lockstep schedule {worst:.2f} % (Sync included), of the "
                     f"real-time schedule {realtime:.2f} % (rrr hil busload)")
    elif name == "real time":
        clock = ""
        schedules = f"worst case of the real-time schedule {worst:.2f} % (rrr hil busload)"
    else:
        clock = ""
        schedules = (f"worst case of the schedule {worst:.2f} % ({name}: rrr hil busload "
                     "--profile canopen)")
    text = (f"load of a {_mbit(load['bitrate'])} classical CAN bus, one period per {period}"
            f"{clock}: measured {load['measured_percent']:.2f} % (this run's frames, stuff bits "
            f"counted exactly); {schedules}")
    if fd is not None:
        text += (f"; CAN FD {_mbit(fd['bitrate'])} + {_mbit(fd['data_bitrate'])}: measured "
                 f"{fd['measured_worst_case_percent']:.2f} % with worst-case stuffing, worst "
                 f"case of the schedule {fd['schedule_worst_case_percent']:.2f} %")
    return text


def format_report(load: BusLoad) -> str:
    """The report of ``rrr hil busload``; its last line states the worst-case load in percent."""
    bus = (f"CAN FD, {load.bitrate} bit/s nominal, {load.data_bitrate} bit/s data (bit-rate "
           "switch)" if load.data_bitrate is not None else f"classical CAN, {load.bitrate} bit/s")
    mode = schedule_name(load)
    lines = [f"schedule of {Path(load.dbc).name or 'the DBC'}, {mode}; bus: {bus}",
             f"{'id':>6} {'frame':<16} {'bytes':>5} {'period':>8} {'bits worst':>10} "
             f"{'bits no stuff':>13} {'us worst':>9} {'load worst':>10} {'load no stuff':>13}"]
    for f in load.frames:
        share = 100.0 * f.time_worst_us * 1e-6 * f.rate_hz
        share0 = 100.0 * f.time_nominal_us * 1e-6 * f.rate_hz
        lines.append(f"0x{f.frame_id:03X} {f.name:<16} {f.length:>5} {f.period_ms:>5g} ms "
                     f"{f.bits_worst:>10.1f} {f.bits_nominal:>13.1f} {f.time_worst_us:>9.2f} "
                     f"{share:>9.2f} % {share0:>11.2f} %")
    lines += [f"not in the periodic schedule: {e}" for e in load.excluded]
    rate = " if run at 1 kHz" if load.lockstep else ""
    lines.append(f"{load.frames_per_second:.0f} frames/s{rate}; load without stuff bits "
                 f"{load.nominal_percent:.2f} %")
    lines.append(f"worst-case bus load: {load.worst_percent:.2f} %")
    return "\n".join(lines)
