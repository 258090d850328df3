#!/usr/bin/env python3
"""The conformance suite of the simulated CiA 402 drives (``rrr_hil_plant --profile canopen``),
modelled on CANopen's conformance test (the open transcript of its run against CANopenNode):
every case of it that applies to these drives (SDO, PDO mapping and COB-ID rules, object
dictionary, EMCY, SYNC, heartbeat producer and consumer, NMT states and transitions, boot-up,
store and restore), and the CiA 402 objects a master in the field reads, each sent as raw frames
with python-can. docs/canopen-conformance.md lists the cases (``--list`` prints its table).

One harness, :class:`Dut`, over any python-can bus: ``test_canopen_conformance.py`` runs every
case over the C node's socketcand server here, and this script in the CAN test guest over
SocketCAN (vcan0):

    canopen_conformance.py --socketcan vcan0 --out results.json [--timeout S] [CASE ...]

starts the plant on the interface, runs the cases (all by default) and writes, per case, ``ok``,
``detail`` (why it failed) and ``seconds``.

Each case starts from NMT reset node (every value at its default, pre-operational) and works on
drive 2 unless it says otherwise. Timing cases assert order and bounds ten times wider than the
times configured, never a latency.
"""

from __future__ import annotations

import argparse
import configparser
import contextlib
import json
import sys
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

IDS = (1, 2, 3)
N = 2  # the drive most cases work on
MASTER = 0x7F  # the master's node id (its heartbeat 0x77F)
EDS = Path(__file__).resolve().parents[3] / "python" / "rrr_robot" / "data" / "rrr_cia402.eds"

# SDO abort codes (CiA 301)
TOGGLE, TIMEOUT, BAD_CS = 0x05030000, 0x05040000, 0x05040001
UNSUPPORTED, WRITE_ONLY, READ_ONLY, NO_OBJECT = 0x06010000, 0x06010001, 0x06010002, 0x06020000
NO_MAP, MAP_LEN, TOO_LONG, TOO_SHORT = 0x06040041, 0x06040042, 0x06070012, 0x06070013
NO_SUB, VALUE, TOO_HIGH, TOO_LOW = 0x06090011, 0x06090030, 0x06090031, 0x06090032


def restricted(can_id: int) -> bool:
    """CiA 301's restricted CAN-IDs and the predefined connection set's SYNC, EMCY and TIME
    (docs/canopen.md, COB-ID rules): no PDO may be valid on one."""
    return (can_id <= 0x180 or 0x581 <= can_id <= 0x5FF or 0x601 <= can_id <= 0x67F
            or 0x6E0 <= can_id <= 0x6FF or can_id >= 0x701)


class SdoAbort(Exception):
    def __init__(self, code: int) -> None:
        super().__init__(f"SDO abort 0x{code:08X}")
        self.code = code


@dataclass
class Frame:
    id: int
    data: bytes
    t: float  # time.monotonic() when received


class Dut:
    """The three drives behind ``bus``: raw frames in and out, every frame received kept in
    ``log``. ``timeout``: how long an answer may take (s)."""

    def __init__(self, bus: can.BusABC, timeout: float = 2.0) -> None:
        self.bus, self.timeout = bus, timeout
        self.log: list[Frame] = []

    # ---- frames ----------------------------------------------------------------------------
    def send(self, cob: int, data: bytes = b"", *, extended: bool = False) -> float:
        self.bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=extended))
        return time.monotonic()

    def _recv(self, until: float) -> Frame | None:
        return self._keep(self.bus.recv(max(0.0, until - time.monotonic())))

    def _keep(self, msg: can.Message | None) -> Frame | None:
        if msg is None or msg.is_error_frame:
            return None
        f = Frame(msg.arbitration_id, bytes(msg.data), time.monotonic())
        self.log.append(f)
        return f

    def mark(self) -> int:
        """A position in ``log``: the frames received from now on are ``since(mark)``. The
        frames already waiting in the bus's queue go into ``log`` first: they came before now
        (on a busy machine a case may not read the bus for several heartbeat periods, and a
        heartbeat sent before the last command would count as one after it)."""
        while (msg := self.bus.recv(0.0)) is not None:
            self._keep(msg)
        return len(self.log)

    def since(self, mark: int, cob: int | None = None) -> list[Frame]:
        return [f for f in self.log[mark:] if cob is None or f.id == cob]

    def wait(self, pred: Callable[[Frame], bool], mark: int, timeout: float | None = None
             ) -> Frame | None:
        """The first frame since ``mark`` for which ``pred`` holds, waiting up to ``timeout``."""
        for f in self.log[mark:]:
            if pred(f):
                return f
        until = time.monotonic() + (self.timeout if timeout is None else timeout)
        while time.monotonic() < until:
            f = self._recv(until)
            if f is not None and pred(f):
                return f
        return None

    def listen(self, seconds: float) -> None:
        """Receive for ``seconds`` (into ``log``)."""
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            self._recv(until)

    def expect(self, cob: int, mark: int, what: str, timeout: float | None = None) -> Frame:
        f = self.wait(lambda f: f.id == cob, mark, timeout)
        assert f is not None, f"no {what} (0x{cob:03X}) within {timeout or self.timeout:g} s"
        return f

    # ---- NMT, SYNC, heartbeat --------------------------------------------------------------
    def nmt(self, command: int, node: int = 0) -> None:
        self.send(0x000, bytes([command, node]))

    def reset(self) -> None:
        """NMT reset node (all): every drive boots (0x700 + id, 0x00) with its defaults."""
        m = self.mark()
        self.nmt(0x81)
        for i in IDS:
            f = self.wait(lambda f, i=i: f.id == 0x700 + i and f.data == b"\0", m)
            assert f is not None, f"drive {i}: no boot-up after NMT reset node"

    def state_seen(self, node: int, timeout: float | None = None) -> int:
        """The NMT state in the second heartbeat of ``node`` from now: the first may have been
        produced before the plant read the last command (it advances the heartbeat's clock
        before it handles a frame)."""
        m = self.mark()
        f = self.expect(0x700 + node, m, f"heartbeat of drive {node}", timeout)
        after = next(i for i in range(m, len(self.log)) if self.log[i] is f) + 1
        return self.expect(0x700 + node, after, f"heartbeat of drive {node}", timeout).data[0]

    def start(self, node: int = 0) -> None:
        self.nmt(0x01, node)

    def sync(self, data: bytes = b"") -> int:
        m = self.mark()
        self.send(0x080, data)
        return m

    def sync_tpdos(self, data: bytes = b"") -> dict[int, bytes]:
        """One SYNC in operational: the six TPDOs it brings, by COB-ID."""
        m = self.sync(data)
        want = {0x180 + i for i in IDS} | {0x280 + i for i in IDS}
        got: dict[int, bytes] = {}
        while want - set(got):
            f = self.wait(lambda f: f.id in want - set(got), m)
            assert f is not None, f"TPDOs {sorted(map(hex, want - set(got)))} missing"
            got[f.id] = f.data
        return got

    # ---- SDO -------------------------------------------------------------------------------
    def request(self, node: int, data: bytes, *, answer: bool = True) -> bytes:
        """One SDO request to ``node``: its server's answer (8 bytes)."""
        m = self.mark()
        self.send(0x600 + node, data)
        f = self.wait(lambda f: f.id == 0x580 + node, m)
        if not answer:
            assert f is None, f"drive {node} answered {f.data.hex() if f else ''}"
            return b""
        assert f is not None, f"no SDO answer of drive {node} to {data.hex()}"
        assert len(f.data) == 8, f"SDO answer of DLC {len(f.data)}"
        return f.data

    def _check(self, r: bytes, index: int, sub: int) -> None:
        if r[0] == 0x80:
            raise SdoAbort(int.from_bytes(r[4:8], "little"))
        assert int.from_bytes(r[1:3], "little") == index and r[3] == sub, r.hex()

    def upload(self, index: int, sub: int = 0, node: int = N) -> bytes:
        """An SDO upload, expedited or segmented (SdoAbort on an abort)."""
        r = self.request(node, bytes([0x40, index & 0xFF, index >> 8, sub, 0, 0, 0, 0]))
        self._check(r, index, sub)
        assert r[0] & 0xE0 == 0x40, f"not an initiate upload response: {r.hex()}"
        if r[0] & 0x02:  # expedited
            size = 4 - ((r[0] >> 2) & 3) if r[0] & 0x01 else 4
            return r[4:4 + size]
        size = int.from_bytes(r[4:8], "little")
        out, toggle = b"", 0
        while True:
            s = self.request(node, bytes([0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0]))
            if s[0] == 0x80:
                raise SdoAbort(int.from_bytes(s[4:8], "little"))
            assert s[0] & 0xE0 == 0 and (s[0] >> 4) & 1 == toggle, s.hex()
            out += s[1:8 - ((s[0] >> 1) & 7)]
            toggle ^= 1
            if s[0] & 1:
                assert len(out) == size, (len(out), size)
                return out

    def read(self, index: int, sub: int = 0, node: int = N, signed: bool = False) -> int:
        return int.from_bytes(self.upload(index, sub, node), "little", signed=signed)

    def download(self, index: int, sub: int, data: bytes, node: int = N) -> None:
        """An expedited SDO download of 1..4 bytes (SdoAbort on an abort)."""
        cmd = 0x23 | (4 - len(data)) << 2
        r = self.request(node, bytes([cmd, index & 0xFF, index >> 8, sub])
                         + data.ljust(4, b"\0"))
        self._check(r, index, sub)
        assert r[0] == 0x60, r.hex()

    def write(self, index: int, sub: int, value: int, size: int, node: int = N) -> None:
        self.download(index, sub, (value & ((1 << 8 * size) - 1)).to_bytes(size, "little"),
                      node)

    def download_segmented(self, index: int, sub: int, data: bytes, node: int = N,
                           size: int | None = None) -> None:
        r = self.request(node, bytes([0x21, index & 0xFF, index >> 8, sub])
                         + (len(data) if size is None else size).to_bytes(4, "little"))
        self._check(r, index, sub)
        assert r[0] == 0x60, r.hex()
        toggle = 0
        for at in range(0, len(data), 7):
            chunk = data[at:at + 7]
            last = at + 7 >= len(data)
            cmd = toggle << 4 | (7 - len(chunk)) << 1 | int(last)
            s = self.request(node, bytes([cmd]) + chunk.ljust(7, b"\0"))
            if s[0] == 0x80:
                raise SdoAbort(int.from_bytes(s[4:8], "little"))
            assert s[0] == 0x20 | toggle << 4, s.hex()
            toggle ^= 1


def abort(action: Callable[[], object]) -> int:
    """The abort code an SDO transfer ends with (AssertionError if it succeeds)."""
    try:
        action()
    except SdoAbort as exc:
        return exc.code
    raise AssertionError("no SDO abort")


def refused(dut: Dut, code: int, index: int, sub: int, value: int, size: int,
            node: int = N) -> None:
    got = abort(lambda: dut.write(index, sub, value, size, node))
    assert got == code, (f"0x{index:04X} sub {sub} = 0x{value:X}: abort 0x{got:08X}, "
                         f"not 0x{code:08X}")


def statusword(dut: Dut, node: int = N) -> int:
    return dut.read(0x6041, 0, node)


def enable(dut: Dut, node: int = N) -> None:
    """The 402 state machine to OPERATION ENABLED by SDO (shutdown, switch on, enable)."""
    for cw, sw in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27)):
        dut.write(0x6040, 0, cw, 2, node)
        assert statusword(dut, node) & 0x6F == sw


def rpdo(dut: Dut, controlword: int, torque: int, node: int = N) -> None:
    dut.send(0x200 + node, controlword.to_bytes(2, "little") + torque.to_bytes(2, "little",
                                                                                signed=True))


def emcy(f: Frame) -> tuple[int, int]:
    """(error code, error register) of an EMCY, checked to be CiA 301's 8 bytes."""
    assert len(f.data) == 8 and f.data[3:] == bytes(5), f.data.hex()
    return int.from_bytes(f.data[:2], "little"), f.data[2]


# ---- the EDS (the standard library's INI reader: CiA 306) -------------------------------------


@dataclass(frozen=True)
class Entry:
    index: int
    sub: int
    dtype: int
    access: str
    default: int | str
    low: int | None
    high: int | None
    pdo: bool

    @property
    def size(self) -> int:
        return {1: 1, 2: 1, 3: 2, 4: 4, 5: 1, 6: 2, 7: 4}.get(self.dtype, 0)

    @property
    def signed(self) -> bool:
        return self.dtype in (2, 3, 4)


def eds_entries(node: int = N) -> list[Entry]:
    eds = configparser.ConfigParser(interpolation=None)
    eds.optionxform = str  # type: ignore[assignment,method-assign]
    eds.read(EDS, encoding="utf-8")
    out = []
    for name in eds.sections():
        sec = eds[name]
        if "DataType" not in sec or not name[:4].isalnum() or len(name) < 4:
            continue
        index = int(name[:4], 16)
        sub = int(name[7:], 16) if "sub" in name else 0
        text = sec.get("DefaultValue", "0")
        dtype = int(sec["DataType"], 0)
        default: int | str = text
        if dtype != 9:
            plus = 0
            if text.upper().startswith("$NODEID"):
                plus, text = node, text[7:].lstrip("+")
            default = int(text, 0) + plus
        lim = {k: int(sec[k], 0) if k in sec else None for k in ("LowLimit", "HighLimit")}
        out.append(Entry(index, sub, dtype, sec["AccessType"], default, lim["LowLimit"],
                         lim["HighLimit"], sec.get("PDOMapping") == "1"))
    return sorted(out, key=lambda e: (e.index, e.sub))


# ---- the cases ----------------------------------------------------------------------------

CaseFn = Callable[[Dut], None]


@dataclass(frozen=True)
class Case:
    name: str
    ref: str  # the conformance test's case(s) it follows ("-": these drives' own)
    fn: CaseFn

    @property
    def checks(self) -> str:
        doc = self.fn.__doc__ or ""
        return " ".join(doc.split())


CASES: list[Case] = []


def case(ref: str) -> Callable[[CaseFn], CaseFn]:
    def add(fn: CaseFn) -> CaseFn:
        CASES.append(Case(fn.__name__, ref, fn))
        return fn

    return add


# ---- SDO (conformance test 2.x) ----


@case("2.1, 2.13")
def sdo_expedited_upload(d: Dut) -> None:
    """An upload of 0x1000 is answered expedited with its size (0x43): the device type
    0x00020192 (CiA 402, servo drive), index and sub-index echoed."""
    r = d.request(N, bytes([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]))
    assert r[:4] == bytes([0x43, 0x00, 0x10, 0]) and r[4:] == (0x00020192).to_bytes(4, "little")


@case("2.2")
def sdo_write_back_communication_entries(d: Dut) -> None:
    """Every rw entry of 0x1000..0x1FFF but the PDO mappings (the mapping cases) is read and
    written back with its value: accepted, the value unchanged."""
    entries = [e for e in eds_entries() if e.access == "rw" and e.index < 0x2000
               and not (0x1600 <= e.index < 0x1800 or 0x1A00 <= e.index < 0x1C00)]
    assert len(entries) >= 6
    for e in entries:
        value = d.read(e.index, e.sub)
        d.write(e.index, e.sub, value, e.size)
        assert d.read(e.index, e.sub) == value, hex(e.index)


@case("2.3")
def sdo_write_read_only(d: Dut) -> None:
    """A write to 0x1000 (ro): abort 0x06010002."""
    refused(d, READ_ONLY, 0x1000, 0, 0x00020192, 4)


@case("2.4")
def sdo_read_write_only(d: Dut) -> None:
    """A read of the write-only 0x2000 (simulated fault): abort 0x06010001."""
    assert abort(lambda: d.upload(0x2000)) == WRITE_ONLY


@case("2.5")
def sdo_missing_sub_index(d: Dut) -> None:
    """A read of 0x1000 sub 1 and of 0x1018 sub 5: abort 0x06090011."""
    assert abort(lambda: d.upload(0x1000, 1)) == NO_SUB
    assert abort(lambda: d.upload(0x1018, 5)) == NO_SUB


@case("2.6, 2.28")
def sdo_missing_object(d: Dut) -> None:
    """Reads of 0x1004, 0x1201 and 0x1402: abort 0x06020000."""
    for index in (0x1004, 0x1201, 0x1402):
        assert abort(lambda index=index: d.upload(index)) == NO_OBJECT


@case("2.7")
def sdo_bad_command_specifier(d: Dut) -> None:
    """A request with command specifier 7: abort 0x05040001."""
    r = d.request(N, bytes([0xE0, 0x00, 0x10, 0, 0, 0, 0, 0]))
    assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("2.8")
def sdo_data_too_long(d: Dut) -> None:
    """4 bytes into the UNSIGNED16 0x1017 and 2 into the UNSIGNED8 0x2001: abort 0x06070012."""
    refused(d, TOO_LONG, 0x1017, 0, 100, 4)
    refused(d, TOO_LONG, 0x2001, 0, 3, 2)


@case("2.9")
def sdo_data_too_short(d: Dut) -> None:
    """1 byte into the UNSIGNED16 0x1017 and 2 into the UNSIGNED32 0x1016 sub 1: abort
    0x06070013."""
    refused(d, TOO_SHORT, 0x1017, 0, 100, 1)
    refused(d, TOO_SHORT, 0x1016, 1, 0, 2)


@case("2.10")
def sdo_value_too_high(d: Dut) -> None:
    """TPDO transmission type 241 (HighLimit 240) and mode 11 (only 10): abort 0x06090031."""
    refused(d, TOO_HIGH, 0x1800, 2, 241, 1)
    refused(d, TOO_HIGH, 0x6060, 0, 11, 1)


@case("2.11")
def sdo_value_too_low(d: Dut) -> None:
    """TPDO transmission type 0 (LowLimit 1) and mode 9: abort 0x06090032."""
    refused(d, TOO_LOW, 0x1800, 2, 0, 1)
    refused(d, TOO_LOW, 0x6060, 0, 9, 1)


@case("2.12")
def sdo_server_parameter(d: Dut) -> None:
    """0x1200: 2 sub-indices, COB-IDs 0x600 + id (client to server) and 0x580 + id, read-only."""
    for node in IDS:
        assert d.read(0x1200, 0, node) == 2
        assert d.read(0x1200, 1, node) == 0x600 + node
        assert d.read(0x1200, 2, node) == 0x580 + node
    refused(d, READ_ONLY, 0x1200, 1, 0x601, 4)


@case("2.14, 2.15")
def sdo_segmented_download(d: Dut) -> None:
    """0x1017 written by a segmented download (size indicated, one segment): accepted, read
    back."""
    d.download_segmented(0x1017, 0, (250).to_bytes(2, "little"))
    assert d.read(0x1017) == 250


@case("2.16")
def sdo_segmented_upload(d: Dut) -> None:
    """0x1008 (26 bytes) by a segmented upload: size indicated, toggle bits alternating, the
    last segment flagged, the text of the EDS."""
    assert d.upload(0x1008).decode() == "RRR simulated CiA 402 axis"


@case("2.17")
def sdo_wrong_toggle(d: Dut) -> None:
    """A segmented upload whose first segment request has toggle 1: abort 0x05030000."""
    r = d.request(N, bytes([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]))
    assert r[0] == 0x41 and int.from_bytes(r[4:], "little") == 26
    s = d.request(N, bytes([0x70, 0, 0, 0, 0, 0, 0, 0]))
    assert s[0] == 0x80 and int.from_bytes(s[4:], "little") == TOGGLE


@case("2.18")
def sdo_upload_again(d: Dut) -> None:
    """0x1008 uploaded twice, and an upload started anew in the middle of one: the same text
    each time (a new initiate ends the transfer under way)."""
    d.request(N, bytes([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]))
    d.request(N, bytes([0x60, 0, 0, 0, 0, 0, 0, 0]))
    assert d.upload(0x1008) == d.upload(0x1008) == b"RRR simulated CiA 402 axis"


@case("2.19, 2.22, 2.23, 2.26, 2.27")
def sdo_block_upload_refused(d: Dut) -> None:
    """A block upload request (with and without CRC): abort 0x05040001 (not supported)."""
    for cmd in (0xA0, 0xA4):
        r = d.request(N, bytes([cmd, 0x08, 0x10, 0, 0x7F, 0, 0, 0]))
        assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("2.20, 2.21, 2.24, 2.25")
def sdo_block_download_refused(d: Dut) -> None:
    """A block download request of 0x1017 (with and without CRC): abort 0x05040001."""
    for cmd in (0xC2, 0xC6):
        r = d.request(N, bytes([cmd, 0x17, 0x10, 0, 2, 0, 0, 0]))
        assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("-")
def sdo_request_not_8_bytes(d: Dut) -> None:
    """SDO requests of 5 and 0 bytes: abort 0x05040001."""
    for data in (bytes([0x40, 0x00, 0x10, 0, 0]), b""):
        r = d.request(N, data)
        assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("-")
def sdo_segment_without_transfer(d: Dut) -> None:
    """An upload segment and a download segment request with no transfer under way: abort
    0x05040001."""
    for cmd in (0x60, 0x00):
        r = d.request(N, bytes([cmd, 0, 0, 0, 0, 0, 0, 0]))
        assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("-")
def sdo_segmented_download_too_long(d: Dut) -> None:
    """A segmented download into 0x1017 announcing 4 bytes (abort 0x06070012), and one
    announcing 2 whose segment brings 3 (0x06070012)."""
    assert abort(lambda: d.download_segmented(0x1017, 0, bytes(4))) == TOO_LONG
    assert abort(lambda: d.download_segmented(0x1017, 0, bytes(3), size=2)) == TOO_LONG
    assert d.read(0x1017) == 100


@case("-")
def sdo_client_abort(d: Dut) -> None:
    """The client aborts a segmented upload (0x80): no answer, and the next segment request
    finds no transfer (abort 0x05040001)."""
    d.request(N, bytes([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]))
    d.request(N, bytes([0x80, 0x08, 0x10, 0, 0, 0, 0, 0x08]), answer=False)
    r = d.request(N, bytes([0x60, 0, 0, 0, 0, 0, 0, 0]))
    assert r[0] == 0x80 and int.from_bytes(r[4:], "little") == BAD_CS


@case("-")
def sdo_server_timeout(d: Dut) -> None:
    """A segmented upload left without a request: the server aborts it with 0x05040000 (its
    timeout is 1 s), not before 0.5 s and within 10 s."""
    t0 = time.monotonic()
    d.request(N, bytes([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]))
    m = d.mark()
    f = d.expect(0x580 + N, m, "server abort", timeout=10.0)
    assert f.data[0] == 0x80 and int.from_bytes(f.data[4:], "little") == TIMEOUT
    assert f.t - t0 >= 0.5, f.t - t0


@case("-")
def sdo_each_node_its_own(d: Dut) -> None:
    """Each drive answers on its own 0x580 + id only (its serial number 0x1018 sub 4 is its id);
    a request to node 4, absent, gets no answer."""
    for node in IDS:
        m = d.mark()
        assert d.read(0x1018, 4, node) == node
        assert {f.id for f in d.since(m) if 0x580 < f.id < 0x600} == {0x580 + node}
    d.request(4, bytes([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]), answer=False)


# ---- PDO (conformance test 3.x) and the COB-ID rules (8.10) ----


@case("3.1")
def pdo_rpdo_parameters(d: Dut) -> None:
    """RPDO1 0x1400: 2 sub-indices, COB-ID 0x200 + id (valid), transmission type 1."""
    assert [d.read(0x1400, s) for s in (0, 1, 2)] == [2, 0x200 + N, 1]


@case("3.2")
def pdo_tpdo_parameters(d: Dut) -> None:
    """TPDO1 0x1800 and TPDO2 0x1801: COB-IDs 0x180 + id and 0x280 + id (valid), transmission
    type 1 (every SYNC)."""
    assert [d.read(0x1800, s) for s in (0, 1, 2)] == [2, 0x180 + N, 1]
    assert [d.read(0x1801, s) for s in (0, 1, 2)] == [2, 0x280 + N, 1]


@case("3.6, 3.18, 6.3")
def pdo_every_sync(d: Dut) -> None:
    """In operational, each of 10 SYNCs brings TPDO1 (7 bytes) and TPDO2 (6 bytes) of each
    drive, once each, after that SYNC."""
    d.start()
    m = d.mark()
    for _ in range(10):
        got = d.sync_tpdos()
        assert all(len(got[0x180 + i]) == 7 and len(got[0x280 + i]) == 6 for i in IDS)
    d.listen(0.05)
    for i in IDS:
        assert len(d.since(m, 0x180 + i)) == len(d.since(m, 0x280 + i)) == 10


@case("3.12")
def pdo_every_nth_sync(d: Dut) -> None:
    """TPDO1 of transmission type 3: sent on every third SYNC (3 of 9), TPDO2 (type 1) on each."""
    d.write(0x1800, 2, 3, 1)
    d.start()
    m = d.mark()
    for _ in range(9):
        s = d.sync()
        d.expect(0x280 + N, s, "TPDO2")
    d.listen(0.05)
    assert len(d.since(m, 0x180 + N)) == 3 and len(d.since(m, 0x280 + N)) == 9


@case("3.7, 3.13")
def pdo_acyclic_refused(d: Dut) -> None:
    """TPDO transmission type 0 (synchronous acyclic, not supported): abort 0x06090032."""
    refused(d, TOO_LOW, 0x1800, 2, 0, 1)
    refused(d, TOO_LOW, 0x1801, 2, 0, 1)


@case("3.4, 3.5, 3.10, 3.11")
def pdo_event_driven_refused(d: Dut) -> None:
    """TPDO transmission types 254 and 255 (event-driven, not supported): abort 0x06090031; the
    event timer sub 5 does not exist (0x06090011)."""
    for kind in (254, 255):
        refused(d, TOO_HIGH, 0x1800, 2, kind, 1)
    assert abort(lambda: d.upload(0x1800, 5)) == NO_SUB


@case("3.8, 3.14, 3.20")
def pdo_no_sync_start_value(d: Dut) -> None:
    """No SYNC start value (sub 6): abort 0x06090011 on read and write."""
    assert abort(lambda: d.upload(0x1800, 6)) == NO_SUB
    refused(d, NO_SUB, 0x1800, 6, 1, 1)


@case("-")
def pdo_rpdo_type_reserved(d: Dut) -> None:
    """RPDO transmission types 241 and 253 (reserved): abort 0x06090030; 240 and 254
    accepted."""
    for kind in (241, 253):
        refused(d, VALUE, 0x1400, 2, kind, 1)
    for kind in (240, 254):
        d.write(0x1400, 2, kind, 1)
        assert d.read(0x1400, 2) == kind


@case("-")
def pdo_rpdo_applied_on_sync(d: Dut) -> None:
    """RPDO1 of type 1: the controlword it carries acts at the next SYNC, not before."""
    d.start()
    rpdo(d, 0x06, 0)
    d.listen(0.1)
    assert statusword(d) & 0x4F == 0x40  # SWITCH ON DISABLED
    d.sync_tpdos()
    assert statusword(d) & 0x6F == 0x21  # READY TO SWITCH ON


@case("-")
def pdo_rpdo_type_255_at_once(d: Dut) -> None:
    """RPDO1 of type 255: its controlword acts at once, without a SYNC."""
    d.write(0x1400, 2, 255, 1)
    d.start()
    rpdo(d, 0x06, 0)
    d.listen(0.1)
    assert statusword(d) & 0x6F == 0x21


@case("3.21")
def pdo_default_mapping(d: Dut) -> None:
    """The default mappings (RPDO1 0x6040 + 0x6071, TPDO1 0x6041 + 0x6064 + 0x6061, TPDO2
    0x606C + 0x6077): each entry names an object that exists, uploads with the mapped length."""
    want = {0x1600: [0x60400010, 0x60710010],
            0x1A00: [0x60410010, 0x60640020, 0x60610008],
            0x1A01: [0x606C0020, 0x60770010]}
    for index, entries in want.items():
        n = d.read(index, 0)
        got = [d.read(index, s) for s in range(1, n + 1)]
        assert got == entries, (hex(index), [hex(g) for g in got])
        for m in got:
            assert len(d.upload(m >> 16, (m >> 8) & 0xFF)) * 8 == m & 0xFF, hex(m)


@case("-")
def pdo_tpdo1_carries_the_mode(d: Dut) -> None:
    """TPDO1 in operational: the statusword (SWITCH ON DISABLED), the position actual value and
    the modes of operation display 0x6061 = 10 (cyclic synchronous torque) in its last byte."""
    d.start()
    got = d.sync_tpdos()
    for i in IDS:
        t1 = got[0x180 + i]
        assert int.from_bytes(t1[:2], "little") & 0x4F == 0x40 and t1[6] == 10
        assert int.from_bytes(t1[2:6], "little", signed=True) == d.read(0x6064, 0, i, True)


@case("3.22, 3.23")
def pdo_remap_procedure(d: Dut) -> None:
    """CiA 301's mapping procedure on TPDO2 (COB-ID invalid, sub 0 = 0, entries, sub 0 = 2,
    COB-ID valid): accepted; TPDO2 then carries the torque actual value and the statusword (4
    bytes)."""
    d.write(0x1801, 1, 0x80000000 | 0x280 + N, 4)
    d.write(0x1A01, 0, 0, 1)
    d.write(0x1A01, 1, 0x60770010, 4)
    d.write(0x1A01, 2, 0x60410010, 4)
    d.write(0x1A01, 0, 2, 1)
    d.write(0x1801, 1, 0x280 + N, 4)
    d.start()
    t2 = d.sync_tpdos()[0x280 + N]
    assert len(t2) == 4 and int.from_bytes(t2[2:], "little") & 0x4F == 0x40


@case("3.24")
def pdo_mapping_while_valid(d: Dut) -> None:
    """The mapping of a valid PDO (sub 0 and an entry), and an entry while sub 0 is not 0:
    abort 0x06010000."""
    refused(d, UNSUPPORTED, 0x1A00, 0, 0, 1)
    refused(d, UNSUPPORTED, 0x1A00, 1, 0x60770010, 4)
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    refused(d, UNSUPPORTED, 0x1A00, 1, 0x60770010, 4)


@case("3.25")
def pdo_too_many_entries(d: Dut) -> None:
    """Sub 0 of a mapping above the 4 entries there are: abort 0x06090031."""
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    d.write(0x1A00, 0, 0, 1)
    refused(d, TOO_HIGH, 0x1A00, 0, 5, 1)


@case("3.26")
def pdo_mapping_too_long(d: Dut) -> None:
    """Three entries of 32 + 32 + 16 bits (80 > 64) made active by sub 0 = 3: abort
    0x06040042."""
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    d.write(0x1A00, 0, 0, 1)
    for s, m in enumerate((0x60640020, 0x606C0020, 0x60410010), 1):
        d.write(0x1A00, s, m, 4)
    refused(d, MAP_LEN, 0x1A00, 0, 3, 1)


@case("3.28")
def pdo_read_only_into_rpdo(d: Dut) -> None:
    """The read-only statusword 0x6041 mapped into RPDO1: abort 0x06040041."""
    d.write(0x1400, 1, 0x80000000 | 0x200 + N, 4)
    d.write(0x1600, 0, 0, 1)
    refused(d, NO_MAP, 0x1600, 1, 0x60410010, 4)


@case("3.29, 3.32")
def pdo_unmappable_refused(d: Dut) -> None:
    """Objects without PDOMapping (max torque 0x6072 into RPDO1, device type 0x1000 into
    TPDO1): abort 0x06040041."""
    d.write(0x1400, 1, 0x80000000 | 0x200 + N, 4)
    d.write(0x1600, 0, 0, 1)
    refused(d, NO_MAP, 0x1600, 1, 0x60720010, 4)
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    d.write(0x1A00, 0, 0, 1)
    refused(d, NO_MAP, 0x1A00, 1, 0x10000020, 4)


@case("3.30")
def pdo_read_only_into_tpdo(d: Dut) -> None:
    """The read-only torque actual value 0x6077 mapped into TPDO1: accepted."""
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    d.write(0x1A00, 0, 0, 1)
    d.write(0x1A00, 1, 0x60770010, 4)
    d.write(0x1A00, 0, 1, 1)
    assert d.read(0x1A00, 1) == 0x60770010


@case("3.27, 3.31, 3.33")
def pdo_dummy_and_wrong_entries(d: Dut) -> None:
    """Entries the drive cannot map (the EDS's DummyUsage is 0): a dummy UNSIGNED8 0x0005, the
    statusword with 32 bits, a missing object: abort 0x06040041."""
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    d.write(0x1A00, 0, 0, 1)
    for m in (0x00050008, 0x60410020, 0x30000010):
        refused(d, NO_MAP, 0x1A00, 1, m, 4)


@case("-")
def pdo_rpdo_too_short(d: Dut) -> None:
    """An RPDO of 3 bytes (4 mapped): EMCY 0x8210 with error register 0, not applied, no
    fault."""
    d.start()
    m = d.mark()
    d.send(0x200 + N, bytes([0x06, 0, 0]))
    assert emcy(d.expect(0x80 + N, m, "EMCY")) == (0x8210, 0)
    d.sync_tpdos()
    assert statusword(d) & 0x4F == 0x40


@case("-")
def pdo_rpdo_longer_applied(d: Dut) -> None:
    """An RPDO of 8 bytes (4 mapped): the mapped bytes are applied, no EMCY."""
    d.start()
    m = d.mark()
    d.send(0x200 + N, bytes([0x06, 0, 0, 0, 0xAA, 0xBB, 0xCC, 0xDD]))
    d.sync_tpdos()
    assert statusword(d) & 0x6F == 0x21 and not d.since(m, 0x80 + N)


@case("-")
def pdo_not_outside_operational(d: Dut) -> None:
    """In pre-operational and in stopped, a SYNC brings no TPDO and an RPDO is not applied."""
    for command in (0x80, 0x02):
        d.nmt(command)
        m = d.mark()
        rpdo(d, 0x06, 0)
        d.sync()
        d.listen(0.2)
        assert not [f for f in d.since(m) if f.id & 0x780 in (0x180, 0x280)]
        d.nmt(0x80)
        assert statusword(d) & 0x4F == 0x40


@case("8.10")
def cob_restricted_tpdo1(d: Dut) -> None:
    """Every restricted CAN-ID (926 of them) as the COB-ID of a valid TPDO1: abort 0x06090030,
    the PDO left as it was."""
    _restricted_sweep(d, 0x1800)


@case("8.10")
def cob_restricted_tpdo2(d: Dut) -> None:
    """The same for TPDO2 (0x1801)."""
    _restricted_sweep(d, 0x1801)


@case("8.10")
def cob_restricted_rpdo1(d: Dut) -> None:
    """The same for RPDO1 (0x1400)."""
    _restricted_sweep(d, 0x1400)


def _restricted_sweep(d: Dut, comm: int) -> None:
    invalid = 0x80000000 | d.read(comm, 1)
    d.write(comm, 1, invalid, 4)
    ids = [i for i in range(0x800) if restricted(i)]
    assert len(ids) == 926
    for can_id in ids:
        refused(d, VALUE, comm, 1, can_id, 4)
    assert d.read(comm, 1) == invalid


@case("-")
def cob_issue_list(d: Dut) -> None:
    """A TPDO moved onto 0x000 (NMT), 0x080 (SYNC), 0x081 (EMCY), 0x581 and 0x601 (SDO), 0x701
    (heartbeat) or 0x7E5 (LSS): abort 0x06090030."""
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    for can_id in (0x000, 0x080, 0x081, 0x581, 0x601, 0x701, 0x7E5):
        refused(d, VALUE, 0x1800, 1, can_id, 4)


@case("-")
def cob_allowed_neighbours(d: Dut) -> None:
    """The identifiers next to the restricted ranges (0x181, 0x580, 0x600, 0x680, 0x6DF, 0x700)
    are accepted for a valid TPDO1."""
    for can_id in (0x181, 0x580, 0x600, 0x680, 0x6DF, 0x700):
        d.write(0x1800, 1, 0x80000000 | can_id, 4)
        d.write(0x1800, 1, can_id, 4)
        assert d.read(0x1800, 1) == can_id


@case("-")
def cob_change_while_valid(d: Dut) -> None:
    """A new identifier for a valid TPDO1: abort 0x06090030; the same identifier again, and bit
    31 set, are accepted."""
    refused(d, VALUE, 0x1800, 1, 0x190, 4)
    d.write(0x1800, 1, 0x180 + N, 4)
    d.write(0x1800, 1, 0x80000000 | 0x180 + N, 4)
    assert d.read(0x1800, 1) == 0x80000000 | 0x180 + N


@case("-")
def cob_29_bit_refused(d: Dut) -> None:
    """COB-IDs with bit 29 (a 29-bit identifier), valid or not, and with bits 11..28 set: abort
    0x06090030."""
    for value in (0x20000000 | 0x180 + N, 0xA0000000 | 0x180 + N, 0x00000800 | 0x180 + N,
                  0x80100000 | 0x180 + N):
        refused(d, VALUE, 0x1800, 1, value, 4)
    assert d.read(0x1800, 1) == 0x180 + N


@case("-")
def cob_restricted_while_invalid(d: Dut) -> None:
    """An invalid TPDO1 (bit 31) may hold a restricted identifier (0x000): accepted, and nothing
    is sent on it at SYNC."""
    d.write(0x1800, 1, 0x80000000, 4)
    d.start()
    m = d.mark()
    for _ in range(3):
        s = d.sync()
        d.expect(0x280 + N, s, "TPDO2")
    d.listen(0.05)
    assert not d.since(m, 0x000) and not d.since(m, 0x180 + N)


@case("-")
def cob_moved_tpdo(d: Dut) -> None:
    """TPDO1 moved to 0x1A5 (invalid, new identifier, valid): sent there at SYNC, not on
    0x180 + id."""
    d.write(0x1800, 1, 0x80000000 | 0x1A5, 4)
    d.write(0x1800, 1, 0x1A5, 4)
    d.start()
    m = d.sync()
    assert len(d.expect(0x1A5, m, "TPDO1 on 0x1A5").data) == 7
    d.listen(0.05)
    assert not d.since(m, 0x180 + N)


# ---- object dictionary (conformance test 4.x) ----


@case("4.1, 4.3, 4.4, 4.7")
def od_access_types(d: Dut) -> None:
    """Every entry of the EDS as its AccessType says: ro and const read (with the size of their
    type) but not written (0x06010002), wo written but not read (0x06010001), rw read."""
    entries = eds_entries()
    assert len(entries) >= 50
    for e in entries:
        if e.access == "wo":
            assert abort(lambda e=e: d.upload(e.index, e.sub)) == WRITE_ONLY
            continue
        data = d.upload(e.index, e.sub)
        assert e.dtype == 9 or len(data) == e.size, (hex(e.index), e.sub, data.hex())
        if e.access in ("ro", "const") and e.dtype != 9:
            refused(d, READ_ONLY, e.index, e.sub, int.from_bytes(data, "little"), e.size)


#: Values the drive measures or sets itself (not a constant default): the statusword (from the
#: 402 state), position, velocity and torque actual values, and the rated torque of each axis.
MEASURED = {0x6041, 0x6064, 0x606C, 0x6077, 0x6076}


@case("4.2, 4.8")
def od_defaults_of_the_eds(d: Dut) -> None:
    """After reset node every readable entry holds the EDS's DefaultValue ($NODEID substituted;
    the device name its text), but the values the drive measures (statusword, actual values,
    rated torque of the axis)."""
    for e in eds_entries():
        if e.access == "wo" or e.index in MEASURED:
            continue
        data = d.upload(e.index, e.sub)
        got: int | str = data.decode() if e.dtype == 9 else int.from_bytes(
            data, "little", signed=e.signed)
        assert got == e.default, (hex(e.index), e.sub, got, e.default)


@case("4.5, 4.6")
def od_limits(d: Dut) -> None:
    """Every entry with LowLimit or HighLimit in the EDS: one below the low limit is aborted
    with 0x06090032, one above the high limit with 0x06090031, and the limits themselves are
    accepted (not for the fault injection 0x2000)."""
    tried = 0
    for e in eds_entries():
        bits = 8 * e.size
        lo_type = -(1 << bits - 1) if e.signed else 0
        hi_type = (1 << bits - 1) - 1 if e.signed else (1 << bits) - 1
        if e.low is not None and e.low > lo_type:
            refused(d, TOO_LOW, e.index, e.sub, e.low - 1, e.size)
            tried += 1
        if e.high is not None and e.high < hi_type:
            refused(d, TOO_HIGH, e.index, e.sub, e.high + 1, e.size)
            tried += 1
        if e.index != 0x2000:
            for limit in (e.low, e.high):
                if limit is not None:
                    d.write(e.index, e.sub, limit, e.size)
    assert tried >= 10


@case("4.9")
def od_write_back_drive_entries(d: Dut) -> None:
    """Every rw entry of 0x2000..0x6FFF read and written back with its value: accepted, the
    value unchanged."""
    entries = [e for e in eds_entries() if e.access == "rw" and e.index >= 0x2000]
    assert len(entries) >= 10
    for e in entries:
        value = d.read(e.index, e.sub)
        d.write(e.index, e.sub, value, e.size)
        assert d.read(e.index, e.sub) == value, hex(e.index)


@case("-")
def od_identity(d: Dut) -> None:
    """0x1018: 4 sub-indices; vendor 0, product code 0x52525233, revision 0x00010000, the serial
    number the node id, on each drive."""
    for node in IDS:
        assert [d.read(0x1018, s, node) for s in range(5)] == [4, 0, 0x52525233, 0x00010000,
                                                                 node]


# ---- EMCY (conformance test 5.x) ----


@case("5.1")
def emcy_cob_id(d: Dut) -> None:
    """0x1014 = 0x80 + id on each drive, read-only (0x06010002)."""
    for node in IDS:
        assert d.read(0x1014, 0, node) == 0x80 + node
    refused(d, READ_ONLY, 0x1014, 0, 0x181, 4)


@case("5.2")
def emcy_error_register_at_boot(d: Dut) -> None:
    """The error register 0x1001 and the error code 0x603F are 0 after reset node."""
    assert d.read(0x1001) == 0 and d.read(0x603F) == 0


@case("5.3, 5.6")
def emcy_no_error_history(d: Dut) -> None:
    """No pre-defined error field 0x1003 (abort 0x06020000): the drive keeps the one error
    code in 0x603F."""
    assert abort(lambda: d.upload(0x1003, 0)) == NO_OBJECT
    assert abort(lambda: d.upload(0x1003, 1)) == NO_OBJECT


@case("5.4, 5.5")
def emcy_forced(d: Dut) -> None:
    """A fault forced through 0x2000 = 0x5001: one EMCY on 0x80 + id (8 bytes: the code, the
    error register 0x81, five zero bytes), 0x1001 = 0x81, 0x603F = 0x5001, FAULT; the other
    drives send none."""
    m = d.mark()
    d.write(0x2000, 0, 0x5001, 2)
    assert emcy(d.expect(0x80 + N, m, "EMCY")) == (0x5001, 0x81)
    assert d.read(0x1001) == 0x81 and d.read(0x603F) == 0x5001
    assert statusword(d) & 0x4F == 0x08
    d.listen(0.1)
    assert [f.id for f in d.since(m) if 0x80 < f.id < 0x100] == [0x80 + N]


@case("-")
def emcy_error_reset(d: Dut) -> None:
    """The 402 fault reset (controlword bit 7 rising) after a forced fault: the error-reset EMCY
    (code 0, register 0), 0x1001 and 0x603F cleared, SWITCH ON DISABLED."""
    d.write(0x2000, 0, 0x5001, 2)
    m = d.mark()
    d.write(0x6040, 0, 0x80, 2)
    assert emcy(d.expect(0x80 + N, m, "error-reset EMCY")) == (0, 0)
    assert d.read(0x1001) == 0 and d.read(0x603F) == 0
    assert statusword(d) & 0x4F == 0x40


@case("-")
def emcy_not_in_stopped(d: Dut) -> None:
    """A fault in NMT stopped (the master's heartbeat lost) sends no EMCY (CiA 301); it is
    latched all the same: 0x1001 = 0x11 and 0x603F = 0x8130 once pre-operational."""
    d.write(0x1016, 1, MASTER << 16 | 200, 4)
    d.send(0x700 + MASTER, b"\x05")
    d.nmt(0x02, N)
    m = d.mark()
    d.listen(1.0)
    assert not d.since(m, 0x80 + N)
    d.nmt(0x80, N)
    assert d.read(0x1001) == 0x11 and d.read(0x603F) == 0x8130


@case("-")
def emcy_sync_length(d: Dut) -> None:
    """A SYNC of 2 bytes: EMCY 0x8240 with error register 0 from each drive, ignored, no
    fault."""
    d.start()
    m = d.sync(b"\x01\x02")
    for node in IDS:
        assert emcy(d.expect(0x80 + node, m, f"EMCY of drive {node}")) == (0x8240, 0)
    d.listen(0.05)
    assert not [f for f in d.since(m) if f.id & 0x780 in (0x180, 0x280)]
    assert d.read(0x1001) == 0 and statusword(d) & 0x4F == 0x40


# ---- SYNC (conformance test 6.x) ----


@case("6.1")
def sync_cob_id(d: Dut) -> None:
    """0x1005 = 0x80 (SYNC consumer), read-only (0x06010002)."""
    assert d.read(0x1005) == 0x80
    refused(d, READ_ONLY, 0x1005, 0, 0x40000080, 4)


@case("6.2, 6.4, 6.5, 6.6, 6.9, 6.10")
def sync_no_producer_objects(d: Dut) -> None:
    """The drives consume SYNC only: no communication cycle period 0x1006, no synchronous
    window 0x1007, no counter overflow 0x1019 (abort 0x06020000)."""
    for index in (0x1006, 0x1007, 0x1019):
        assert abort(lambda index=index: d.upload(index)) == NO_OBJECT


@case("6.7, 6.8")
def sync_with_counter(d: Dut) -> None:
    """SYNCs with a counter byte (1 to 5) bring the TPDOs as SYNCs without one."""
    d.start()
    for k in range(1, 6):
        got = d.sync_tpdos(bytes([k]))
        assert len(got[0x180 + N]) == 7


# ---- heartbeat (conformance test 7.x) ----


@case("7.101")
def hb_producer_time_written(d: Dut) -> None:
    """0x1017 written (250 ms) and read back; its type is UNSIGNED16 (4 bytes: 0x06070012)."""
    d.write(0x1017, 0, 250, 2)
    assert d.read(0x1017) == 250
    refused(d, TOO_LONG, 0x1017, 0, 250, 4)


@case("7.102")
def hb_producer_period(d: Dut) -> None:
    """0x1017 = 50 ms: over 1.5 s drive 2's heartbeats come (NMT state 0x7F) at a mean interval
    within 5..500 ms (10x either way)."""
    d.write(0x1017, 0, 50, 2)
    m = d.mark()
    d.listen(1.5)
    beats = d.since(m, 0x700 + N)
    assert len(beats) >= 3 and all(f.data == b"\x7f" for f in beats)
    mean = (beats[-1].t - beats[0].t) / (len(beats) - 1)
    assert 0.005 <= mean <= 0.5, mean


@case("7.103")
def hb_producer_off(d: Dut) -> None:
    """0x1017 = 0: drive 2 sends no heartbeat in the next 0.5 s (five periods of the default),
    the others go on."""
    d.write(0x1017, 0, 0, 2)
    m = d.mark()
    d.listen(0.5)
    assert not d.since(m, 0x700 + N) and d.since(m, 0x701) and d.since(m, 0x703)


@case("7.104")
def hb_consumer_written_twice(d: Dut) -> None:
    """The consumer 0x1016: 1 entry; the same value (node 0x7F, 500 ms) written twice is
    accepted and read back."""
    assert d.read(0x1016, 0) == 1
    for _ in range(2):
        d.write(0x1016, 1, MASTER << 16 | 500, 4)
    assert d.read(0x1016, 1) == MASTER << 16 | 500


@case("7.105, 7.106")
def hb_consumer_timeout(d: Dut) -> None:
    """Consumer of node 0x7F, 1000 ms: no fault while its heartbeat comes every 50 ms for 1.5 s;
    after the last one, EMCY 0x8130 with error register 0x11 (0.5 to 10 s after it), FAULT, on
    drive 2 only."""
    d.write(0x1016, 1, MASTER << 16 | 1000, 4)
    m = d.mark()
    last = 0.0
    for _ in range(30):
        last = d.send(0x700 + MASTER, b"\x05")
        d.listen(0.05)
    assert not d.since(m, 0x80 + N)
    f = d.expect(0x80 + N, m, "EMCY 0x8130", timeout=10.0)
    assert emcy(f) == (0x8130, 0x11) and 0.5 <= f.t - last <= 10.0, f.t - last
    assert statusword(d) & 0x4F == 0x08
    assert not [g for g in d.since(m) if 0x80 < g.id < 0x100 and g.id != 0x80 + N]


@case("7.106")
def hb_consumer_starts_with_first(d: Dut) -> None:
    """Consumer armed (200 ms) but no heartbeat of the master yet: monitoring has not started,
    no EMCY in 1 s."""
    d.write(0x1016, 1, MASTER << 16 | 200, 4)
    m = d.mark()
    d.listen(1.0)
    assert not d.since(m, 0x80 + N) and statusword(d) & 0x4F == 0x40


@case("-")
def hb_consumer_other_node_ignored(d: Dut) -> None:
    """Consumer of node 0x7F (300 ms): heartbeats of node 0x7E do not feed it; one of 0x7F then
    only 0x7E's every 50 ms: EMCY 0x8130 all the same."""
    d.write(0x1016, 1, MASTER << 16 | 300, 4)
    m = d.mark()
    d.send(0x700 + MASTER, b"\x05")
    f = None
    for _ in range(100):  # up to 5 s (10x)
        d.send(0x77E, b"\x05")
        f = d.wait(lambda g: g.id == 0x80 + N, m, 0.05)
        if f is not None:
            break
    assert f is not None and emcy(f) == (0x8130, 0x11)


@case("7.107")
def hb_consumer_off_after_reset(d: Dut) -> None:
    """Reset communication sets the consumer back to 0 (off) and the producer to 100 ms."""
    d.write(0x1016, 1, MASTER << 16 | 500, 4)
    d.write(0x1017, 0, 30, 2)
    m = d.mark()
    d.nmt(0x82, N)
    d.expect(0x700 + N, m, "boot-up")
    assert d.read(0x1016, 1) == 0 and d.read(0x1017) == 100


@case("7.1, 7.2, 7.3, 7.4, 7.5, 7.6, 7.201")
def hb_no_node_guarding(d: Dut) -> None:
    """Heartbeat only: no guard time 0x100C nor life time factor 0x100D (abort 0x06020000)."""
    for index in (0x100C, 0x100D):
        assert abort(lambda index=index: d.upload(index)) == NO_OBJECT


# ---- NMT (conformance test 9.x and 10.x) ----


@case("9.2")
def nmt_boot_up(d: Dut) -> None:
    """NMT reset node: each drive sends its boot-up 0x700 + id with one byte 0x00, then
    heartbeats of pre-operational (0x7F)."""
    m = d.mark()
    d.reset()
    boots = [f for f in d.since(m) if f.id in (0x701, 0x702, 0x703) and f.data == b"\0"]
    assert sorted(f.id for f in boots) == [0x701, 0x702, 0x703]
    assert d.state_seen(N) == 0x7F


@case("9.1")
def nmt_reset_node_defaults(d: Dut) -> None:
    """Reset node brings every value written back to its default (0x1017, 0x1800 sub 2, 0x2001,
    0x605A, 0x605D, 0x6072)."""
    written = {(0x1017, 0, 2): 30, (0x1800, 2, 1): 7, (0x2001, 0, 1): 9, (0x605A, 0, 2): 5,
               (0x605D, 0, 2): 2, (0x6072, 0, 2): 500}
    before = {k: d.read(k[0], k[1]) for k in written}
    for (index, sub, size), value in written.items():
        d.write(index, sub, value, size)
    d.reset()
    assert {k: d.read(k[0], k[1]) for k in written} == before


@case("10.1")
def nmt_reset_communication(d: Dut) -> None:
    """Reset communication: a boot-up, pre-operational, 0x1000..0x1FFF back to their defaults
    (0x1017, 0x1800 sub 2), the drive's objects kept (0x605A)."""
    d.write(0x1017, 0, 30, 2)
    d.write(0x1800, 2, 7, 1)
    d.write(0x605A, 0, 5, 2)
    d.start()
    m = d.mark()
    d.nmt(0x82, N)
    d.expect(0x700 + N, m, "boot-up")
    assert d.state_seen(N) == 0x7F
    assert (d.read(0x1017), d.read(0x1800, 2), d.read(0x605A)) == (100, 1, 5)


@case("9.3")
def nmt_operational(d: Dut) -> None:
    """NMT start: heartbeat state 0x05, TPDOs on SYNC, SDO answered."""
    d.start()
    assert d.state_seen(N) == 0x05
    d.sync_tpdos()
    assert d.read(0x1000) == 0x00020192


@case("9.4")
def nmt_stopped(d: Dut) -> None:
    """NMT stop: heartbeat state 0x04, no SDO answer, no TPDO on SYNC."""
    d.start()
    d.nmt(0x02)
    assert d.state_seen(N) == 0x04
    d.request(N, bytes([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]), answer=False)
    m = d.sync()
    d.listen(0.2)
    assert not [f for f in d.since(m) if f.id & 0x780 in (0x180, 0x280)]


@case("10.2")
def nmt_transitions(d: Dut) -> None:
    """Pre-operational, operational, pre-operational, stopped, pre-operational, operational,
    stopped: each state in the next heartbeat (0x7F, 0x05, 0x04)."""
    for command, state in ((0x01, 0x05), (0x80, 0x7F), (0x02, 0x04), (0x80, 0x7F),
                           (0x01, 0x05), (0x02, 0x04)):
        d.nmt(command)
        assert d.state_seen(N) == state, (hex(command), state)


@case("10.3")
def nmt_reset_from_stopped(d: Dut) -> None:
    """Reset node and reset communication from stopped: the boot-up, then pre-operational."""
    for command in (0x81, 0x82):
        d.nmt(0x02)
        assert d.state_seen(N) == 0x04
        m = d.mark()
        d.nmt(command, N)
        f = d.expect(0x700 + N, m, "boot-up")
        assert f.data == b"\0" and d.state_seen(N) == 0x7F


@case("-")
def nmt_addressed(d: Dut) -> None:
    """NMT start of node 2 only: drive 2 operational, drives 1 and 3 stay pre-operational; a
    command to node 9 (absent) changes nothing."""
    d.nmt(0x01, N)
    d.nmt(0x02, 9)
    d.listen(0.25)
    assert d.state_seen(N) == 0x05
    assert d.state_seen(1) == 0x7F and d.state_seen(3) == 0x7F


@case("-")
def nmt_bad_frames_ignored(d: Dut) -> None:
    """NMT frames of 1 and 3 bytes and with the unknown command 0x03: ignored (still
    pre-operational, SDO answered)."""
    for data in (b"\x01", b"\x01\x00\x00", b"\x03\x00"):
        d.send(0x000, data)
    d.listen(0.25)
    assert d.state_seen(N) == 0x7F and d.read(0x1000) == 0x00020192


@case("-")
def nmt_leave_operational_enabled(d: Dut) -> None:
    """NMT pre-operational while OPERATION ENABLED in operational: EMCY 0x8100 with error
    register 0x11 (sent before the state changes), FAULT."""
    d.write(0x2001, 0, 0, 1)
    d.start()
    enable(d)
    m = d.mark()
    d.nmt(0x80, N)
    assert emcy(d.expect(0x80 + N, m, "EMCY 0x8100")) == (0x8100, 0x11)
    assert statusword(d) & 0x4F == 0x08


# ---- store and restore (conformance test 8.x) ----


@case("8.1, 8.2, 8.5, 8.6, 8.9")
def other_no_store(d: Dut) -> None:
    """No store parameters 0x1010 (the drives keep nothing across a reset): abort
    0x06020000."""
    assert abort(lambda: d.upload(0x1010, 1)) == NO_OBJECT
    refused(d, NO_OBJECT, 0x1010, 1, int.from_bytes(b"save", "little"), 4)


@case("8.3, 8.4, 8.7, 8.8")
def other_no_restore(d: Dut) -> None:
    """No restore default parameters 0x1011 (reset node restores them): abort 0x06020000."""
    assert abort(lambda: d.upload(0x1011, 1)) == NO_OBJECT
    refused(d, NO_OBJECT, 0x1011, 1, int.from_bytes(b"load", "little"), 4)


# ---- CiA 402, as masters in the field use it ----


@case("-")
def p402_enable_sequence(d: Dut) -> None:
    """Shutdown, switch on, enable operation by SDO: statusword READY TO SWITCH ON (0x21 under
    0x6F), SWITCHED ON (0x23), OPERATION ENABLED (0x27), each with the remote bit 9."""
    for cw, sw in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27)):
        d.write(0x6040, 0, cw, 2)
        word = statusword(d)
        assert word & 0x6F == sw and word & 0x200, hex(word)


@case("-")
def p402_modes(d: Dut) -> None:
    """Supported modes 0x6502 = bit 9 (cyclic synchronous torque) only, no homing mode; 0x6060
    takes 10 only (8, cyclic synchronous position: 0x06090032); 0x6061 shows 10."""
    assert d.read(0x6502) == 1 << 9
    refused(d, TOO_LOW, 0x6060, 0, 8, 1)
    d.write(0x6060, 0, 10, 1)
    assert d.read(0x6061) == 10


@case("-")
def p402_homing_method(d: Dut) -> None:
    """The homing method 0x6098 reads 0 (no homing: a master that homes at start-up is done);
    35 (homing on the current position) is refused with 0x06090031."""
    assert d.read(0x6098, signed=True) == 0
    refused(d, TOO_HIGH, 0x6098, 0, 35, 1)


@case("-")
def p402_option_codes(d: Dut) -> None:
    """The option codes 0x605A..0x605E read 6, 0, 1, 1, 0; the quick stop codes that brake on a
    limit (3) and codes beyond each object's range are refused."""
    assert [d.read(i, signed=True) for i in range(0x605A, 0x605F)] == [6, 0, 1, 1, 0]
    refused(d, VALUE, 0x605A, 0, 3, 2)
    for index, high in ((0x605B, 1), (0x605C, 1), (0x605D, 2), (0x605E, 2)):
        refused(d, TOO_HIGH, index, 0, high + 1, 2)


@case("-")
def p402_torque_and_halt(d: Dut) -> None:
    """In OPERATION ENABLED the torque actual value 0x6077 (TPDO2) is the target torque of the
    RPDO (300 per mille), 0 while the halt bit (controlword 0x010F) is set, the state kept."""
    d.write(0x2001, 0, 0, 1)
    d.start()
    enable(d)
    for cw, want in ((0x000F, 300), (0x010F, 0), (0x000F, 300)):
        rpdo(d, cw, 300)
        d.sync_tpdos()  # applies the RPDO
        t1t2 = d.sync_tpdos()  # the torque of that period
        assert int.from_bytes(t1t2[0x280 + N][4:6], "little", signed=True) == want, hex(cw)
        assert int.from_bytes(t1t2[0x180 + N][:2], "little") & 0x6F == 0x27


@case("-")
def p402_quick_stop(d: Dut) -> None:
    """Quick stop (controlword 0x02) in OPERATION ENABLED: QUICK STOP ACTIVE (0x07 under 0x6F),
    no EMCY; enable operation leaves it."""
    enable(d)
    m = d.mark()
    d.write(0x6040, 0, 0x02, 2)
    assert statusword(d) & 0x6F == 0x07
    d.write(0x6040, 0, 0x0F, 2)
    assert statusword(d) & 0x6F == 0x27 and not d.since(m, 0x80 + N)


@case("-")
def p402_fault_reset_edge(d: Dut) -> None:
    """A latched fault (0x2000) stays under enable operation; only the rising edge of bit 7
    resets it (a controlword that keeps bit 7 set does not reset again)."""
    d.write(0x2000, 0, 0x5001, 2)
    d.write(0x6040, 0, 0x0F, 2)
    assert statusword(d) & 0x4F == 0x08
    d.write(0x6040, 0, 0x80, 2)
    assert statusword(d) & 0x4F == 0x40
    d.write(0x2000, 0, 0x5002, 2)
    d.write(0x6040, 0, 0x80, 2)
    assert statusword(d) & 0x4F == 0x08 and d.read(0x603F) == 0x5002


# ---- running the cases ------------------------------------------------------------------------


def run_case(dut: Dut, c: Case) -> None:
    """One case from reset node; the frames it received are dropped after it."""
    dut.reset()
    try:
        c.fn(dut)
    finally:
        dut.log.clear()


def table() -> str:
    """The manual's table of the cases (docs/canopen-conformance.md)."""
    rows = ["| case | conformance test | what it checks |", "| --- | --- | --- |"]
    rows += [f"| `{c.name}` | {c.ref} | {c.checks} |" for c in CASES]
    return "\n".join(rows) + "\n"


#: The plant node's options for the suite: the CANopen profile, and silence allowed for long
#: (the cases wait up to 10 s without a frame of the master).
PLANT_ARGS = ["--profile", "canopen", "--idle-timeout-ms", "600000"]


@contextlib.contextmanager
def socketcan_dut(channel: str, timeout: float) -> Iterator[Dut]:
    """The plant on the SocketCAN interface ``channel`` (the bus opened first: a frame sent
    before a node has bound its socket is lost to it), once its first boot-up is on the bus."""
    from rrr_robot.hil.nodes import start_plant, wait_for_boot_up

    bus = can.Bus(interface="socketcan", channel=channel)
    try:
        with start_plant(socketcan=channel, extra=PLANT_ARGS) as plant:
            wait_for_boot_up(bus, plant, 0x700 + IDS[-1], timeout=120.0)
            yield Dut(bus, timeout)
    finally:
        bus.shutdown()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--socketcan", metavar="IF", help="run the cases on this interface")
    ap.add_argument("--out", type=Path, help="the results as JSON")
    ap.add_argument("--timeout", type=float, default=2.0, help="an answer's timeout (s)")
    ap.add_argument("--list", action="store_true", help="print the manual's table of the cases")
    ap.add_argument("cases", nargs="*", help="the cases to run (default: all)")
    args = ap.parse_args(argv)
    if args.list:
        sys.stdout.write(table())
        return 0
    if not args.socketcan or not args.out:
        ap.error("--socketcan and --out are needed to run the cases")
    by_name = {c.name: c for c in CASES}
    unknown = [n for n in args.cases if n not in by_name]
    if unknown:
        ap.error(f"unknown cases: {unknown}")
    results: dict[str, Any] = {}
    with socketcan_dut(args.socketcan, args.timeout) as dut:
        for c in [by_name[n] for n in args.cases] or CASES:
            t0 = time.monotonic()
            try:
                run_case(dut, c)
                results[c.name] = {"ok": True, "detail": ""}
            except Exception:  # every failure is reported in the results
                results[c.name] = {"ok": False, "detail": traceback.format_exc(limit=-3)}
            results[c.name]["seconds"] = round(time.monotonic() - t0, 3)
            tmp = args.out.with_name(args.out.name + ".tmp")
            tmp.write_text(json.dumps(results, indent=1))
            tmp.replace(args.out)
    failed = [n for n, r in results.items() if not r["ok"]]
    print(f"{len(results) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
