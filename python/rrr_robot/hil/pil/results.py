"""The files of ``rrr hil pil``: summary.json, the logs and the figures of ``rrr hil bench``
(:func:`rrr_robot.hil.dbc.results.write_results`), plus the target's section: what the image
occupies, the stack it used, the instructions of its law and of a period's work, and the share
of a 1 ms period that is at a stated clock; of the single-precision build also its voltages
against the double law on the same frames.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...core._arrays import FloatArray
from ...core.control import CtcGains
from ...core.model import Model
from ...core.outputs import ResultSet
from ...writing.trajectory import Reference
from ..dbc.results import RunInfo, write_results
from .firmware import Target, elf_sizes
from .loop import PilRun

__all__ = ["CLOCKS", "INSTRUCTION_COUNT", "double_law_difference", "target_section",
           "write_pil_results"]

#: The clock at which the share of a 1 ms period is stated, per target, and a part it is
#: typical of.
CLOCKS: dict[str, tuple[float, str]] = {
    "m7": (216e6, "216 MHz (an STM32F7's)"),
    "m4f": (168e6, "168 MHz (an STM32F4's)"),
}
#: How the instructions are counted (summary.json says it with the figures).
INSTRUCTION_COUNT = (
    "instructions, not cycles: QEMU runs with -icount shift=0 (each instruction advances the "
    "virtual clock by 1 ns) and the firmware reads the board's 25 MHz timer before and after "
    "each part (40 instructions per tick, interrupts off); 'law' is eq 15 with the model "
    "(rrr_ctc, or the float law), 'period' adds decoding the period's frames and encoding the "
    "commands (not the serial I/O, not the log)")


def _stats(v: FloatArray) -> dict[str, float]:
    return {"median": float(np.median(v)), "max": float(v.max())}


def target_section(target: Target, image: Path, instructions: FloatArray,
                   firmware: Mapping[str, Any], run_block_bytes: int) -> dict[str, Any]:
    """summary.json's ``target``: the core, the image's flash and RAM (from the ELF), the stack
    used (measured: the firmware paints its stack at reset), the instructions per period of the
    law and of the period's work (median, max) and their share of a 1 ms period at the
    target's clock with one instruction per cycle (an optimistic bound: said so)."""
    sizes = elf_sizes(image)
    fw = firmware.get("target", {})
    clock, clock_text = CLOCKS[target.name]
    law, period = instructions[:, 0], instructions[:, 1]
    per_ms = clock * 1e-3
    return {
        "core": target.core, "law_arithmetic": target.law, "image": image.name,
        "qemu_machine": target.machine,
        "flash_bytes": sizes.flash, "ram_bytes": sizes.ram,
        "sections_bytes": {"text_rodata": sizes.text, "data": sizes.data, "bss": sizes.bss,
                           "stack_reserved": sizes.stack},
        "run_block_bytes": run_block_bytes,
        "stack_used_bytes": fw.get("stack_used_bytes"),
        "instructions_per_period": {"law": _stats(law), "period": _stats(period)},
        "instruction_count": INSTRUCTION_COUNT,
        "share_of_1ms_period": {
            "clock_hz": clock,
            "assumption": f"{clock_text}, one instruction per cycle: an optimistic bound (flash "
                          "wait states, cache misses and multi-cycle FPU and divide "
                          "instructions cost more cycles on a real part)",
            "law_median": float(np.median(law)) / per_ms, "law_max": float(law.max()) / per_ms,
            "period_max": float(period.max()) / per_ms},
    }


def double_law_difference(run: PilRun, ref: Reference, model: Model,
                          gains: CtcGains) -> dict[str, Any]:
    """The firmware's voltages against librrr's double law (``Model.ctc``) on the same frames:
    each period's measured state (the JointState values, from the firmware's log) and
    reference row. Largest |du| per joint of u, u_n and u_c, V."""
    r, n = run.run, run.run.t.shape[0]
    q, qd = run.measured
    u, u_n, u_c = model.ctc(gains, ref.q[:n], ref.qd[:n], ref.qdd[:n], q, qd)
    assert r.u_n is not None and r.u_c is not None

    def dmax(a: FloatArray, b: FloatArray) -> list[float]:
        return np.abs(a - b).max(axis=0).tolist()  # type: ignore[no-any-return]

    return {"periods": n, "u_max_abs": dmax(r.u, u), "u_n_max_abs": dmax(r.u_n, u_n),
            "u_c_max_abs": dmax(r.u_c, u_c)}


def write_pil_results(rs: ResultSet, info: RunInfo, ref: Reference, run: PilRun, model: Model,
                      controller_values: Mapping[str, float | bool], target: Target,
                      image: Path, run_block_bytes: int, *, can_log: Path | None,
                      figures: bool = True, mcap: bool = False,
                      double_law: dict[str, Any] | None = None) -> dict[str, Any]:
    """summary.json (``rrr hil bench``'s, with ``target`` and, given, ``difference_to_double_
    law``), the figures and the frame log of a run whose logs are in the staging folder."""
    extra: dict[str, Any] = {"target": target_section(target, image, run.instructions,
                                                      run.nodes["controller"], run_block_bytes)}
    if double_law is not None:
        extra["difference_to_double_law"] = double_law
    return write_results(rs, info, ref, run.run, model, controller_values, run.nodes,
                         can_log=can_log, figures=figures, mcap=mcap, extra=extra)
