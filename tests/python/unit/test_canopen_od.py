"""The CANopen object dictionary of the simulated CiA 402 drive (docs/canopen.md): the committed
C table and EDS are what tools/gen_canopen_od.py generates, the EDS ships with the installed
package, and the unmodified ``canopen`` package's EDS parser reads every entry of the table with
its data type, access, default (node id substituted), PDO mapping flag and limits."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import canopen
import pytest
from canopen.objectdictionary import ODArray, ODRecord, ODVariable
from rrr_robot.core._package import DATA_DIR
from support import REPO

GEN = REPO / "tools" / "gen_canopen_od.py"
EDS = REPO / "python" / "rrr_robot" / "data" / "rrr_cia402.eds"


def _gen() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gen_canopen_od", GEN)
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    sys.modules["gen_canopen_od"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_regenerating_gives_the_committed_files() -> None:
    result = subprocess.run([sys.executable, str(GEN), "--check"], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_check_notices_a_stale_file(tmp_path: Path) -> None:
    gen = _gen()
    fresh = gen.outputs()
    assert set(fresh) == {gen.C_DIR / "hil_canopen_od_table.h",
                          gen.C_DIR / "hil_canopen_od_table.c", gen.EDS_PATH}
    # one changed default in the table changes the C table and the EDS (the header holds the
    # layout only)
    table = gen.OD
    try:
        gen.OD = tuple(
            gen.var(o.index, "HB_PRODUCER", o.name, "UNSIGNED16", "rw", 250)
            if o.index == 0x1017 else o for o in table)
        changed = gen.outputs()
    finally:
        gen.OD = table
    h, c = gen.C_DIR / "hil_canopen_od_table.h", gen.C_DIR / "hil_canopen_od_table.c"
    assert changed[h] == fresh[h]
    assert changed[c] != fresh[c] and changed[gen.EDS_PATH] != fresh[gen.EDS_PATH]
    assert "0x000000FAu" in changed[c] and "DefaultValue=0xFA" in changed[gen.EDS_PATH]


def test_the_installed_package_ships_the_eds() -> None:
    assert (DATA_DIR / "rrr_cia402.eds").read_text() == EDS.read_text()


@pytest.mark.parametrize("node_id", [1, 3])
def test_canopen_parses_every_entry_of_the_table(node_id: int) -> None:
    gen = _gen()
    od = canopen.objectdictionary.import_od(str(EDS), node_id=node_id)
    assert sorted(od.indices) == sorted(o.index for o in gen.OD)
    types = {name: code for name, (code, _) in gen.DTYPES.items()}
    n_entries = 0
    for obj in gen.OD:
        item = od[obj.index]
        assert item.name == obj.name
        kind = {"VAR": ODVariable, "ARRAY": ODArray, "RECORD": ODRecord}[obj.code]
        assert isinstance(item, kind), (hex(obj.index), type(item))
        for s in obj.subs:
            var = item if obj.code == "VAR" else item[s.sub]
            assert isinstance(var, ODVariable)
            where = f"0x{obj.index:04X} sub {s.sub}"
            assert (var.index, var.subindex) == (obj.index, s.sub), where
            assert var.data_type == types[s.dtype], where
            assert var.access_type == s.access, where
            assert var.pdo_mappable == s.pdo, where
            assert var.min == s.low and var.max == s.high, where
            if s.dtype == "VISIBLE_STRING":
                assert var.default == s.default, where
            else:
                assert var.default == s.default + (node_id if s.node_id else 0), where
            n_entries += 1
    assert n_entries == len(gen.entries())


def test_the_objects_of_the_profile() -> None:
    """What a CiA 402 master expects in the file: device type 402, CST, the PDO mapping."""
    od = canopen.objectdictionary.import_od(str(EDS), node_id=2)
    assert od[0x1000].default & 0xFFFF == 402
    assert od[0x6060].default == 10 and od[0x6502].default == 1 << 9
    assert od[0x1400][1].default == 0x202 and od[0x1800][1].default == 0x182
    assert od[0x1801][1].default == 0x282 and od[0x1014].default == 0x82
    rpdo = [od[0x1600][i].default for i in range(1, od[0x1600][0].default + 1)]
    tpdo1 = [od[0x1A00][i].default for i in range(1, od[0x1A00][0].default + 1)]
    tpdo2 = [od[0x1A01][i].default for i in range(1, od[0x1A01][0].default + 1)]
    assert rpdo == [0x60400010, 0x60710010]
    assert tpdo1 == [0x60410010, 0x60640020, 0x60610008]  # with the mode display (ros2_canopen)
    assert tpdo2 == [0x606C0020, 0x60770010]
    for mapping in (rpdo, tpdo1, tpdo2):  # each fits a classical CAN frame, mappable objects
        assert sum(m & 0xFF for m in mapping) <= 64
        for m in mapping:
            var = od[m >> 16]
            assert isinstance(var, ODVariable) and var.pdo_mappable
            assert len(var.encode_raw(0)) * 8 == m & 0xFF
    assert od[0x1800][2].default == 1 and od[0x1801][2].default == 1  # every SYNC
    assert od[0x608F][1].default == 1 << 20 and od[0x608F][2].default == 1
    # the target torque's range is the max torque 0x6072 (per mille, rw; the node checks it),
    # and the quick stop option code 0x605A (rw) stays in QUICK STOP ACTIVE by default
    assert od[0x6071].min is None and od[0x6071].max is None
    assert od[0x6072].default == 1000 and od[0x6072].access_type == "rw"
    assert od[0x605A].default == 6 and od[0x605A].access_type == "rw"
    assert od[0x605A].data_type == canopen.objectdictionary.INTEGER16


def test_what_field_masters_read() -> None:
    """The objects a CiA 402 master in the field reads (ros2_canopen's driver, its fake slave):
    the homing method 0x6098 = 0 (no homing, nothing else accepted), the option codes
    0x605A..0x605E with the limits of what the drive does, the torque actual value 0x6077
    mappable, and the SDO server's COB-IDs 0x1200."""
    od = canopen.objectdictionary.import_od(str(EDS), node_id=3)
    assert od[0x6098].default == 0 and (od[0x6098].min, od[0x6098].max) == (0, 0)
    assert od[0x6098].data_type == canopen.objectdictionary.INTEGER8
    codes = {0x605B: (0, 0, 1), 0x605C: (1, 0, 1), 0x605D: (1, 1, 2), 0x605E: (0, 0, 2)}
    for index, (default, low, high) in codes.items():
        var = od[index]
        assert (var.default, var.min, var.max, var.access_type) == (default, low, high, "rw")
        assert var.data_type == canopen.objectdictionary.INTEGER16
    assert od[0x6077].pdo_mappable and od[0x6061].pdo_mappable
    assert od[0x1200][1].default == 0x603 and od[0x1200][2].default == 0x583
    assert od[0x6502].default & (1 << 5) == 0  # no homing mode (6): a master skips homing


def test_an_independent_eds_checker_finds_nothing(tmp_path: Path) -> None:
    """eds-utils (an EDS/DCF editor of its own, not the parser the other tests use) reads the
    EDS without an error or an auto-fix: every section and entry CiA 306 has it look for, the
    object lists, each mapping entry's format and size against the object it maps."""
    from eds_utils.core.file_io.read_eds import read_eds

    eds, errors = read_eds(str(EDS))
    assert errors == []
    assert sorted(eds.indexes) == sorted(o.index for o in _gen().OD)
    proc = subprocess.run([sys.executable, "-c", "from eds_utils.eds_validate import "
                           "eds_validate; eds_validate()", str(EDS)], capture_output=True,
                          text=True, timeout=60)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, "", "")
    # and it does find a broken file: a mapping entry of the wrong size
    broken = EDS.read_text().replace("DefaultValue=0x60610008", "DefaultValue=0x60610010")
    assert broken != EDS.read_text()
    path = tmp_path / "broken.eds"
    path.write_text(broken)
    _, errors = read_eds(str(path))
    assert any("wrong mapped object size" in e for e in errors), errors


def test_the_canopen_schedule_is_read_from_the_eds() -> None:
    from rrr_robot.hil.canopen.drives import canopen_schedule

    frames = canopen_schedule()
    per_ms = [(f.frame_id, f.length) for f in frames if f.cycle_time == 1.0]
    assert sorted(per_ms) == sorted([(0x080, 0)] + [(0x200 + i, 4) for i in (1, 2, 3)] +
                                    [(0x180 + i, 7) for i in (1, 2, 3)] +
                                    [(0x280 + i, 6) for i in (1, 2, 3)])
    heartbeats = [(f.frame_id, f.length, f.cycle_time) for f in frames if f.cycle_time != 1.0]
    assert sorted(heartbeats) == [(0x701, 1, 100.0), (0x702, 1, 100.0), (0x703, 1, 100.0),
                                  (0x77F, 1, 100.0)]
    assert all(f.cycle_time == 2.0 for f in canopen_schedule(2.0) if f.frame_id < 0x700)


def test_canopen_bus_load(capsys: pytest.CaptureFixture[str]) -> None:
    from rrr_robot.cli import main
    from rrr_robot.hil.busload import classical_bits
    from rrr_robot.hil.canopen.drives import canopen_load

    # worst-case stuffing, classical CAN: per ms a SYNC, three 4-byte RPDOs, three 7-byte TPDO1
    # and three 6-byte TPDO2, plus four 1-byte heartbeats every 100 ms
    bits_per_ms = (classical_bits(0) + 3 * classical_bits(4) + 3 * classical_bits(7) +
                   3 * classical_bits(6) + 4 * classical_bits(1) / 100)
    assert bits_per_ms == 1062.6
    load = canopen_load(1_000_000)
    assert load.worst_percent == pytest.approx(bits_per_ms / 10, rel=1e-12)  # over 1 Mbit/s
    assert canopen_load(1_000_000, 5_000_000).worst_percent < 70  # CAN FD at 5 Mbit/s fits
    assert main(["hil", "busload", "--profile", "canopen", "--bitrate", "1000000"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("schedule of rrr_cia402.eds, three CiA 402 drives, SYNC every 1 ms")
    assert out[-1] == "worst-case bus load: 106.26 %"
    assert main(["hil", "busload", "--profile", "canopen", "--sync-period-ms", "2"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "SYNC every 2 ms" in out[0] and out[-1] == "worst-case bus load: 53.26 %"
    assert main(["hil", "busload", "--sync-period-ms", "2"]) == 2  # the DBC profile
    assert "--sync-period-ms applies to --profile canopen only" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["hil", "busload", "--profile", "canopen", "--sync-period-ms", "0"])
    assert exc.value.code == 2
    assert main(["hil", "busload", "--profile", "canopen", "--dbc", "x.dbc"]) == 2
    assert "--dbc and --lockstep do not apply" in capsys.readouterr().err
