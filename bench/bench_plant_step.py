#!/usr/bin/env python3
"""Cost of one plant fmi2DoStep (1 ms) at the default integrator against the fixed-step RK4 of
ten substeps (the former default), interleaved in one process.

A C driver (bench/bench_plant_step.c, built here with the system C compiler against FMPy's FMI
headers) loads the plant FMU binary, makes one instance per configuration, snapshots each after
initialization, and then runs blocks: every block runs every configuration once over the same
input sequence from its snapshot (the order reversed every other block), timing each
fmi2DoStep call. So the configurations share the machine state; the table gives the min /
median / max over blocks of the mean cost per step, and of the ratio default / fixed step
within each block.

Configurations: ``default`` (adaptive Dormand-Prince 5(4), rtol and atol at their defaults) and
``fixed`` (adaptive = false, h_int = 1e-4 s: ten RK4 substeps, the former default) of the FMU
under test, and with ``--baseline-ref REF`` (or ``--baseline-fmu FILE``) the plant FMU built from
another revision, at its defaults (``today``: e.g. the revision before the adaptive integrator,
whose doStep is ten RK4 substeps with libm's tanh).

Input sequences: ``open loop`` (u = [0.5, 1, 0.3] V from q0 = (0.1, 0.4, 1.0), 2 s) and
``writing`` (the voltages of the default writing task's ctc scenario, 5.91 s, recorded from a
co-simulation with the FMU under test and replayed open loop from the same start).

A measurement, not a test: it prints and never fails on a missed target (target of the issue:
the default at most 1/3 of the ten-substep cost).

Usage:
    python bench/bench_plant_step.py [--fmu-dir DIR] [--blocks N] [--baseline-ref REF]
                                     [--baseline-fmu FILE] [--no-writing]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
from _timing import add_quick, apply_quick, logger

ROOT = Path(__file__).resolve().parent.parent
DRIVER = ROOT / "bench" / "bench_plant_step.c"
STEP = 1e-3
OPEN_LOOP_Q0 = (0.1, 0.4, 1.0)
OPEN_LOOP_U = (0.5, 1.0, 0.3)


log = logger("bench_plant_step")


class Binary:
    """A plant FMU binary (Linux, FMI 2.0) with its GUID and value references."""

    def __init__(self, unzip_dir: Path) -> None:
        import xml.etree.ElementTree as ET

        root = ET.parse(unzip_dir / "modelDescription.xml").getroot()
        self.guid = root.attrib["guid"]
        self.vr = {v.attrib["name"]: int(v.attrib["valueReference"])
                   for v in root.iter("ScalarVariable")}
        self.so = unzip_dir / "binaries" / "linux64" / "rrr_plant.so"
        self.resources = (unzip_dir / "resources").as_uri()

    def config(self, label: str, q0: tuple[float, ...], values: dict[str, object]) -> str:
        sets = {f"q0[{i + 1}]": q for i, q in enumerate(q0)} | values
        spec = ",".join(f"{self.vr[k]}={str(v).lower() if isinstance(v, bool) else repr(v)}"
                        for k, v in sets.items())
        return f"{label}|{self.so}|{self.guid}|{self.resources}|{spec}"


def unzip(fmu: Path, into: Path) -> Path:
    with zipfile.ZipFile(fmu) as z:
        z.extractall(into)
    return into


def build_baseline(ref: str, work: Path) -> Path:
    """The FMI 2.0 plant FMU of revision REF, built from `git archive` (staged, unzipped)."""
    src = work / "src"
    src.mkdir()
    log(f"building the plant FMU of {ref} in {src} ...")
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    build = work / "build"
    subprocess.run(["cmake", "-S", str(src), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                    "-DRRR_BUILD_HIL=OFF", "-DRRR_BUILD_TESTS=OFF", "-DRRR_FMU_WINDOWS=OFF",
                    f"-DPython3_EXECUTABLE={sys.executable}"], check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(build), "-j2", "--target", "rrr_plant_fmi2_fmu"],
                   check=True, capture_output=True)
    return build / "fmu" / "fmi2" / "rrr_plant"


def build_driver(work: Path) -> Path:
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    exe = work / "bench_plant_step"
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-O2", "-std=c11", "-Wall", "-Wextra", f"-I{headers}", str(DRIVER),
                    "-o", str(exe), "-ldl"], check=True)
    return exe


def writing_inputs(plant_fmu: Path, controller_fmu: Path,
                   work: Path) -> tuple[tuple[float, ...], np.ndarray]:
    """q0 and the applied voltages of the default writing task's ctc scenario."""
    from rrr_robot.core.param_names import model_fmu_values
    from rrr_robot.sim.cosim import CosimOptions, run_cosim
    from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare

    model, robot, (scn,), ref = prepare(WritingJob(out=work / "writing", scenarios=["ctc"]))
    res = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                    CosimOptions(step=float(ref.t[1] - ref.t[0]),
                                 plant_values=model_fmu_values(model),
                                 controller_values=controller_fmu_values(
                                     scn, model, robot.require_control()),
                                 plant_fmu=plant_fmu, controller_fmu=controller_fmu))
    # u at t_k is held over [t_k, t_k+1]: the last sample has no step after it
    return tuple(float(v) for v in ref.q[0]), np.asarray(res.u, dtype=float)[:-1]


def run(driver: Path, blocks: int, u: np.ndarray, configs: list[str], work: Path) -> list[dict]:
    inputs = work / "u.bin"
    np.concatenate([[float(len(u))], np.asarray(u, dtype=float).ravel()]).tofile(inputs)
    out = subprocess.run([str(driver), str(blocks), repr(STEP), str(inputs), *configs],
                         check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def report(name: str, rows: list[dict], n: int, labels: list[str]) -> None:
    per: dict[str, list[float]] = {lab: [] for lab in labels}
    q_end: dict[str, list[float]] = {}
    for r in rows:
        if "us_per_step" in r:
            per[r["label"]].append(r["us_per_step"])
        else:
            q_end[r["label"]] = r["q_end"]
    print(f"\n### {name}: {n} doSteps of 1 ms per block, {len(per[labels[0]])} blocks\n")
    print("| configuration | us per fmi2DoStep: min / median / max |")
    print("|---|---|")
    for lab in labels:
        a = np.array(per[lab])
        print(f"| {lab} | {a.min():.3f} / {np.median(a):.3f} / {a.max():.3f} |")
    base = np.array(per["default"])
    for other in labels[1:]:
        ratio = base / np.array(per[other])
        print(f"| default / {other} (per block) | {ratio.min():.3f} / {np.median(ratio):.3f} / "
              f"{ratio.max():.3f} |")
    diff = {lab: float(np.max(np.abs(np.array(q_end[lab]) - np.array(q_end["default"]))))
            for lab in labels[1:]}
    print("\nend state, max |q - q_default| (rad): "
          + ", ".join(f"{lab} {d:.3g}" for lab, d in diff.items()))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", type=Path,
                        help="folder with rrr_plant.fmu and rrr_controller.fmu (a CMake build's "
                             "fmus/); default: the installed package's")
    parser.add_argument("--blocks", type=int, default=9)
    parser.add_argument("--baseline-ref", help="git revision whose plant FMU is 'today'")
    parser.add_argument("--baseline-fmu", type=Path, help="a plant .fmu file as 'today'")
    parser.add_argument("--no-writing", action="store_true", help="open loop only")
    add_quick(parser)
    args = apply_quick(parser, parser.parse_args(), {"blocks": 1})
    if args.fmu_dir is not None:
        plant_fmu, ctrl_fmu = args.fmu_dir / "rrr_plant.fmu", args.fmu_dir / "rrr_controller.fmu"
    else:
        import rrr_robot as rr

        plant_fmu, ctrl_fmu = Path(rr.fmu_path("plant")), Path(rr.fmu_path("controller"))
    work = Path(tempfile.mkdtemp(prefix="bench_plant_step-"))
    try:
        new = Binary(unzip(plant_fmu, work / "new"))
        baseline = None
        if args.baseline_fmu is not None:
            baseline = Binary(unzip(args.baseline_fmu, work / "baseline"))
        elif args.baseline_ref is not None:
            (work / "baseline").mkdir()
            baseline = Binary(build_baseline(args.baseline_ref, work / "baseline"))
        driver = build_driver(work)
        scenarios: list[tuple[str, tuple[float, ...], np.ndarray]] = [
            ("open loop, u = [0.5, 1, 0.3] V, 2 s", OPEN_LOOP_Q0,
             np.tile(OPEN_LOOP_U, (2000, 1)))]
        if not args.no_writing:
            try:
                q0, u = writing_inputs(plant_fmu, ctrl_fmu, work)
                scenarios.append(("writing task ctc voltages, replayed open loop", q0, u))
            except Exception as exc:  # a bench: say why and go on
                log(f"no writing-task inputs ({type(exc).__name__}: {exc}); open loop only")
        load = os.getloadavg()
        print(f"# Plant doStep cost: {platform.processor() or platform.machine()}, "
              f"{os.cpu_count()} CPUs, load average {load[0]:.2f} at start")
        print(f"FMU under test: {plant_fmu}"
              + (f"; today: {args.baseline_ref or args.baseline_fmu}" if baseline else ""))
        for name, q0, u in scenarios:
            labels = ["default", "fixed"]
            configs = [new.config("default", q0, {}),
                       new.config("fixed", q0, {"adaptive": False, "h_int": 1e-4})]
            if baseline is not None:
                labels.append("today")
                configs.append(baseline.config("today", q0, {}))
            rows = run(driver, args.blocks, u, configs, work)
            report(name, rows, len(u), labels)
        print(f"\nload average {os.getloadavg()[0]:.2f} at the end")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
