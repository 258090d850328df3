"""The object dictionary of the simulated CiA 402 drive (one axis of the arm): one table, here,
from which two files are generated and committed:

- c_src/hil/canopen/gen/hil_canopen_od_table.[ch]: the C table the CANopen slave core
  (c_src/hil/canopen/hil_canopen.c) serves;
- python/rrr_robot/data/rrr_cia402.eds: the EDS (CiA 306) a CANopen master loads (python's
  ``canopen.objectdictionary.import_od``, a PLC's configuration tool), shipped in the wheel and
  installed by CMake next to the DBC.

tests/python/unit/test_canopen_od.py checks that regenerating gives the committed files and that the
unmodified ``canopen`` package parses the EDS into this table. docs/canopen.md describes it.

Usage: python tools/gen_canopen_od.py [--check]   (--check: compare, write nothing; exit 1 if
a committed file differs)
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
C_DIR = ROOT / "c_src" / "hil" / "canopen" / "gen"
EDS_PATH = ROOT / "python" / "rrr_robot" / "data" / "rrr_cia402.eds"

#: CiA 301 data types: code, size in bytes (0: variable), EDS name.
DTYPES: dict[str, tuple[int, int]] = {
    "BOOLEAN": (0x01, 1),
    "INTEGER8": (0x02, 1),
    "INTEGER16": (0x03, 2),
    "INTEGER32": (0x04, 4),
    "UNSIGNED8": (0x05, 1),
    "UNSIGNED16": (0x06, 2),
    "UNSIGNED32": (0x07, 4),
    "VISIBLE_STRING": (0x09, 0),
}
SIGNED = {"INTEGER8", "INTEGER16", "INTEGER32"}
ACCESS = ("ro", "wo", "rw", "const")
OBJECT_CODES = {"VAR": 0x7, "ARRAY": 0x8, "RECORD": 0x9}
#: PDO mapping entries per PDO (sub-indices 1..MAX_MAPPED of 0x1600 / 0x1A00 / 0x1A01).
MAX_MAPPED = 4


@dataclass(frozen=True)
class Sub:
    """One entry (index, sub-index) of the dictionary."""

    sub: int
    key: str  # C slot name: RRR_CO_OD_<key>
    name: str
    dtype: str
    access: str
    default: int | str
    pdo: bool = False  # PDO-mappable
    node_id: bool = False  # the default is "$NODEID+default"
    low: int | None = None
    high: int | None = None


@dataclass(frozen=True)
class Obj:
    """One object: a VAR (one entry, sub-index 0), an ARRAY or a RECORD."""

    index: int
    name: str
    code: str
    subs: tuple[Sub, ...]


def var(index: int, key: str, name: str, dtype: str, access: str, default: int | str, *,
        pdo: bool = False, node_id: bool = False, low: int | None = None,
        high: int | None = None) -> Obj:
    """A VAR object: one entry, sub-index 0."""
    return Obj(index, name, "VAR",
               (Sub(0, key, name, dtype, access, default, pdo, node_id, low, high),))


def _n(key: str, n: int, access: str = "ro") -> Sub:
    return Sub(0, key, "Highest sub-index supported", "UNSIGNED8", access, n)


def _pdo_comm(index: int, pfx: str, name: str, cob: int, rpdo: bool) -> Obj:
    return Obj(index, name, "RECORD", (
        _n(f"{pfx}_N", 2),
        Sub(1, f"{pfx}_COBID", "COB-ID used by PDO", "UNSIGNED32", "rw", cob, node_id=True),
        # RPDO: 0..240 act on the next SYNC, 254/255 at once; TPDO: 1..240 every n-th SYNC
        Sub(2, f"{pfx}_TYPE", "Transmission type", "UNSIGNED8", "rw", 1,
            low=0 if rpdo else 1, high=255 if rpdo else 240),
    ))


def _pdo_map(index: int, pfx: str, name: str, entries: tuple[int, ...]) -> Obj:
    subs = [_n(f"{pfx}_N", len(entries), "rw")]
    for i in range(MAX_MAPPED):
        subs.append(Sub(i + 1, f"{pfx}_{i + 1}", f"Mapping entry {i + 1}", "UNSIGNED32", "rw",
                        entries[i] if i < len(entries) else 0))
    return Obj(index, name, "RECORD", tuple(subs))


#: The CiA 402 profile number and the "servo drive" type in 0x1000.
DEVICE_TYPE = 0x00020192
#: 0x6502 bit 9: cyclic synchronous torque (CST), the one mode of operation (0x6060 = 10).
MODE_CST = 10
#: Position actual value 0x6064 in increments: 2^20 per revolution of the joint (0x608F).
ENCODER_INCREMENTS = 1 << 20

#: The EDS's [FileInfo] dates (CiA 306: MM-DD-YYYY; fixed, so that the file is reproducible):
#: its first version, and the last change of the table (bump it with the table).
EDS_CREATED = "12-03-2026"
EDS_MODIFIED = "12-04-2026"
EDS_TIME = "12:00PM"

#: 0x605A: slow down on the quick-stop ramp and stay in QUICK STOP ACTIVE.
QUICK_STOP_OPTION = 6
#: 0x6072 in per mille of the rated torque 0x6076: |target torque 0x6071| <= 1000.
MAX_TORQUE = 1000

OD: tuple[Obj, ...] = (
    var(0x1000, "DEVICE_TYPE", "Device type", "UNSIGNED32", "ro", DEVICE_TYPE),
    var(0x1001, "ERROR_REGISTER", "Error register", "UNSIGNED8", "ro", 0),
    var(0x1005, "SYNC_COBID", "COB-ID SYNC", "UNSIGNED32", "ro", 0x80),
    var(0x1008, "DEVICE_NAME", "Manufacturer device name", "VISIBLE_STRING", "const",
        "RRR simulated CiA 402 axis"),
    var(0x1014, "EMCY_COBID", "COB-ID EMCY", "UNSIGNED32", "ro", 0x80, node_id=True),
    Obj(0x1016, "Consumer heartbeat time", "ARRAY", (
        _n("HB_CONSUMER_N", 1),
        # bits 16..23 the producer's node id, bits 0..15 the time in ms (0: not monitored)
        Sub(1, "HB_CONSUMER_1", "Consumer heartbeat time 1", "UNSIGNED32", "rw", 0),
    )),
    var(0x1017, "HB_PRODUCER", "Producer heartbeat time", "UNSIGNED16", "rw", 100),
    Obj(0x1018, "Identity object", "RECORD", (
        _n("IDENTITY_N", 4),
        Sub(1, "VENDOR_ID", "Vendor-ID", "UNSIGNED32", "ro", 0),
        Sub(2, "PRODUCT_CODE", "Product code", "UNSIGNED32", "ro", 0x52525233),
        Sub(3, "REVISION", "Revision number", "UNSIGNED32", "ro", 0x00010000),
        Sub(4, "SERIAL", "Serial number", "UNSIGNED32", "ro", 0, node_id=True),
    )),
    Obj(0x1200, "SDO server parameter", "RECORD", (
        _n("SDO_SERVER_N", 2),
        Sub(1, "SDO_RX_COBID", "COB-ID client to server", "UNSIGNED32", "ro", 0x600,
            node_id=True),
        Sub(2, "SDO_TX_COBID", "COB-ID server to client", "UNSIGNED32", "ro", 0x580,
            node_id=True),
    )),
    _pdo_comm(0x1400, "RPDO1", "RPDO1 communication parameter", 0x200, rpdo=True),
    _pdo_map(0x1600, "RPDO1_MAP", "RPDO1 mapping parameter", (0x60400010, 0x60710010)),
    _pdo_comm(0x1800, "TPDO1", "TPDO1 communication parameter", 0x180, rpdo=False),
    _pdo_comm(0x1801, "TPDO2", "TPDO2 communication parameter", 0x280, rpdo=False),
    # 0x6061 last: a CiA 402 master (ros2_canopen) wants the mode display beside the
    # statusword; appended, it leaves the statusword and position where masters decode them
    _pdo_map(0x1A00, "TPDO1_MAP", "TPDO1 mapping parameter",
             (0x60410010, 0x60640020, 0x60610008)),
    _pdo_map(0x1A01, "TPDO2_MAP", "TPDO2 mapping parameter", (0x606C0020, 0x60770010)),
    # manufacturer objects of the simulated drive
    var(0x2000, "FAULT_INJECT", "Simulated fault: write an EMCY error code", "UNSIGNED16", "wo",
        0, low=1),
    var(0x2001, "RPDO_TIMEOUT", "RPDO timeout in SYNC periods (0: off)", "UNSIGNED8", "rw", 3),
    # CiA 402
    var(0x603F, "ERROR_CODE", "Error code", "UNSIGNED16", "ro", 0),
    var(0x6040, "CONTROLWORD", "Controlword", "UNSIGNED16", "rw", 0, pdo=True),
    var(0x6041, "STATUSWORD", "Statusword", "UNSIGNED16", "ro", 0, pdo=True),
    # 0: disable drive function; 1, 2: slow down on the slow-down / quick-stop ramp, then
    # SWITCH ON DISABLED; 5, 6: the same ramp, then stay in QUICK STOP ACTIVE (a torque drive at
    # 0 V: the ramp is immediate). Other values: abort 0x06090030 (checked in hil_canopen.c)
    var(0x605A, "QUICK_STOP_OPTION", "Quick stop option code", "INTEGER16", "rw",
        QUICK_STOP_OPTION),
    # The other option codes (CiA 402): the drive's every stop is 0 torque at once (a torque
    # drive at 0 V: a ramp is immediate), so the codes that ramp do what 0 does; those that
    # brake on the current or voltage limit are refused by the limits (0x06090031)
    # 0x605B shutdown (transition 8): 0 disable drive function, 1 slow down, then disable
    var(0x605B, "SHUTDOWN_OPTION", "Shutdown option code", "INTEGER16", "rw", 0, low=0, high=1),
    # 0x605C disable operation (transition 5): 0 disable drive function, 1 slow down, then disable
    var(0x605C, "DISABLE_OPTION", "Disable operation option code", "INTEGER16", "rw", 1,
        low=0, high=1),
    # 0x605D halt (controlword bit 8): 1 slow-down ramp, 2 quick-stop ramp; stay in OPERATION
    # ENABLED at 0 torque while bit 8 is set (hil_canopen.c)
    var(0x605D, "HALT_OPTION", "Halt option code", "INTEGER16", "rw", 1, low=1, high=2),
    # 0x605E fault reaction: 0 disable drive function (what the drive does: 0 torque at once),
    # 1 slow-down ramp, 2 quick-stop ramp
    var(0x605E, "FAULT_OPTION", "Fault reaction option code", "INTEGER16", "rw", 0,
        low=0, high=2),
    var(0x6060, "MODE", "Modes of operation", "INTEGER8", "rw", MODE_CST, pdo=True,
        low=MODE_CST, high=MODE_CST),
    var(0x6061, "MODE_DISPLAY", "Modes of operation display", "INTEGER8", "ro", MODE_CST,
        pdo=True),
    var(0x6064, "POSITION_ACTUAL", "Position actual value", "INTEGER32", "ro", 0, pdo=True),
    var(0x606C, "VELOCITY_ACTUAL", "Velocity actual value", "INTEGER32", "ro", 0, pdo=True),
    # the target torque's limit is the max torque 0x6072 (checked in hil_canopen.c)
    var(0x6071, "TARGET_TORQUE", "Target torque", "INTEGER16", "rw", 0, pdo=True),
    var(0x6072, "MAX_TORQUE", "Max torque", "UNSIGNED16", "rw", MAX_TORQUE),
    var(0x6076, "RATED_TORQUE", "Motor rated torque", "UNSIGNED32", "ro", 100000),
    var(0x6077, "TORQUE_ACTUAL", "Torque actual value", "INTEGER16", "ro", 0, pdo=True),
    Obj(0x608F, "Position encoder resolution", "ARRAY", (
        _n("ENCODER_N", 2),
        Sub(1, "ENCODER_INCREMENTS", "Encoder increments", "UNSIGNED32", "ro",
            ENCODER_INCREMENTS),
        Sub(2, "ENCODER_REVOLUTIONS", "Motor revolutions", "UNSIGNED32", "ro", 1),
    )),
    # 0x6098 homing method: 0, no homing (the joints' encoders are absolute): a master that
    # homes at start-up (ros2_canopen's CiA 402 driver) reads 0 and is done; 0x6502 lists no
    # homing mode, and every other method is refused
    var(0x6098, "HOMING_METHOD", "Homing method", "INTEGER8", "rw", 0, low=0, high=0),
    var(0x6502, "SUPPORTED_MODES", "Supported drive modes", "UNSIGNED32", "ro", 1 << 9),
)


def entries() -> list[tuple[Obj, Sub]]:
    """Every (object, entry), sorted by (index, sub-index): the C table's order."""
    out = [(o, s) for o in OD for s in o.subs]
    out.sort(key=lambda e: (e[0].index, e[1].sub))
    return out


def _check_table() -> None:
    keys: set[str] = set()
    seen: set[tuple[int, int]] = set()
    for o, s in entries():
        assert o.code in OBJECT_CODES and s.dtype in DTYPES and s.access in ACCESS, (o, s)
        assert (o.index, s.sub) not in seen and s.key not in keys, (o, s)
        seen.add((o.index, s.sub))
        keys.add(s.key)
        assert (o.code == "VAR") == (len(o.subs) == 1 and s.sub == 0), o
        if s.dtype == "VISIBLE_STRING":
            assert isinstance(s.default, str) and s.access == "const" and not s.pdo, s
        else:
            assert isinstance(s.default, int), s


def _size(s: Sub) -> int:
    size = DTYPES[s.dtype][1]
    return len(str(s.default)) if size == 0 else size


def _u32(v: int) -> str:
    return f"0x{v & 0xFFFFFFFF:08X}u"


def gen_header() -> str:
    ent = entries()
    lines = [
        "/* GENERATED by tools/gen_canopen_od.py from its table OD: do not edit (regenerate:",
        " * python tools/gen_canopen_od.py; tests/python/unit/test_canopen_od.py checks it). */",
        "/**",
        " * @file hil_canopen_od_table.h",
        " * @brief The object dictionary of the simulated CiA 402 drive: one row per entry",
        " *        (index, sub-index), sorted, and one slot constant per row.",
        " */",
        "#ifndef RRR_HIL_CANOPEN_OD_TABLE_H",
        "#define RRR_HIL_CANOPEN_OD_TABLE_H",
        "",
        "#include <stdint.h>",
        "",
        "/** CiA 301 data types. */",
    ]
    for name, (code, _) in DTYPES.items():
        lines.append(f"#define RRR_CO_T_{name} 0x{code:02X}u")
    lines += [
        "",
        "/** Access of an entry (const: read-only and never changed by the node). */",
        "enum { RRR_CO_RO = 0, RRR_CO_WO = 1, RRR_CO_RW = 2, RRR_CO_CONST = 3 };",
        "",
        f"/** PDO mapping entries per PDO (sub-indices 1..{MAX_MAPPED} of a mapping record). */",
        f"#define RRR_CO_MAX_MAPPED {MAX_MAPPED}u",
        "/** The one mode of operation (0x6060): cyclic synchronous torque. */",
        f"#define RRR_CO_MODE_CST {MODE_CST}",
        "",
        "/** One entry of the dictionary. */",
        "typedef struct rrr_co_od_entry {",
        "    uint16_t index;     ///< object index",
        "    uint8_t subindex;   ///< sub-index",
        "    uint8_t dtype;      ///< RRR_CO_T_*",
        "    uint8_t access;     ///< RRR_CO_RO, _WO, _RW, _CONST",
        "    uint8_t size;       ///< bytes (strings: their length)",
        "    uint8_t pdo;        ///< 1: PDO-mappable",
        "    uint8_t node_id;    ///< 1: the value at reset is def + node id",
        "    uint8_t has_low;    ///< 1: low applies to writes",
        "    uint8_t has_high;   ///< 1: high applies to writes",
        "    int32_t low;        ///< smallest value a write may set (signed types: as signed)",
        "    int32_t high;       ///< largest value a write may set",
        "    uint32_t def;       ///< value at reset (raw bits, before + node id)",
        "    const char *str;    ///< VISIBLE_STRING: the constant text, NULL otherwise",
        "    const char *name;   ///< parameter name (as in the EDS)",
        "} rrr_co_od_entry;",
        "",
        "/** Slots: the row of each entry in rrr_co_od (and in a node's value array). */",
        "enum rrr_co_od_slot {",
    ]
    for i, (o, s) in enumerate(ent):
        lines.append(f"    RRR_CO_OD_{s.key} = {i}, ///< 0x{o.index:04X} sub {s.sub}: {s.name}")
    lines += [
        f"    RRR_CO_OD_COUNT = {len(ent)}",
        "};",
        "",
        "/** The dictionary, sorted by (index, sub-index). */",
        "extern const rrr_co_od_entry rrr_co_od[RRR_CO_OD_COUNT];",
        "",
        "#endif /* RRR_HIL_CANOPEN_OD_TABLE_H */",
        "",
    ]
    return "\n".join(lines)


def _c_int(v: int | None) -> str:
    return "0" if v is None else str(v)


def gen_source() -> str:
    lines = [
        "/* GENERATED by tools/gen_canopen_od.py from its table OD: do not edit (regenerate:",
        " * python tools/gen_canopen_od.py; tests/python/unit/test_canopen_od.py checks it). */",
        '#include "hil_canopen_od_table.h"',
        "",
        "#include <stddef.h>",
        "",
        "const rrr_co_od_entry rrr_co_od[RRR_CO_OD_COUNT] = {",
    ]
    acc = {"ro": "RRR_CO_RO", "wo": "RRR_CO_WO", "rw": "RRR_CO_RW", "const": "RRR_CO_CONST"}
    for o, s in entries():
        if isinstance(s.default, str):
            text = s.default.replace("\\", "\\\\").replace('"', '\\"')
            dv, st = "0u", f'"{text}"'
        else:
            dv, st = _u32(s.default), "NULL"
        lines.append(
            f"    {{0x{o.index:04X}u, {s.sub}u, RRR_CO_T_{s.dtype}, {acc[s.access]}, {_size(s)}u, "
            f"{int(s.pdo)}u, {int(s.node_id)}u, {int(s.low is not None)}u, "
            f"{int(s.high is not None)}u, {_c_int(s.low)}, {_c_int(s.high)}, {dv}, {st}, "
            f'"{s.name}"}}, /* {s.key} */')
    lines += ["};", ""]
    return "\n".join(lines)


def _eds_value(s: Sub) -> str:
    if isinstance(s.default, str):
        return s.default
    if s.key.startswith(("RPDO1_MAP_", "TPDO1_MAP_", "TPDO2_MAP_")) and s.sub >= 1:
        return f"0x{s.default:08X}"  # a mapping entry: index, sub-index, bits
    if s.node_id:
        return f"$NODEID+0x{s.default:X}"
    if s.dtype in SIGNED:
        return str(s.default)
    return f"0x{s.default:X}" if s.default > 9 else str(s.default)


def _eds_entry(section: str, s: Sub) -> list[str]:
    lines = [
        f"[{section}]",
        f"ParameterName={s.name}",
        "ObjectType=0x7",
        f"DataType=0x{DTYPES[s.dtype][0]:04X}",
        f"AccessType={s.access}",
        f"DefaultValue={_eds_value(s)}",
        f"PDOMapping={int(s.pdo)}",
    ]
    if s.low is not None:
        lines.append(f"LowLimit={s.low}")
    if s.high is not None:
        lines.append(f"HighLimit={s.high}")
    return [*lines, ""]


def _default(key: str) -> int:
    value = next(s.default for _, s in entries() if s.key == key)
    assert isinstance(value, int)
    return value


def gen_eds() -> str:
    objs = sorted(OD, key=lambda o: o.index)
    mandatory = [o for o in objs if o.index in (0x1000, 0x1001, 0x1018)]
    manufacturer = [o for o in objs if 0x2000 <= o.index < 0x6000]
    optional = [o for o in objs if o not in mandatory and o not in manufacturer]
    n_rpdo = sum(1 for o in objs if 0x1400 <= o.index < 0x1600)
    n_tpdo = sum(1 for o in objs if 0x1800 <= o.index < 0x1A00)
    lines = [
        "; GENERATED by tools/gen_canopen_od.py from its table OD: do not edit.",
        "; The simulated CiA 402 drive of one axis of the RRR arm (rrr_hil_plant --profile",
        "; canopen): cyclic synchronous torque. docs/canopen.md describes the objects and units.",
        "[FileInfo]",
        "FileName=rrr_cia402.eds",
        "FileVersion=1",
        "FileRevision=0",
        "EDSVersion=4.0",
        "Description=RRR robot-arm toolkit: simulated CiA 402 axis (CST)",
        f"CreationTime={EDS_TIME}",
        f"CreationDate={EDS_CREATED}",
        "CreatedBy=tools/gen_canopen_od.py",
        f"ModificationTime={EDS_TIME}",
        f"ModificationDate={EDS_MODIFIED}",
        "ModifiedBy=tools/gen_canopen_od.py",
        "",
        "[DeviceInfo]",
        "VendorName=RRR robot-arm toolkit",
        "VendorNumber=0x0",
        "ProductName=RRR simulated CiA 402 axis",
        f"ProductNumber=0x{_default('PRODUCT_CODE'):X}",
        f"RevisionNumber=0x{_default('REVISION'):X}",
        "OrderCode=RRR-CIA402-AXIS",
    ]
    for rate in (10, 20, 50, 125, 250, 500, 800, 1000):
        lines.append(f"BaudRate_{rate}=1")
    lines += [
        "SimpleBootUpMaster=0",
        "SimpleBootUpSlave=1",
        "Granularity=8",
        "DynamicChannelsSupported=0",
        "GroupMessaging=0",
        f"NrOfRXPDO={n_rpdo}",
        f"NrOfTXPDO={n_tpdo}",
        "LSS_Supported=0",
        "",
        "[DummyUsage]",
    ]
    for d in range(1, 8):
        lines.append(f"Dummy000{d}=0")
    lines += ["", "[Comments]", "Lines=0", ""]
    for title, group in (("MandatoryObjects", mandatory), ("OptionalObjects", optional),
                         ("ManufacturerObjects", manufacturer)):
        lines += [f"[{title}]", f"SupportedObjects={len(group)}"]
        lines += [f"{i}=0x{o.index:04X}" for i, o in enumerate(group, 1)]
        lines.append("")
    for o in objs:
        if o.code == "VAR":
            lines += _eds_entry(f"{o.index:04X}", o.subs[0])
            continue
        lines += [f"[{o.index:04X}]", f"ParameterName={o.name}",
                  f"ObjectType=0x{OBJECT_CODES[o.code]:X}", f"SubNumber={len(o.subs)}", ""]
        for s in o.subs:
            lines += _eds_entry(f"{o.index:04X}sub{s.sub:X}", s)
    return "\n".join(lines)


def outputs() -> dict[Path, str]:
    _check_table()
    return {
        C_DIR / "hil_canopen_od_table.h": gen_header(),
        C_DIR / "hil_canopen_od_table.c": gen_source(),
        EDS_PATH: gen_eds(),
    }


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="compare with the committed files, write nothing")
    args = ap.parse_args(argv)
    stale = []
    for path, text in outputs().items():
        rel = path.relative_to(ROOT)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(str(rel))
        else:
            _write_atomic(path, text)
            print(f"wrote {rel}")
    if stale:
        print("not what tools/gen_canopen_od.py generates (run it): " + ", ".join(stale),
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
