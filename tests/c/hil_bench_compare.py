#!/usr/bin/env python3
"""Runs the lockstep CAN bench (rrr_hil_plant + rrr_hil_controller over socketcand on loopback)
with two builds of the nodes and compares the runs.

    hil_bench_compare.py --work DIR --seconds S --tolerance T
        --a LABEL PLANT CONTROLLER FMU_DIR [LAUNCHER...]
        --b LABEL PLANT CONTROLLER FMU_DIR [LAUNCHER...] [--mixed]

Each side is a pair of node executables, the unzipped plant FMU its plant node loads, and an
optional launcher put before both (e.g. qemu-aarch64; QEMU_LD_PREFIX names its sysroot). The
reference is a smooth joint motion of S seconds (1 ms periods) written into DIR. With --mixed a
third run pairs b's plant with a's controller (the two machines of a real bench).

Checks: every run exits 0 with both nodes' "completed" lines; the plant and controller logs
(--log CSV) have the same header and one row per period; every value is finite and within T of
the first run (T = 0: the same text, bit for bit); the RRR_HIL_SUMMARY lines of each node are
equal (counters of periods, frames, rejected frames, faults); the summary metrics computed from
the logs (RMS joint tracking error, RMS of u, u_n and u_c per joint, the largest |u|) are printed
for each run and are within T. Exits 1 on a mismatch, 2 when a run fails.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

J = (1, 2, 3)


def write_reference(path, seconds):
    """q_ref = q0 + a sin(w t) per joint, with its exact derivatives."""
    q0, amp, w = (0.2, 0.6, -1.0), (0.3, 0.2, 0.4), (2.0, 3.0, 5.0)
    cols = ["t"] + [f"{s}[{i}]" for s in ("q_ref", "qd_ref", "qdd_ref") for i in J]
    lines = [",".join(cols)]
    for k in range(round(seconds * 1000)):
        t = k * 1e-3
        q = [q0[j] + amp[j] * math.sin(w[j] * t) for j in range(3)]
        qd = [amp[j] * w[j] * math.cos(w[j] * t) for j in range(3)]
        qdd = [-amp[j] * w[j] ** 2 * math.sin(w[j] * t) for j in range(3)]
        lines.append(",".join(f"{x:.17g}" for x in [t, *q, *qd, *qdd]))
    path.write_text("\n".join(lines) + "\n")
    return [[float(x) for x in ln.split(",")] for ln in lines[1:]]


def run_bench(label, plant_side, ctrl_side, ref, work):
    """One lockstep run; returns its logs (header, rows) and the two summaries."""
    work.mkdir(parents=True, exist_ok=True)
    plant_log, ctrl_log = work / "plant.csv", work / "controller.csv"
    for f in (plant_log, ctrl_log):
        f.unlink(missing_ok=True)
    start = time.monotonic()
    plant = subprocess.Popen(
        [*plant_side["launcher"], plant_side["plant"], "--fmu", plant_side["fmu"],
         "--listen", "127.0.0.1:0", "--q0", "0.2,0.6,-1.0", "--qd0", "0.6,0.6,-2.0",
         "--log", str(plant_log)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = plant.stdout.readline()
    if re.search(r"listening on [\d.]+:\d+", first) is None:
        plant.kill()
        out, err = plant.communicate()
        fail(2, f"{label}: the plant did not start listening: {first.strip()} {err.strip()}")
    port = re.search(r"listening on [\d.]+:(\d+)", first).group(1)
    ctrl = subprocess.run(
        [*ctrl_side["launcher"], ctrl_side["controller"], "--reference", str(ref),
         "--connect", f"127.0.0.1:{port}", "--log", str(ctrl_log)],
        capture_output=True, text=True, timeout=300)
    try:
        p_out, p_err = plant.communicate(timeout=60 if ctrl.returncode == 0 else 5)
    except subprocess.TimeoutExpired:
        plant.kill()
        fail(2, f"{label}: the plant did not exit after the controller")
    seconds = time.monotonic() - start
    if plant.returncode != 0 or ctrl.returncode != 0:
        fail(2, f"{label}: exit codes plant {plant.returncode}, controller {ctrl.returncode}\n"
                f"plant stderr:\n{p_err}\ncontroller stderr:\n{ctrl.stderr}")
    for text, what in ((p_err, "rrr_hil_plant: exit 0 (completed)"),
                       (ctrl.stderr, "rrr_hil_controller: exit 0 (completed)")):
        if what not in text:
            fail(2, f"{label}: missing on stderr: {what!r}\n{text}")
    summaries = {}
    for node, out in (("plant", first + p_out), ("controller", ctrl.stdout)):
        lines = [ln for ln in out.splitlines() if ln.startswith("RRR_HIL_SUMMARY ")]
        if len(lines) != 1:
            fail(2, f"{label}: {node} printed {len(lines)} RRR_HIL_SUMMARY lines")
        summaries[node] = json.loads(lines[0][len("RRR_HIL_SUMMARY "):])
    logs = {"plant": read_csv(plant_log), "controller": read_csv(ctrl_log)}
    print(f"{label}: {len(logs['plant'][1])} plant rows, {len(logs['controller'][1])} controller "
          f"rows in {seconds:.2f} s")
    return logs, summaries


def read_csv(path):
    lines = path.read_text().splitlines()
    if len(lines) < 2:
        fail(2, f"{path}: no data rows")
    return lines[0].split(","), [ln.split(",") for ln in lines[1:]]


def metrics(logs, ref):
    """RMS tracking error and RMS voltages per joint from the controller's log."""
    header, rows = logs["controller"]
    col = {name: i for i, name in enumerate(header)}
    out = {}
    n = min(len(rows), len(ref))
    for j in J:
        e = [float(rows[k][col[f"q[{j}]"]]) - ref[k][j] for k in range(n)]
        out[f"rms_e[{j}]"] = math.sqrt(sum(x * x for x in e) / n)
        for s in ("u", "u_n", "u_c"):
            v = [float(r[col[f"{s}[{j}]"]]) for r in rows[:n]]
            out[f"rms_{s}[{j}]"] = math.sqrt(sum(x * x for x in v) / n)
    out["max_abs_u"] = max(abs(float(r[col[f"u[{j}]"]])) for r in rows[:n] for j in J)
    return out


def compare_logs(name, a, b, tol):
    """Max |a - b| over every numeric field; fails on a different shape or text."""
    (ha, ra), (hb, rb) = a, b
    if ha != hb or len(ra) != len(rb):
        fail(1, f"{name}: header or row count differ ({len(ra)} vs {len(rb)} rows)")
    worst, where, identical, total = 0.0, "", 0, 0
    for k, (x, y) in enumerate(zip(ra, rb, strict=True)):
        if len(x) != len(y):
            fail(1, f"{name}: row {k} has {len(x)} fields against {len(y)}")
        for c, (fx, fy) in enumerate(zip(x, y, strict=True)):
            total += 1
            identical += fx == fy
            vx, vy = float(fx), float(fy)
            if not (math.isfinite(vx) and math.isfinite(vy)):
                fail(1, f"{name}: row {k} {ha[c]}: {fx} / {fy} not finite")
            d = abs(vx - vy)
            if d > worst:
                worst, where = d, f"row {k} {ha[c]}: {fx} vs {fy}"
    if tol == 0 and identical != total:
        fail(1, f"{name}: {total - identical} values not bit-identical (tolerance 0)")
    print(f"  {name}: {len(ra)} rows, {total} values, {identical} identical, max diff {worst:.3g}"
          + (f" at {where}" if where else ""))
    return worst


def fail(code, msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(code)


def side(values):
    if len(values) < 4:
        fail(2, "--a/--b take LABEL PLANT CONTROLLER FMU_DIR [LAUNCHER...]")
    label, plant, controller, fmu, *launcher = values
    return {"label": label, "plant": plant, "controller": controller, "fmu": fmu,
            "launcher": launcher}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--tolerance", type=float, required=True)
    ap.add_argument("--a", nargs="+", required=True)
    ap.add_argument("--b", nargs="+", required=True)
    ap.add_argument("--mixed", action="store_true")
    opt = ap.parse_args()
    a, b = side(opt.a), side(opt.b)
    opt.work.mkdir(parents=True, exist_ok=True)
    ref_csv = opt.work / "reference.csv"
    ref = write_reference(ref_csv, opt.seconds)
    print(f"reference: {len(ref)} periods; QEMU_LD_PREFIX={os.environ.get('QEMU_LD_PREFIX', '')}")

    runs = [(a["label"], a, a), (b["label"], b, b)]
    if opt.mixed:
        runs.append((f"{b['label']} plant + {a['label']} controller", b, a))
    results = [run_bench(label, p, c, ref_csv, opt.work / f"run{i}")
               for i, (label, p, c) in enumerate(runs)]

    base_label = runs[0][0]
    base_logs, base_sum = results[0]
    base_metrics = metrics(base_logs, ref)
    print(f"{base_label}: " + ", ".join(f"{k} {v:.6g}" for k, v in base_metrics.items()))
    worst = 0.0
    for (label, _, _), (logs, summaries) in zip(runs[1:], results[1:], strict=True):
        print(f"{label} against {base_label}:")
        for node in ("plant", "controller"):
            worst = max(worst, compare_logs(f"{node} log", base_logs[node], logs[node],
                                            opt.tolerance))
            if summaries[node] != base_sum[node]:
                diff = {k: (base_sum[node].get(k), v) for k, v in summaries[node].items()
                        if base_sum[node].get(k) != v}
                fail(1, f"{label}: {node} summaries differ: {diff}")
            print(f"  {node} summary: equal ({len(summaries[node])} fields)")
        m = metrics(logs, ref)
        d = max(abs(m[k] - base_metrics[k]) for k in m)
        worst = max(worst, d)
        print(f"  summary metrics: max diff {d:.3g}")
    print(f"max difference {worst:.3g} (tolerance {opt.tolerance:g})")
    if not worst <= opt.tolerance:
        fail(1, "the runs differ by more than the tolerance")
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
