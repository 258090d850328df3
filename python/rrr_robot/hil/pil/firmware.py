"""The firmware images of ``rrr hil pil`` (c_src/firmware): the targets, where the images are,
what they occupy (from the ELF) and the run block they read (gains, model, reference).

Two targets, both Arm MPS2 boards that QEMU emulates: :data:`M7` (Cortex-M7 with the
double-precision FPU, ``mps2-an500``; librrr's law in double) and :data:`M4F` (Cortex-M4F,
single precision only, ``mps2-an386``; the law in float). The images are built with CMake
(``cmake -S c_src/firmware -B build-firmware``) and found in ``--firmware DIR``.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core._arrays import FloatArray
from ...core.fmu_vars import names
from ...core.outputs import atomic_path
from ...core.param_names import param
from ...errors import BadInputError, HilError
from ..nodes import PERIOD

__all__ = ["M4F", "M7", "RUN_BLOCK_ADDRESS", "RUN_BLOCK_CAPACITY", "TARGETS", "ElfSizes",
           "Target", "elf_sizes", "find_image", "max_periods", "write_run_block"]

#: Where the run block goes: the linker script's RUN region (c_src/firmware/board/mps2.ld).
RUN_BLOCK_ADDRESS = 0x00100000
#: Its size: 3 MB.
RUN_BLOCK_CAPACITY = 3 * 1024 * 1024
#: The run block's layout (c_src/firmware/pil_run.h).
_MAGIC = b"RRRPIL01"
_HEADER = struct.Struct("<8sIIIII4x6d")
_SET = struct.Struct("<I4xd")
#: Bytes per period of the reference table (t, q, qd, qdd: 10 doubles).
_ROW_BYTES = 80


@dataclass(frozen=True)
class Target:
    """A firmware image and the board QEMU emulates for it."""

    name: str      # "m7", "m4f"
    image: str     # the ELF's file name in the build folder
    machine: str   # qemu-system-arm -M
    core: str      # the core and its FPU, as said
    law: str       # "double" or "float": the arithmetic of the law


M7 = Target("m7", "rrr_pil_m7.elf", "mps2-an500",
            "Cortex-M7 with double-precision FPU (FPv5-D16), QEMU mps2-an500", "double")
M4F = Target("m4f", "rrr_pil_m4f.elf", "mps2-an386",
             "Cortex-M4F with single-precision FPU (FPv4-SP-D16), QEMU mps2-an386", "float")
TARGETS: dict[str, Target] = {t.name: t for t in (M7, M4F)}

_BUILD = ("cmake -S c_src/firmware -B build-firmware && cmake --build build-firmware -j2 "
          "(gcc-arm-none-eabi and picolibc-arm-none-eabi; docs/microcontroller.md)")


def find_image(folder: Path, target: Target) -> Path:
    """The target's ELF in ``folder`` (a build folder of c_src/firmware); BadInputError saying
    how to build it when it is not there."""
    path = Path(folder) / target.image
    if not path.is_file():
        raise BadInputError(f"no firmware {path}: build it from a clone with {_BUILD}, or give "
                            "its folder with --firmware DIR")
    return path


@dataclass(frozen=True)
class ElfSizes:
    """What an image occupies, from its ELF's section headers, in bytes: flash (code and
    constants, and the initial values of .data, copied to RAM at reset) and RAM (.data, .bss
    with picolibc's thread-local errno, and the stack the linker script reserves)."""

    text: int
    data: int
    bss: int
    stack: int

    @property
    def flash(self) -> int:
        return self.text + self.data

    @property
    def ram(self) -> int:
        return self.data + self.bss + self.stack


def elf_sizes(path: Path) -> ElfSizes:
    """The sections of a 32-bit little-endian ARM ELF summed by kind (allocated sections only:
    code and read-only data; initialised data; zeroed data; the stack); HilError if it is not
    one."""
    raw = Path(path).read_bytes()
    if raw[:4] != b"\x7fELF" or raw[4] != 1 or raw[5] != 1 or len(raw) < 52:
        raise HilError(f"{path}: not a 32-bit little-endian ELF")
    shoff, = struct.unpack_from("<I", raw, 32)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", raw, 46)
    sections = [struct.unpack_from("<IIIIIIIIII", raw, shoff + i * shentsize)
                for i in range(shnum)]
    names_at = sections[shstrndx][4]

    def name(sec: tuple[int, ...]) -> str:
        start = names_at + sec[0]
        return raw[start:raw.index(b"\0", start)].decode("ascii")

    sizes = {"text": 0, "data": 0, "bss": 0, "stack": 0}
    alloc, write, exec_, tls, nobits = 0x2, 0x1, 0x4, 0x400, 8
    for sec in sections:
        sh_type, flags, size = sec[1], sec[2], sec[5]
        if not flags & alloc or size == 0 or (sh_type == nobits and flags & tls):
            continue  # .tbss takes no room of its own (the linker script's .tbss_space does)
        if name(sec) == ".stack":
            sizes["stack"] += size
        elif sh_type == nobits:
            sizes["bss"] += size
        elif flags & write and not flags & exec_:
            sizes["data"] += size
        else:
            sizes["text"] += size
    return ElfSizes(**sizes)


def max_periods(sets: int) -> int:
    """The longest reference (periods) a run block holds with ``sets`` parameter values."""
    return (RUN_BLOCK_CAPACITY - _HEADER.size - _SET.size * sets - 8) // _ROW_BYTES


def write_run_block(path: Path, t: FloatArray, q: FloatArray, qd: FloatArray, qdd: FloatArray,
                    values: Mapping[str, float | bool], timeout_ms: int = 5000) -> int:
    """Write the run block (c_src/firmware/pil_run.h) of a reference and the controller's start
    values (the controller FMU's names: kp[i], kd[i], feedforward and model parameters, as the
    controller node takes them) to ``path``, atomically; returns its size in bytes.
    BadInputError for a reference longer than the block holds, not sampled at the bench's
    period, or an unknown name."""
    kp_names, kd_names = names("controller", "kp"), names("controller", "kd")
    kp = [float(values.get(name, np.nan)) for name in kp_names]
    kd = [float(values.get(name, np.nan)) for name in kd_names]
    gains = {*kp_names, *kd_names}
    if np.isnan(kp + kd).any():
        raise BadInputError(f"the controller's gains are missing: {sorted(gains - set(values))}")
    sets = [(param(name).row, float(v)) for name, v in values.items()
            if name not in gains and name != "feedforward"]
    n = int(np.asarray(t).shape[0])
    steps = np.diff(np.asarray(t, dtype=float))
    if steps.size and not np.allclose(steps, PERIOD, rtol=1e-9, atol=1e-12):
        raise BadInputError(f"the firmware runs at the bench's {PERIOD:g} s: the reference is "
                            f"sampled at {float(steps[0]):g} s")
    if not 1 <= n <= max_periods(len(sets)):
        raise BadInputError(f"the reference has {n} periods: the firmware's run block holds 1 "
                            f"to {max_periods(len(sets))} ({RUN_BLOCK_CAPACITY // 2**20} MB "
                            "of flash; a shorter --duration)")
    total = _HEADER.size + _SET.size * len(sets) + _ROW_BYTES * n + 8
    body = bytearray(_HEADER.pack(_MAGIC, total, n, len(sets),
                                  int(bool(values.get("feedforward", True))), timeout_ms,
                                  *kp, *kd))
    for row, v in sets:
        body += _SET.pack(row, v)
    for column in (t, q, qd, qdd):
        body += np.ascontiguousarray(column, dtype="<f8").tobytes()
    body += struct.pack("<I4x", zlib.crc32(body))
    assert len(body) == total
    with atomic_path(Path(path)) as tmp:
        tmp.write_bytes(bytes(body))
    return total
