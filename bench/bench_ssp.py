"""The writing task as an SSP archive in libcosim and FMPy against rrr writing: the maximum and
RMS tip error of each built-in scenario with the one-step compensation (reference look-ahead and
controller lead), with the reference look-ahead only, and with none; then one run in libcosim's
real-time mode and the real-time factor it achieved. Prints a table; asserts nothing.

Usage: python bench/bench_ssp.py [--out DIR] [--no-real-time]
"""

from __future__ import annotations

import argparse
import re
import tempfile
import zipfile
from pathlib import Path

from _timing import add_quick, apply_quick, timed
from rrr_robot.ssp.export import SspJob, export_ssp
from rrr_robot.ssp.run import SspRun, run_ssp
from rrr_robot.writing.job import WritingJob, run_writing
from rrr_robot.writing.scenarios import BUILTIN


def without_lead(src: Path, dst: Path) -> Path:
    """The archive with the controller's lead set to 0 (the reference keeps its look-ahead)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "SystemStructure.ssd":
                text, n = re.subn(r'(<ssv:Parameter name="lead">\s*<ssv:Real value=")[^"]*',
                                  r"\g<1>0.0", data.decode())
                assert n == 1
                data = text.encode()
            zout.writestr(item, data)
    return dst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="folder for the archives and results (default: a "
                    "temporary one)")
    ap.add_argument("--no-real-time", action="store_true", help="skip the real-time run")
    ap.add_argument("--real-time-only", action="store_true", help="only the real-time run")
    ap.add_argument("--scenario", action="append", choices=list(BUILTIN), metavar="S",
                    help="the scenarios of the table (repeatable; default: all built-in)")
    add_quick(ap)
    args = apply_quick(ap, ap.parse_args(), {"scenario": ["ctc"], "no_real_time": True})
    with tempfile.TemporaryDirectory(prefix="bench-ssp-") as tmp:
        root = args.out or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        if args.real_time_only:
            export_ssp(SspJob(out=root / "ctc.ssp", scenario="ctc"))
        scenarios = args.scenario or list(BUILTIN)
        ours = {"scenarios": {}} if args.real_time_only else run_writing(
            WritingJob(out=root / "writing", engine="native", figures=False,
                       scenarios=scenarios))
        print("| scenario | rrr writing: max / RMS (mm) | compensation | libcosim: max / RMS (mm)"
              " | FMPy: max / RMS (mm) |")
        print("|---|---|---|---|---|")
        for scn in () if args.real_time_only else scenarios:
            w = ours["scenarios"][scn]
            both = root / f"{scn}.ssp"
            export_ssp(SspJob(out=both, scenario=scn))
            none = root / f"{scn}-none.ssp"
            export_ssp(SspJob(out=none, scenario=scn, lookahead_steps=0))
            ref_only = without_lead(both, root / f"{scn}-reference-only.ssp")
            for label, ssp in (("look-ahead + lead (default)", both),
                               ("look-ahead only", ref_only), ("none", none)):
                cells = []
                for tool in ("libcosim", "fmpy"):
                    s = run_ssp(SspRun(ssp=ssp, tool=tool, out=root / f"{ssp.stem}-{tool}"))
                    m = s["scenarios"][scn]
                    cells.append(f"{1e3 * m['tip_error_max']:.3f} / "
                                 f"{1e3 * m['tip_error_rms']:.3f} "
                                 f"({s['ssp']['real_time_factor']:.0f}x real time)")
                print(f"| `{scn}` | {1e3 * w['tip_error_max']:.3f} / "
                      f"{1e3 * w['tip_error_rms']:.3f} | {label} | {cells[0]} | {cells[1]} |")
        if not args.no_real_time:
            s, wall = timed(lambda: run_ssp(SspRun(ssp=root / "ctc.ssp", tool="libcosim",
                                                    out=root / "rt", real_time=True)))
            info = s["ssp"]
            print(f"\nreal time (libcosim, ctc): {info['simulated_time']:.3f} s simulated in "
                  f"{info['wall_time']:.3f} s: real-time factor {info['real_time_factor']:.4f} "
                  f"(libcosim's own figure at the end: {info['libcosim_real_time_factor']:.4f}); "
                  f"the whole call took {wall:.2f} s with loading and writing")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
