#!/usr/bin/env python3
"""Runs two fmu_run commands on the same arguments and compares their CSV outputs.

    compare_runs.py [--tolerance T] --a LABEL CMD... --b LABEL CMD... -- ARGS...

Each command (the program and any launcher before it, e.g. ``wine fmu_run.exe``) is run with
ARGS appended. Both must exit with 0 and print the same lines: text fields (scenario names, the
header lines) equal, numeric fields finite and within T (absolute) of each other. Prints the
measured maximum difference, where it occurs and how many values are bit-identical; exits 1 when
the outputs differ by more than T, 2 when a run fails or the outputs are unusable.
"""
import argparse
import math
import subprocess
import sys
import time


def run(label, cmd):
    start = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, check=False)
    seconds = time.monotonic() - start
    err = proc.stderr.decode("utf-8", "replace").strip()
    if proc.returncode != 0:
        print(f"{label}: {' '.join(cmd)}\n  exited with {proc.returncode}", file=sys.stderr)
        if err:
            print(f"  stderr:\n{err}", file=sys.stderr)
        sys.exit(2)
    print(f"{label}: {len(proc.stdout)} bytes in {seconds:.2f} s: {' '.join(cmd)}")
    if err:
        print(f"  ({label} stderr: {err})")
    return proc.stdout.decode("ascii").splitlines()


def number(field):
    try:
        return float(field)
    except ValueError:
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, required=True)
    ap.add_argument("--a", nargs="+", required=True, metavar=("LABEL", "CMD"))
    ap.add_argument("--b", nargs="+", required=True, metavar=("LABEL", "CMD"))
    ap.add_argument("args", nargs="*", help="arguments appended to both commands (after --)")
    opt = ap.parse_args()
    if len(opt.a) < 2 or len(opt.b) < 2:
        ap.error("--a and --b take a label and a command")

    label_a, label_b = opt.a[0], opt.b[0]
    lines_a = run(label_a, opt.a[1:] + opt.args)
    lines_b = run(label_b, opt.b[1:] + opt.args)
    if len(lines_a) != len(lines_b):
        print(f"FAIL: {label_a} printed {len(lines_a)} lines, {label_b} {len(lines_b)}")
        return 1

    max_diff, where, n_values, n_identical = 0.0, "", 0, 0
    scenario_max = {}  # max difference per scenario
    rows = {}  # data rows per scenario (first field)
    header = None  # the last header line: "scenario,t,<names>"
    for i, (la, lb) in enumerate(zip(lines_a, lines_b, strict=True), start=1):
        fa, fb = la.split(","), lb.split(",")
        if len(fa) != len(fb):
            print(f"FAIL: line {i}: {len(fa)} fields against {len(fb)}")
            return 1
        if fa[0] == "scenario":
            if la != lb:
                print(f"FAIL: line {i}: headers differ:\n  {la}\n  {lb}")
                return 1
            header = fa
            continue
        if fa[0] != fb[0]:
            print(f"FAIL: line {i}: scenario {fa[0]!r} against {fb[0]!r}")
            return 1
        if header is None or len(header) != len(fa):
            print(f"FAIL: line {i}: no header line of {len(fa)} fields before the data")
            return 2
        rows[fa[0]] = rows.get(fa[0], 0) + 1
        for j in range(1, len(fa)):
            xa, xb = number(fa[j]), number(fb[j])
            if xa is None or xb is None or not math.isfinite(xa) or not math.isfinite(xb):
                print(f"FAIL: line {i}, column {header[j]}: {fa[j]!r} / {fb[j]!r} (not finite "
                      "numbers)")
                return 2
            n_values += 1
            n_identical += fa[j] == fb[j]
            d = abs(xa - xb)
            scenario_max[fa[0]] = max(scenario_max.get(fa[0], 0.0), d)
            if d > max_diff:
                max_diff = d
                where = f"{fa[0]} t={fa[1]} {header[j]}: {fa[j]} vs {fb[j]}"

    if not rows:
        print("FAIL: no data rows")
        return 2
    print("rows: " + ", ".join(f"{k} {v} (max diff {scenario_max[k]:.3g})"
                               for k, v in rows.items())
          + f"; {n_values} values, {n_identical} bit-identical")
    print(f"max |{label_a} - {label_b}| = {max_diff:.3g} (tolerance {opt.tolerance:g})"
          + (f" at {where}" if where else ""))
    if not max_diff <= opt.tolerance:
        print("FAIL: the outputs differ by more than the tolerance")
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
