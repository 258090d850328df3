"""Processor in the loop (``rrr hil pil``, docs/microcontroller.md): the controller firmware of
c_src/firmware, built here with the GNU Arm toolchain and run in qemu-system-arm.

- the Cortex-M7 image (double) against the C plant node gives the bench's closed loop: the same
  frames as ``rrr hil bench``, voltages equal to the Linux controller node's but for the last
  bits of libm's sin, cos and exp (picolibc's against glibc's), the same tip error; its summary
  states flash, RAM, stack and instructions per period;
- the Cortex-M4F image (float) stays within the stated bound of the double law on the same
  frames, and its tip error within 1 % of the double controller's;
- the firmware's safety policy is the controller node's (a fake plant on its SLCAN line):
  tampered input ends the run with status 8, a plant reporting a fault with status 7, a silent
  plant with status 3, each after StopCmd; a damaged run block is refused.

The images are built (incrementally) into $RRR_PIL_FIRMWARE_DIR or build-firmware of the
clone; the toolchain (gcc-arm-none-eabi, picolibc-arm-none-eabi) and qemu-system-arm must be
installed (scripts/test_pil.sh installs them when missing and root). Nothing here measures the
machine's speed: instruction counts come from QEMU's virtual clock, and only structural bounds
are asserted.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rrr_robot.hil.dbc.protocol import decode, encode, frame_id
from rrr_robot.hil.pil.firmware import M4F, M7, elf_sizes, write_run_block
from rrr_robot.hil.pil.loop import open_slcan, start_firmware
from support import REPO

RRR = str(Path(sys.executable).with_name("rrr"))
#: The double firmware's voltages against the Linux node's on the same frames, V (the libms'
#: last bits: docs/microcontroller.md).
DOUBLE_BOUND_V = 1e-12
#: The stated bound of the float law against the double law on the same frames, V
#: (docs/microcontroller.md; test_pil_law_float checks the same over random states).
FLOAT_BOUND_V = 1e-4


@pytest.fixture(scope="module")
def firmware() -> Path:
    """The firmware's build folder, built now (a no-op when it is current)."""
    missing = [t for t in ("arm-none-eabi-gcc", "qemu-system-arm") if shutil.which(t) is None]
    assert not missing, (f"{missing} not on PATH: apt-get install gcc-arm-none-eabi "
                         "picolibc-arm-none-eabi qemu-system-arm (scripts/test_pil.sh)")
    folder = Path(os.environ.get("RRR_PIL_FIRMWARE_DIR") or REPO / "build-firmware")
    if not (folder / "CMakeCache.txt").exists():
        subprocess.run(["cmake", "-S", str(REPO / "c_src/firmware"), "-B", str(folder),
                        "-DRRR_WERROR=ON"], check=True, capture_output=True)
    build = subprocess.run(["cmake", "--build", str(folder), "-j2"], capture_output=True,
                           text=True)
    assert build.returncode == 0, build.stdout + build.stderr
    return folder


def _rrr(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([RRR, *args], cwd=cwd, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def runs(firmware: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``rrr hil bench``, ``rrr hil pil`` and ``rrr hil pil --float``, 2 s each, into a folder
    with a space in its path."""
    base = tmp_path_factory.mktemp("pil") / "with space"
    base.mkdir()
    out = {}
    for name, extra in (("bench", ["bench"]), ("m7", ["pil", "--firmware", str(firmware)]),
                        ("m4f", ["pil", "--float", "--firmware", str(firmware)])):
        r = _rrr("hil", *extra, "--duration", "2", "--out", str(base / name), "-q", cwd=base)
        assert r.returncode == 0, r.stdout + r.stderr
        (base / name / "stdout.txt").write_text(r.stdout, encoding="utf-8")
        out[name] = base / name
    return out


def _summary(folder: Path) -> dict[str, Any]:
    return json.loads((folder / "summary.json").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def _log(folder: Path, name: str) -> np.ndarray:
    return np.loadtxt(folder / name, delimiter=",", skiprows=1, ndmin=2)


def test_double_firmware_is_the_bench(runs: dict[str, Path]) -> None:
    """The Cortex-M7 firmware closes the bench's loop: its tip error is the bench's (within
    1 %, the acceptance; in fact equal), because it sees the same frames: a voltage that differs
    in its last bits quantises to the same 1 mV of VoltageCmd."""
    bench, pil = _summary(runs["bench"]), _summary(runs["m7"])
    assert pil["side"] == "pil" and pil["reference"]["periods"] == 2001
    e_bench, e_pil = bench["bench"]["tip_error_max"], pil["bench"]["tip_error_max"]
    assert abs(e_pil - e_bench) <= 0.01 * e_bench
    assert pil["controller"]["exit"] == 0 and pil["plant_exit"] == 0
    assert pil["controller"]["states"] == 2001 and pil["controller"]["rx_bad_crc"] == 0
    a, b = _log(runs["m7"], "controller.csv"), _log(runs["bench"], "controller.csv")
    assert a.shape == b.shape == (2001, 18)
    assert np.array_equal(a[:, :8], b[:, :8])  # k, t and the measured q, qd: the same frames
    assert np.array_equal(_log(runs["m7"], "plant.csv"), _log(runs["bench"], "plant.csv"))


def test_double_firmware_voltages_equal_the_linux_controller(runs: dict[str, Path]) -> None:
    """On the same frames the firmware's voltages are the Linux node's: the PD part u_c (no
    libm) bit for bit; u and the feedforward u_n within DOUBLE_BOUND_V. The arithmetic is the
    same source compiled for both, but the libm is not (the firmware's is picolibc's, the
    node's glibc's): their sin, cos and exp may differ in the last bit, and the feedforward's
    terms of a few volts carry that into u_n as a few 1e-16 V."""
    a, b = _log(runs["m7"], "controller.csv"), _log(runs["bench"], "controller.csv")
    u_c = [10, 13, 16]
    assert np.array_equal(a[:, u_c], b[:, u_c])
    for col in (8, 9, 11, 12, 14, 15):  # u, u_n of each joint
        assert np.abs(a[:, col] - b[:, col]).max() <= DOUBLE_BOUND_V
    assert np.abs(b[:, [8, 11, 14]]).max() > 1.0


def test_summary_states_the_target(runs: dict[str, Path], firmware: Path) -> None:
    """flash, RAM, stack and instructions per period, with how they were counted; structural
    bounds only (the counts are deterministic, but no number of a machine is asserted)."""
    for name, target in (("m7", M7), ("m4f", M4F)):
        t = _summary(runs[name])["target"]
        assert t["image"] == target.image and t["law_arithmetic"] == target.law
        assert 1000 < t["flash_bytes"] < 1024 * 1024  # the linker script's image region
        assert t["ram_bytes"] <= 256 * 1024 and t["sections_bytes"]["stack_reserved"] > 0
        assert 0 < t["stack_used_bytes"] < t["sections_bytes"]["stack_reserved"]
        law, period = t["instructions_per_period"]["law"], t["instructions_per_period"]["period"]
        assert 100 < law["median"] <= law["max"] < period["max"] < 1e6
        assert "not cycles" in t["instruction_count"]
        share = t["share_of_1ms_period"]
        assert "optimistic bound" in share["assumption"]
        assert share["law_max"] == pytest.approx(law["max"] / (share["clock_hz"] * 1e-3))
        counts = _log(runs[name], "instructions.csv")
        assert counts.shape == (2001, 3) and np.all(counts[:, 1] > 0)
        printed = (runs[name] / "stdout.txt").read_text(encoding="utf-8")
        assert "instructions, not cycles" in printed and "optimistic bound" in printed
    sizes = elf_sizes(firmware / M7.image)
    assert sizes.flash == _summary(runs["m7"])["target"]["flash_bytes"]


def test_elf_sizes_agree_with_the_toolchain(firmware: Path) -> None:
    """The ELF reader's sums against arm-none-eabi-size's sections (System V format)."""
    size = shutil.which("arm-none-eabi-size")
    assert size is not None
    for target in (M7, M4F):
        out = subprocess.run([size, "-A", str(firmware / target.image)], capture_output=True,
                             text=True, check=True).stdout
        sections = {f[0]: int(f[1]) for f in (line.split() for line in out.splitlines())
                    if len(f) == 3 and f[0].startswith(".")}
        s = elf_sizes(firmware / target.image)
        assert s.text == sections[".text"]
        assert s.data == sections[".data"] + sections.get(".tdata", 0)
        assert s.stack == sections[".stack"] == 16384
        assert s.bss == sections[".bss"] + sections.get(".tbss_space", 0)


def test_float_firmware_within_its_bound(runs: dict[str, Path]) -> None:
    """The Cortex-M4F's float law: within FLOAT_BOUND_V of librrr's double law on the same
    frames, and a tip error within 1 % of the double controller's; both printed."""
    s, double = _summary(runs["m4f"]), _summary(runs["m7"])
    d = s["difference_to_double_law"]
    assert d["periods"] == 2001
    assert 0.0 < max(d["u_max_abs"]) <= FLOAT_BOUND_V
    e, e_double = s["bench"]["tip_error_max"], double["bench"]["tip_error_max"]
    assert abs(e - e_double) <= 0.01 * e_double
    printed = (runs["m4f"] / "stdout.txt").read_text(encoding="utf-8")
    assert "float law against librrr's double law on the same frames: max |du|" in printed
    assert "Cortex-M4F" in printed


def test_refused_before_anything_runs(tmp_path: Path, firmware: Path) -> None:
    """No firmware, a reference longer than the run block holds, no QEMU: clear errors."""
    r = _rrr("hil", "pil", "--firmware", str(tmp_path / "none"), "--out", str(tmp_path / "o"),
             cwd=tmp_path)
    assert r.returncode != 0 and "no firmware" in r.stderr and "cmake -S c_src/firmware" in r.stderr
    r = _rrr("hil", "pil", "--firmware", str(firmware), "--duration", "60",
             "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert r.returncode != 0 and "run block holds" in r.stderr
    env = {**os.environ, "PATH": str(Path(sys.executable).parent)}
    r = subprocess.run([RRR, "hil", "pil", "--firmware", str(firmware), "--duration", "0.01",
                        "--out", str(tmp_path / "o")], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "qemu-system-arm, which is not on PATH" in r.stderr
    assert not (tmp_path / "o" / "summary.json").exists()


# ---- the firmware against a fake plant on its SLCAN line ------------------------------------

class FakePlant:
    """The firmware in QEMU with a short run block, its SLCAN line in this process."""

    def __init__(self, firmware: Path, work: Path, periods: int = 5, timeout_ms: int = 5000,
                 damage: bool = False) -> None:
        t = np.arange(periods) * 1e-3
        q = np.tile([0.1, 0.5, -1.0], (periods, 1))
        z = np.zeros_like(q)
        block = work / "run_block.bin"
        write_run_block(block, t, q, z, z, {f"{g}[{i}]": 1.0 for g in ("kp", "kd")
                                            for i in (1, 2, 3)}, timeout_ms=timeout_ms)
        if damage:
            raw = bytearray(block.read_bytes())
            raw[200] ^= 0xFF
            block.write_bytes(bytes(raw))
        self.node, port = start_firmware(M7, firmware / M7.image, block,
                                         work / "controller.csv", work / "instructions.csv")
        self.bus = None if damage else open_slcan(port, self.node)

    def state(self, k: int, *, crc_bad: bool = False) -> None:
        for j in (1, 2, 3):
            self.bus.send(encode(f"JointState{j}", {"AliveCounter": k & 15, "Q": 0.1,
                                                     "Qd": 0.0}, corrupt_crc=crc_bad))

    def status(self, k: int, faults: int = 0) -> None:
        self.bus.send(encode("PlantStatus", {"AliveCounter": k & 15, "State": 1 + (faults > 0),
                                             "Faults": faults, "ZeroVoltage": 0,
                                             "FaultCount": 0, "CmdMissed": 0}))

    def expect(self, *names: str, timeout: float = 10.0) -> list[dict[str, float]]:
        """The next frames of these messages (others are skipped), their signals."""
        got = []
        deadline = time.monotonic() + timeout
        for name in names:
            while True:
                msg = self.bus.recv(max(0.0, deadline - time.monotonic()))
                assert msg is not None, f"no {name} from the firmware"
                if msg.arbitration_id == frame_id(name):
                    got.append(decode(msg)[1])
                    break
        return got

    def end(self) -> dict[str, Any]:
        """Close the channel; the firmware's summary (its exit status in 'exit')."""
        import can

        if self.bus is not None:
            with contextlib.suppress(can.CanError):  # the firmware may have ended already
                self.bus.close()  # python-can's slcan: "C"
        summary = self.node.wait(30.0)
        if self.bus is not None:
            with contextlib.suppress(can.CanError):
                self.bus.shutdown()
        return summary


@pytest.fixture
def plant(firmware: Path, tmp_path: Path) -> Iterator[Any]:
    made: list[FakePlant] = []

    def make(**kw: Any) -> FakePlant:
        made.append(FakePlant(firmware, tmp_path, **kw))
        return made[-1]

    yield make
    for p in made:
        p.node.close()


def test_firmware_ends_a_tampered_run(plant: Any) -> None:
    """A second JointState of a joint in one period ends the run at once (status 8, as the
    controller node), after StopCmd; a frame with a bad CRC is ignored and counted."""
    p = plant()
    p.expect("HeartbeatCtrl")
    p.state(0, crc_bad=True)
    p.state(0)
    p.expect("VoltageCmd", "Sync")
    p.state(1)
    p.bus.send(encode("JointState2", {"AliveCounter": 1, "Q": 0.1, "Qd": 0.0}))
    stop, = p.expect("StopCmd")
    assert stop["AliveCounter"] == 2  # the command sequence's next
    s = p.end()
    assert s["exit"] == 8 and s["repeated"] == 1 and s["rx_bad_crc"] == 3
    assert "two JointState2 with alive counter 1" in s["tampered"]
    assert "tampered input" in p.node.stdout


def test_firmware_reports_the_plants_safety_policy(plant: Any) -> None:
    """A completed run in which a PlantStatus reported a latched fault: status 7; StopCmd
    'end of run' after the last period."""
    p = plant(periods=3)
    p.expect("HeartbeatCtrl")
    for k in range(3):
        p.state(k)
        p.status(k, faults=1 if k == 1 else 0)
        p.expect("VoltageCmd")
    stop, = p.expect("StopCmd")
    assert stop["Reason"] == 0 and stop["AliveCounter"] == 3
    s = p.end()
    assert s["exit"] == 7 and s["plant_status_faulty"] == 1 and s["states"] == 3
    assert "safety policy fired" in p.node.stdout


def test_firmware_loses_a_silent_plant(plant: Any) -> None:
    """No joint state within the run block's timeout: status 3, StopCmd 'plant lost'."""
    p = plant(timeout_ms=300)
    p.expect("HeartbeatCtrl")
    stop, = p.expect("StopCmd")
    assert stop["Reason"] == 3
    assert p.end()["exit"] == 3
    assert "no joint state within 300 ms" in p.node.stdout


def test_firmware_refuses_a_damaged_run_block(plant: Any) -> None:
    """A run block with a changed byte: the firmware says so and ends with status 2."""
    p = plant(damage=True)
    s = p.end()
    assert s["exit"] == 2 and "CRC-32 mismatch" in p.node.stdout


def test_run_block_layout(tmp_path: Path) -> None:
    """write_run_block: the header of c_src/firmware/pil_run.h, the columns, the CRC."""
    import zlib

    t = np.arange(4) * 1e-3
    q = np.arange(12.0).reshape(4, 3)
    values = {"kp[1]": 1.0, "kp[2]": 2.0, "kp[3]": 3.0, "kd[1]": 4.0, "kd[2]": 5.0,
              "kd[3]": 6.0, "feedforward": False, "a2": 0.4}
    n = write_run_block(tmp_path / "b.bin", t, q, q + 100, q + 200, values, timeout_ms=1234)
    raw = (tmp_path / "b.bin").read_bytes()
    assert len(raw) == n == 80 + 16 + 80 * 4 + 8
    magic, total, periods, sets, ff, timeout = struct.unpack_from("<8sIIIII", raw)
    assert (magic, total, periods, sets, ff, timeout) == (b"RRRPIL01", n, 4, 1, 0, 1234)
    assert struct.unpack_from("<6d", raw, 32) == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert struct.unpack_from("<d", raw, 88) == (0.4,)
    cols = np.frombuffer(raw[96:96 + 320], dtype="<f8")
    assert np.array_equal(cols[:4], t) and np.array_equal(cols[4:16], q.ravel())
    assert np.array_equal(cols[28:40], (q + 200).ravel())
    assert struct.unpack_from("<I", raw, n - 8) == (zlib.crc32(raw[:n - 8]),)
    with pytest.raises(ValueError, match="gains are missing"):
        write_run_block(tmp_path / "c.bin", t, q, q, q, {"kp[1]": 1.0})
    with pytest.raises(ValueError, match=r"sampled at 0\.002 s"):
        write_run_block(tmp_path / "c.bin", 2 * t, q, q, q, values)
    with pytest.raises(ValueError, match="unknown model parameter"):
        write_run_block(tmp_path / "c.bin", t, q, q, q, {**values, "nonsense": 1.0})
