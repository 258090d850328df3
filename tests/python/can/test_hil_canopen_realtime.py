"""``rrr hil canopen --realtime`` (docs/canopen.md, "Real time"): a SYNC every 1 ms on the wall
clock (the Python master: the canopen package's producer; the C master: its own clock) against
``rrr_hil_plant --profile canopen --realtime`` over socketcand, the master's heartbeat watched by
the drives' consumer 0x1016 (what it prints, docs/canopen.md's blocks show and the docs test
checks). A test, not a benchmark: it passes on a busy machine, so nothing
here asserts a latency, a jitter or a deadline. Either master's runs set the drives' watchdogs
generously (consumer 2 s against a 20 ms heartbeat, RPDO timeout 255 SYNC periods against the
EDS's 3: the C master's --consumer-ms and --rpdo-timeout); the runs complete with every drive
in OPERATION ENABLED and the summary holds the timing statistics, which are printed (``pytest
-s``); when the master's heartbeat stops, the drives fault (EMCY 0x8130, FAULT, 0 V), never
before their consumer time."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.cli.app import main
from rrr_robot.core.outputs import ResultSet
from rrr_robot.errors import EmcyError
from rrr_robot.hil.canopen.c_master import run_c_master
from rrr_robot.hil.canopen.drives import MASTER_NODE_ID, NODE_FRAMES
from rrr_robot.hil.canopen.master import MasterRun, run_canopen_master
from rrr_robot.hil.canopen.realtime import CanopenRealTime, frame_log_timing
from rrr_robot.hil.canopen.results import (
    WritingController,
    write_master_results,
    writing_controller,
)
from rrr_robot.hil.logs import frames as fl
from rrr_robot.hil.logs.specs import PLANT_LOG, read_log
from rrr_robot.hil.results import extend_reference

#: Seconds of the writing task a real-time run covers (3,001 SYNC periods).
SECONDS = 3.0
#: Either master's runs: the drives' heartbeat consumer (ms) and RPDO timeout (SYNC periods),
#: far above what a quiet machine needs (a heartbeat every 20 ms, an RPDO a period).
GENEROUS = CanopenRealTime(consumer_ms=2000, rpdo_timeout=255)
_SW_MASK, _SW_ENABLED = 0x6F, 0x27


@pytest.fixture(scope="module")
def wc() -> WritingController:
    w = writing_controller(None, "ctc")
    return replace(w, ref=extend_reference(w.ref, SECONDS))


def _run(w: WritingController, work: Path, realtime: CanopenRealTime,
         kind: str = "python") -> MasterRun:
    ref = w.ref
    if kind == "c":
        return run_c_master(ref.t, ref.q, ref.qd, ref.qdd, w.controller_model,
                            w.controller_values, work, realtime=realtime)
    return run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd, w.controller_model, w.gains,
                              work, realtime=realtime)


def _ids(records: np.ndarray) -> np.ndarray:
    return np.asarray(records["id"] & 0x1FFFFFFF)


@pytest.mark.parametrize("kind", ["python", "c"])
def test_realtime_writing_task(kind: str, wc: WritingController, tmp_path: Path) -> None:
    """Either master: the Python one on the canopen package, the C node (rrr_hil_rt clock), each
    with the generous watchdogs."""
    n = wc.ref.t.shape[0]
    with ResultSet(tmp_path / "rt", kind="hil") as rs:
        mrun = _run(wc, rs.staging, GENEROUS, kind)
        summary = write_master_results(rs, wc, mrun, scenario="ctc", figures=False)
    ps = mrun.plant_summary
    assert ps["exit"] == 0 and ps["drive_faults"] == 0, ps
    assert all(d["rpdo_timeouts"] == 0 and d["hb_lost"] == 0 for d in ps["drives"]), ps
    assert "SCHED_FIFO" in ps.get("rt_setup", ""), ps  # the plant ran with --realtime
    # every SYNC the drives received was answered by each with a TPDO1 saying OPERATION
    # ENABLED (the master checks each one it uses); the producer may send a SYNC or more after
    # the last one the master answers, before it is stopped
    records = fl.read_node_log(tmp_path / "rt" / NODE_FRAMES)
    ids, tx = _ids(records), records["dir"] == 1
    syncs = int(np.count_nonzero((ids == 0x080) & ~tx))
    assert syncs >= n
    for node in (1, 2, 3):
        sel = records[tx & (ids == 0x180 + node)]
        sw = sel["data"][:, 0].astype(int) | (sel["data"][:, 1].astype(int) << 8)
        assert sel.size == syncs and np.all(sw & _SW_MASK == _SW_ENABLED), node
    # the master's heartbeat reached the drives while they watched it
    hb = records["t_ns"][(ids == 0x700 + MASTER_NODE_ID) & ~tx]
    assert hb.size >= 1
    # the watchdogs written by SDO to each drive: consumer 0x1016 sub 1 of node 127, 2000 ms,
    # and the RPDO timeout 0x2001, 255 SYNC periods
    for node in (1, 2, 3):
        sdo = {bytes(d) for d in records[~tx & (ids == 0x600 + node)]["data"][:, :8]}
        assert bytes([0x23, 0x16, 0x10, 0x01, 0xD0, 0x07, 0x7F, 0x00]) in sdo, (node, sdo)
        assert bytes([0x2F, 0x01, 0x20, 0x00, 0xFF, 0x00, 0x00, 0x00]) in sdo, (node, sdo)
    # the tracking and the timing: in the summary, printed (this machine's speed is not tested)
    assert summary["mode"] == "realtime"
    tip = summary["bench"]["tip_error_max"]
    assert np.isfinite(tip) and tip > 0
    rt = summary["realtime"]
    d = rt["drives"]
    assert d["syncs"] == syncs and rt["sync_source"] == ("clock" if kind == "c" else "canopen")
    assert d["sync_period"]["min_us"] <= d["sync_period"]["median_us"] <= d["sync_period"][
        "max_us"]
    assert d["sync_jitter"]["max_us"] >= 0 and isinstance(d["deadline_misses"], int)
    assert rt["master_heartbeat_ms"] == 20
    assert rt["drive_consumer_ms"] == 2000 and rt["drive_rpdo_timeout_syncs"] == 255
    print(f"{kind} master, {SECONDS:g} s in real time: tip error max {1e3 * tip:.4f} mm "
          f"(lockstep: test_hil_canopen_master.py); SYNC period at the drives median "
          f"{d['sync_period']['median_us']:.1f} us, max {d['sync_period']['max_us']:.1f} us; "
          f"jitter p99 {d['sync_jitter']['p99_us']:.1f} us; {d['deadline_misses']} deadline "
          f"misses at the drives; master heartbeat interval median "
          f"{np.median(np.diff(hb)) * 1e-6 if hb.size > 1 else float('nan'):.1f} ms")
    m = rt["master"]
    if kind == "c":  # the C master's own account: one SYNC per period, its heartbeats
        cs = mrun.run.controller_summary
        assert cs["exit"] == 0 and cs["syncs"] == n and cs["heartbeats"] == hb.size, cs
        assert cs["consumer_ms"] == 2000 and cs["rpdo_timeout"] == 255, cs
        assert cs["tampered"] == "" and cs["tpdo_duplicates"] == 0, cs
        assert {"p50_us", "p99_us", "p999_us", "max_us"} <= set(m["wake_up"])
        assert "SCHED_FIFO 80" in m["setup"], m
        print(f"C master: wake-up latency p99 {m['wake_up']['p99_us']} us, "
              f"{m['rt_deadline_misses']} deadline misses")
    else:
        assert "python-can SYNC thread" in m["setup"], m
    saved = json.loads((tmp_path / "rt" / "summary.json").read_text())
    assert saved["realtime"] == json.loads(json.dumps(rt))


def test_heartbeat_loss_in_real_time(wc: WritingController, tmp_path: Path) -> None:
    """The master's heartbeat stops at SYNC 200: each drive's consumer (1 s here) faults on the
    wall clock, not before its time: EMCY 0x8130 with the error register 0x11, FAULT in its
    statusword, 0 V. The run (3 s of SYNCs on the clock) is long enough by construction."""
    rt = replace(GENEROUS, consumer_ms=1000, heartbeat_stop_at=200)
    with pytest.raises(EmcyError, match=r"SYNC \d+: EMCY 0x8130 from drive [123]"):
        _run(wc, tmp_path, rt)
    records = fl.read_node_log(tmp_path / NODE_FRAMES)
    ids, tx = _ids(records), records["dir"] == 1
    hb = records["t_ns"][(ids == 0x700 + MASTER_NODE_ID) & ~tx]
    assert hb.size >= 1
    last_hb = int(hb[-1])
    for node in (1, 2, 3):
        emcy = records[tx & (ids == 0x80 + node)]
        assert emcy.size == 1, node
        data = bytes(emcy["data"][0][:8])
        assert data[:3] == bytes([0x30, 0x81, 0x11]), data.hex()  # 0x8130, error register
        delay_ms = (int(emcy["t_ns"][0]) - last_hb) * 1e-6
        # not before the consumer time (1 ms for the clocks of the log and of the drive)
        assert delay_ms >= rt.consumer_ms - 1.0, delay_ms
        print(f"drive {node}: EMCY 0x8130 {delay_ms:.1f} ms after the last heartbeat")
        after = records[tx & (ids == 0x180 + node) & (records["t_ns"] > emcy["t_ns"][0])]
        assert after.size >= 5, node  # the master SYNCs on for a while after the EMCY
        sw = int(after["data"][-1, 0]) | int(after["data"][-1, 1]) << 8
        assert sw & 0x4F == 0x08, hex(sw)  # FAULT
    # 0 V from the fault on: the plant's last periods are at zero voltage
    plant = read_log(tmp_path / "plant.csv", PLANT_LOG)
    zero, u = plant.cols(["zero"])[:, 0], plant.group("u")
    assert zero[-5:].tolist() == [1.0] * 5 and np.all(u[-5:] == 0.0)
    assert zero[:200].max() == 0.0  # before the heartbeat stopped: no fault


def test_frame_log_timing_counts_late_rpdos() -> None:
    """frame_log_timing on a made-up log: SYNCs 1 ms apart but one 3 ms late, drive 2's RPDO
    missing before one SYNC."""
    rows = []
    t = 0
    for k in range(6):
        t += 3_000_000 if k == 3 else 1_000_000
        rows.append((t, 0x080))
        if k < 5:
            for node in (1, 2, 3):
                if not (k == 1 and node == 2):
                    rows.append((t + 500_000, 0x200 + node))
    rec = np.zeros(len(rows), dtype=fl.RECORD)
    rec["t_ns"] = [r[0] for r in rows]
    rec["id"] = [r[1] for r in rows]
    got = frame_log_timing(rec, [1, 2, 3])
    assert got["syncs"] == 6 and got["deadline_misses"] == 1
    assert got["deadline_miss_periods"] == [2]  # SYNC 2 came without drive 2's RPDO
    assert got["sync_period"]["max_us"] == 3000.0 and got["sync_jitter"]["max_us"] == 2000.0
    assert got["sync_period"]["median_us"] == 1000.0


@pytest.mark.parametrize(("argv", "message"), [
    (["--no-fifo"], "--no-fifo: an option of 'rrr hil canopen --realtime'"),
    (["--consumer-ms", "500"], "--consumer-ms: an option of 'rrr hil canopen --realtime'"),
    (["--rpdo-timeout", "9"], "--rpdo-timeout: an option of 'rrr hil canopen --realtime'"),
    (["--realtime", "--node-ids", "1,2,127"], "node id 127 is the master's own"),
    (["--realtime", "--master", "c", "--node-ids", "1,2,127"], "node id 127 is the master's own"),
    (["--realtime", "--spin-us", "50"], "--spin-us: the C master's clock (--master c)"),
    (["--consumer-ms", "500", "--master", "c"],
     "--consumer-ms: an option of 'rrr hil canopen --realtime'"),
    (["--realtime", "--master", "c", "--consumer-ms", "20"],
     "must be shorter than the consumer time 20 ms"),
    (["--realtime", "--consumer-ms", "20"], "must be shorter than the consumer time 20 ms"),
    (["--realtime", "--rpdo-timeout", "256"], "RPDO timeout is 1..255 SYNC periods, got 256"),
])
def test_realtime_options_are_checked(argv: list[str], message: str, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["-q", "hil", "canopen", "--duration", "0.1", "--no-figures", "--out",
               str(tmp_path / "out"), *argv])
    assert rc == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "out" / "summary.json").exists()
