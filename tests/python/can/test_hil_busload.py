"""Bus load of the bench's schedule (rrr_robot.hil.busload): frame lengths against hand-counted
values, the CRC-15 and the exact stuffing of real frames, the DBC's real-time schedule within
70 % of a 1 Mbit/s classical CAN bus, and ``rrr hil busload``'s report.

Hand counts (ISO 11898-1 field widths, intermission included): a standard data frame is
SOF 1 + identifier 11 + RTR 1 + IDE 1 + r0 1 + DLC 4 + 8 n + CRC 15 + delimiter 1 + ACK 2 +
EOF 7 + IFS 3 = 47 + 8 n bits; stuffing covers the 34 + 8 n bits from SOF to the CRC and adds at
most floor((34 + 8 n - 1) / 4): 8 bytes 111 and 135 bits, 0 bytes 47 and 55; extended 8 bytes
131 and 160.
"""

from __future__ import annotations

import importlib
import random
import subprocess
import sys

import pytest
from rrr_robot.errors import BadInputError
from rrr_robot.hil import PROFILES
from rrr_robot.hil import busload as bl
from rrr_robot.hil.dbc.protocol import database


@pytest.mark.parametrize(("n", "extended", "worst", "plain"), [
    (8, False, 135, 111), (0, False, 55, 47), (2, False, 75, 63), (4, False, 95, 79),
    (8, True, 160, 131), (0, True, 80, 67),
])
def test_classical_frame_lengths(n: int, extended: bool, worst: int, plain: int) -> None:
    assert bl.classical_bits(n, extended=extended) == worst
    assert bl.classical_bits(n, extended=extended, stuffing=False) == plain


def test_fd_frame_lengths() -> None:
    # 8 bytes, CRC-17: nominal SOF..BRS 17 + ACK/EOF/IFS 12 = 29; data ESI 1 + DLC 4 + 64 +
    # stuff count 4 + CRC 17 + 6 fixed stuff bits + delimiter 1 = 97; dynamic stuff bits over
    # the 86 bits SOF..data at most 21, 4 of them in the 17 arbitration bits
    assert bl.fd_bits(8, stuffing=False) == (29, 97)
    assert bl.fd_bits(8) == (33, 114)
    # 64 bytes, CRC-21 with 7 fixed stuff bits: data 1 + 4 + 512 + 4 + 21 + 7 + 1 = 550
    assert bl.fd_bits(64, stuffing=False) == (29, 550)
    with pytest.raises(BadInputError, match="CAN FD"):
        bl.fd_bits(9)
    with pytest.raises(BadInputError, match="classical"):
        bl.classical_bits(9)


def test_crc15_check_value() -> None:
    bits = [int(b) for ch in b"123456789" for b in format(ch, "08b")]
    assert bl.can_crc15(bits) == 0x059E  # CRC-15/CAN's catalogued check value


def test_exact_stuffing_lies_between_no_stuffing_and_the_worst_case() -> None:
    rng = random.Random(7)
    for _ in range(300):
        n = rng.randint(0, 8)
        ext = rng.random() < 0.3
        can_id = rng.getrandbits(29 if ext else 11)
        data = bytes(rng.getrandbits(8) for _ in range(n))
        bits = bl.stuffed_length(can_id, data, extended=ext)
        assert bl.classical_bits(n, extended=ext, stuffing=False) <= bits
        assert bits <= bl.classical_bits(n, extended=ext)
    # identifier 0 and zero data: runs of five zeros get stuffed all along the frame
    zeros = bl.stuffed_length(0, bytes(8))
    assert zeros > bl.classical_bits(8, stuffing=False) + 10


def test_real_time_schedule_fits_70_percent_of_1_mbit() -> None:
    load = bl.schedule_load(database(), 1_000_000)
    names = {f.name for f in load.frames}
    assert "Sync" not in names and "StopCmd" not in names
    assert {"VoltageCmd", "JointState1", "JointState2", "JointState3", "PlantStatus"} <= names
    # 5 frames of 8 bytes every 1 ms (5 x 135 bits) + two 2-byte heartbeats every 100 ms
    assert load.worst_percent == pytest.approx(100 * (5 * 135 + 2 * 75 / 100) / 1000)
    assert load.worst_percent <= 70.0
    assert load.nominal_percent == pytest.approx(100 * (5 * 111 + 2 * 63 / 100) / 1000)
    lockstep = bl.schedule_load(database(), 1_000_000, lockstep=True)
    assert lockstep.worst_percent == pytest.approx(load.worst_percent + 100 * 95 / 1000)
    # CAN FD at 1/5 Mbit/s: 8-byte frames (33, 114) bits; 2-byte heartbeats 33 nominal bits and
    # 1 + 4 + 16 + 4 + 17 + 6 + 1 = 49 data bits + (38 - 1) // 4 - 4 = 5 dynamic stuff bits
    assert bl.fd_bits(2) == (33, 54)
    fd = bl.schedule_load(database(), 1_000_000, 5_000_000)
    assert fd.worst_percent == pytest.approx(100 * 5 * (33 / 1e6 + 114 / 5e6) * 1000
                                             + 100 * 2 * (33 / 1e6 + 54 / 5e6) * 10, rel=1e-9)
    with pytest.raises(BadInputError, match="--bitrate"):
        bl.schedule_load(database(), 0)
    with pytest.raises(BadInputError, match="--fd"):
        bl.schedule_load(database(), 1_000_000, 500_000)


def test_busload_command_ends_with_the_worst_case_load() -> None:
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload", "--bitrate",
                           "1000000"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    assert last.startswith("worst-case bus load: ") and last.endswith(" %")
    assert float(last.split()[-2]) <= 70.0
    fd = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload", "--fd",
                         "5000000"], capture_output=True, text=True, timeout=60)
    assert fd.returncode == 0 and "CAN FD" in fd.stdout
    assert float(fd.stdout.strip().splitlines()[-1].split()[-2]) < 40.0


def test_measured_fd_load_counts_frames_bytes_and_bits() -> None:
    """Frames and data bytes per period of a frame list, and its time on a CAN FD bus from
    fd_bits: two periods with an 8-byte and a 2-byte standard frame each, and one 8-byte
    extended frame."""
    frames = [(0x100, bytes(8), False), (0x080, bytes(2), False)] * 2 + [(0x1234, bytes(8), True)]
    m = bl.measured_fd_load(frames, 2, 1_000_000, 4_000_000)
    assert m["frames_per_period"] == 2.5 and m["bytes_per_period"] == (2 * 10 + 8) / 2
    for key, stuffing in (("load_worst_percent", True), ("load_no_stuffing_percent", False)):
        s = 0.0
        for n, ext, count in ((8, False, 2), (2, False, 2), (8, True, 1)):
            nom, dat = bl.fd_bits(n, extended=ext, stuffing=stuffing)
            s += count * (nom / 1e6 + dat / 4e6)
        assert m[key] == pytest.approx(100.0 * s / 2e-3, rel=1e-12)
    assert m["load_worst_percent"] > m["load_no_stuffing_percent"]
    # 8 bytes standard at 1/5 Mbit/s: (33 + 114 / 5) us worst, (29 + 97 / 5) us without stuffing
    one = bl.measured_fd_load([(0x100, bytes(8), False)], 1)
    assert one["load_worst_percent"] == pytest.approx(100 * (33 + 114 / 5) * 1e-6 / 1e-3)
    assert one["load_no_stuffing_percent"] == pytest.approx(100 * (29 + 97 / 5) * 1e-6 / 1e-3)
    with pytest.raises(BadInputError, match="periods"):
        bl.measured_fd_load(frames, 0)
    with pytest.raises(BadInputError, match="--fd"):
        bl.measured_fd_load(frames, 1, 1_000_000, 500_000)
    with pytest.raises(BadInputError, match="CAN FD frame"):
        bl.measured_fd_load([(0x100, bytes(9), False)], 1)


def test_each_registered_profile_is_a_package_of_hil() -> None:
    """rrr_robot.hil.PROFILES (``rrr hil busload --profile`` offers them): each row names the
    package of its profile, beside the others."""
    assert {"dbc", "canopen"} <= set(PROFILES)
    for name, module in PROFILES.items():
        assert module == f"rrr_robot.hil.{name}", module
        assert hasattr(importlib.import_module(module), "__path__"), module
    got = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload", "--profile",
                          "nope"], capture_output=True, text=True, timeout=120)
    assert got.returncode == 2 and all(name in got.stderr for name in PROFILES), got.stderr


def test_each_load_of_a_run_is_named_and_printed_by_its_meaning() -> None:
    """bus_loads: the measured load of a frame list (exact stuffing), the worst case of the
    run's schedule and of the real-time one, each under its own name; format_loads says which
    is which (a lockstep run's rate is the hypothetical one of a 1 ms period); the real-time
    schedule's worst case is what rrr hil busload's last line prints."""
    rt = bl.schedule_load(database(), 1_000_000)
    lockstep = bl.schedule_load(database(), 1_000_000, lockstep=True)
    frames = [(0x100, bytes(range(8)), False), (0x080, bytes(4), False)] * 3
    load = bl.bus_loads(frames, 3, lockstep, rt)
    assert load["measured_percent"] == bl.measured_load(frames, 3)["load_percent"]
    assert load["schedule_worst_case_percent"] == lockstep.worst_percent
    assert load["schedule_no_stuffing_percent"] == lockstep.nominal_percent
    assert load["realtime_schedule_worst_case_percent"] == rt.worst_percent
    assert load["schedule"] == "lockstep (Sync included)"
    text = bl.format_loads(load)
    assert f"measured {load['measured_percent']:.2f} % (this run's frames" in text
    assert f"lockstep schedule {lockstep.worst_percent:.2f} % (Sync included)" in text
    assert f"real-time schedule {rt.worst_percent:.2f} % (rrr hil busload)" in text
    assert "as if run at that rate" in text and "frames/s" not in text
    alone = bl.format_loads(bl.bus_loads(frames, 3, rt, rt))
    assert "as if" not in alone and "lockstep" not in alone
    assert f"real-time schedule {rt.worst_percent:.2f} %" in alone
    fd_schedule = bl.schedule_load(database(), 1_000_000, bl.FD_DATA_BITRATE, lockstep=True)
    fd = bl.fd_bus_loads(frames, 3, fd_schedule)
    measured = bl.measured_fd_load(frames, 3)
    assert fd["measured_worst_case_percent"] == measured["load_worst_percent"]
    assert fd["measured_no_stuffing_percent"] == measured["load_no_stuffing_percent"]
    assert fd["schedule_worst_case_percent"] == fd_schedule.worst_percent
    assert f"CAN FD 1 Mbit/s + 5 Mbit/s: measured {fd['measured_worst_case_percent']:.2f} %" \
        in bl.format_loads(load, fd)
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload"],
                          capture_output=True, text=True, timeout=60)
    assert proc.stdout.strip().splitlines()[-1] == f"worst-case bus load: {rt.worst_percent:.2f} %"
    assert " frames/s; " in proc.stdout and "if run at 1 kHz" not in proc.stdout
    locked = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload", "--lockstep"],
                            capture_output=True, text=True, timeout=60)
    assert "6020 frames/s if run at 1 kHz" in locked.stdout
