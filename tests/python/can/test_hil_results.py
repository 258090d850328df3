"""``rrr hil bench --out DIR``: summary.json with the writing task's metrics, the figures and a
frame log in a standard format.

- The metrics of the lockstep bench equal those of the FMPy co-simulation with the DBC's
  quantisation exactly (the same plant FMU binary, the same rrr_ctc, the same rounding), and the
  summary states the difference to the unquantised co-simulation (rr.simulate) of the scenario.
- The .blf (default) and .asc (--can-log) logs, read back with python-can's can.LogReader, hold
  the controller node's own frame log (frames.rrrcan) frame for frame: the same count, and per
  frame identifier, DLC, data, direction and time (within the microsecond ASC prints).
- The frames per period are the lockstep schedule's: VoltageCmd, Sync (Tx), JointState1..3,
  PlantStatus (Rx), plus the heartbeats every 100 periods.
- ``rrr hil bench --mcap``: bench.mcap, read by rosbags, holds the run's joint states, faults,
  every frame of the controller's frame log and each frame's signals as cantools decodes them.
"""

from __future__ import annotations

import contextlib
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.cli import main
from rrr_robot.hil.dbc.bench import quantised_cosim_result
from rrr_robot.hil.dbc.protocol import EXIT_SAFETY
from rrr_robot.hil.logs import frames as fl
from rrr_robot.hil.logs.specs import CONTROLLER_LOG, PLANT_LOG, read_log
from rrr_robot.hil.results import unquantised_cosim
from rrr_robot.writing.job import WritingJob, controller_fmu_values, metrics, prepare
from support.mcap_support import rosbags_messages, same


@pytest.fixture(scope="module")
def bench_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The output folder of ``rrr hil bench --out DIR -q``; what it printed is in the file
    printed.txt beside the folder."""
    out = tmp_path_factory.mktemp("hil") / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["hil", "bench", "--out", str(out), "-q"]) == 0
    (out.parent / "printed.txt").write_text(printed.getvalue(), encoding="utf-8")
    return out


def test_bench_writes_summary_figures_and_logs(bench_out: Path) -> None:
    s = json.loads((bench_out / "summary.json").read_text())
    expected = {"summary.json", "plant.csv", "controller.csv", "reference.csv", "frames.blf",
                "frames.rrrcan", "fig_letters_bench.png", "fig_bench_vs_cosim.png",
                "fig_joint_errors.png", "fig_voltages.png"}
    assert set(s["files"]) == expected
    assert all((bench_out / f).stat().st_size > 0 for f in expected)
    assert s["side"] == "bench" and s["mode"] == "lockstep" and s["scenario"] == "ctc"
    assert s["bench"]["status"] == "ok" and s["faults"]["faults"] == 0
    assert s["missed_commands"] == 0 and s["plant_exit"] == 0
    assert "realtime" not in s


def test_lockstep_metrics_equal_the_quantised_cosim(bench_out: Path) -> None:
    s = json.loads((bench_out / "summary.json").read_text())
    model, robot, scenarios, ref = prepare(WritingJob(out=Path("."), scenarios=["ctc"]))
    values = controller_fmu_values(scenarios[0], model, robot.control)
    quantised = quantised_cosim_result(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                                       controller_values=values)
    # the signals the metrics come from are the quantised co-simulation's, bit for bit
    # (the logs the C nodes wrote, read through the one spec of their columns)
    plant = read_log(bench_out / "plant.csv", PLANT_LOG)
    ctrl = read_log(bench_out / "controller.csv", CONTROLLER_LOG)
    assert np.array_equal(plant.group("q"), quantised.q)
    assert np.array_equal(plant.group("tip"), quantised.tip)
    for group, signal in (("u", quantised.u), ("u_n", quantised.u_n), ("u_c", quantised.u_c)):
        assert np.array_equal(ctrl.group(group), signal)
    # and so the metrics: maxima exactly, RMS values to the rounding of numpy's summation,
    # whose order depends on the arrays' memory layout (the FMU master's u_n is a strided view)
    want = metrics(quantised)
    assert s["bench"]["tip_error_max"] == want["tip_error_max"]
    for key in ("rms_u_n", "rms_u_c", "tip_error_rms"):
        assert s["bench"][key] == pytest.approx(want[key], rel=1e-14, abs=0), key
    e = quantised.q - quantised.q_ref
    assert s["bench"]["joint_error_max"] == np.abs(e).max(axis=0).tolist()
    # the difference to the unquantised run: the DBC's quantisation, small against tracking
    exact = unquantised_cosim(ref, model, values)
    d = s["difference_to_unquantised"]
    assert d["q_max_abs"] == np.abs(quantised.q - exact.q).max(axis=0).tolist()
    assert 0 < max(d["q_max_abs"]) < 1e-5 < max(s["bench"]["joint_error_max"])
    assert d["tip_error_max_delta_m"] == pytest.approx(
        want["tip_error_max"] - metrics(exact)["tip_error_max"], abs=1e-15)
    assert s["unquantised_cosim"]["tip_error_max"] == metrics(exact)["tip_error_max"]


def _check_read_back(records: np.ndarray, path: Path) -> None:
    back = fl.read_can_log(path)
    assert fl.compare(records, back) is None
    assert len(back) == len(records)


def test_frame_log_reads_back_frame_for_frame(bench_out: Path, tmp_path: Path) -> None:
    s = json.loads((bench_out / "summary.json").read_text())
    records = fl.read_node_log(bench_out / "frames.rrrcan")
    periods = s["reference"]["periods"]
    tx, rx = records[records["dir"] == 1], records[records["dir"] == 0]
    # every period VoltageCmd and (but the last) Sync; the plant's 4 frames per state
    assert np.count_nonzero(tx["id"] == 0x100) == periods
    assert np.count_nonzero(tx["id"] == 0x080) == periods - 1
    assert all(np.count_nonzero(rx["id"] == i) == periods for i in (0x201, 0x202, 0x203))
    # the last PlantStatus follows the last state, after which the controller stops reading
    assert np.count_nonzero(rx["id"] == 0x300) in (periods - 1, periods)
    assert s["bus"]["frames"] == len(records) and s["bus"]["tx"] == len(tx)
    assert np.all(np.diff(records["t_ns"]) >= 0)
    _check_read_back(records, bench_out / "frames.blf")
    # the same frames as ASC; and a log that differs is caught
    asc = fl.write_can_log(records, tmp_path / "frames.asc")
    _check_read_back(records, asc)
    changed = records.copy()
    changed["data"][100, 3] ^= 1
    assert "frame 100: data" in (fl.compare(changed, fl.read_can_log(asc)) or "")
    assert "frames read back" in (fl.compare(records[:-1], fl.read_can_log(asc)) or "")


def test_each_bus_load_is_named_by_its_meaning(bench_out: Path) -> None:
    """summary.json ``bus`` of a lockstep run: frames per period, no frames per second (no wall
    clock), and the loads of a 1 Mbit/s bus each under its own name: measured from the frame
    log (exact stuffing), the worst case of the lockstep schedule (Sync included) and of the
    real-time schedule (what rrr hil busload prints), each recomputed here."""
    from rrr_robot.hil.busload import measured_load, schedule_load
    from rrr_robot.hil.dbc.protocol import database

    s = json.loads((bench_out / "summary.json").read_text())
    bus, periods = s["bus"], s["reference"]["periods"]
    records = fl.read_node_log(bench_out / "frames.rrrcan")

    def keys(value: object) -> set[str]:
        if isinstance(value, dict):
            return set(value).union(*(keys(v) for v in value.values()))
        return set()
    assert not keys(bus) & {"frames_per_second", "per_second", "duration_s"}
    assert bus["frames_per_period"] == len(records) / periods
    assert bus["by_id"]["0x100"] == {"frames": periods, "per_period": 1.0}
    load = bus["load"]
    assert load["bitrate"] == 1_000_000 and load["period_s"] == 1e-3
    assert load["measured_percent"] == measured_load(fl.frames(records), periods)["load_percent"]
    lockstep = schedule_load(database(), lockstep=True)
    assert load["schedule"] == "lockstep (Sync included)"
    assert load["schedule_worst_case_percent"] == lockstep.worst_percent
    assert load["schedule_no_stuffing_percent"] == lockstep.nominal_percent
    assert load["realtime_schedule_worst_case_percent"] == schedule_load(database()).worst_percent
    # the frames really sent lie between the schedule without stuff bits and its worst case
    assert load["schedule_no_stuffing_percent"] < load["measured_percent"] < \
        load["schedule_worst_case_percent"]
    assert "load_fd" not in bus
    # what rrr hil bench prints: each load by its name, no rate per second
    printed = (bench_out.parent / "printed.txt").read_text(encoding="utf-8")
    lines = [ln for ln in printed.splitlines() if ln.startswith("  bus")]
    assert lines[0].startswith(f"  bus: {len(records)} frames (") and "per second" not in printed
    assert f", {bus['frames_per_period']:.2f} per period;" in lines[0]
    assert "frames/s" not in printed
    assert f"measured {load['measured_percent']:.2f} %" in lines[1]
    assert f"lockstep schedule {lockstep.worst_percent:.2f} %" in lines[1]
    assert f"real-time schedule {load['realtime_schedule_worst_case_percent']:.2f} %" in lines[1]


def test_can_log_option_writes_asc(tmp_path: Path) -> None:
    target = tmp_path / "elsewhere" / "bench.asc"
    target.parent.mkdir()
    out = tmp_path / "out"
    assert main(["hil", "bench", "--text", "a", "--out", str(out), "--can-log", str(target),
                 "--no-figures", "-q"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["bus"]["can_log"] == str(target) and "frames.blf" not in s["files"]
    _check_read_back(fl.read_node_log(out / "frames.rrrcan"), target)


def test_realtime_bench_reports_latencies(tmp_path: Path) -> None:
    """Both C nodes in real time for 1 s (SCHED_FIFO, mlockall, affinity where permitted: the
    numbers are the machine's and are not asserted; a benchmark records them). On a loaded
    machine the plant may miss commands long enough to time out: the run then completes with
    EXIT_SAFETY, and its summary says why."""
    out = tmp_path / "rt"
    rc = main(["hil", "bench", "--realtime", "--duration", "1", "--out", str(out),
               "--no-can-log", "-q"])
    s = json.loads((out / "summary.json").read_text())
    fired = s["faults"]["fault_events"] > 0 or s["faults"]["zero_periods"] > 0
    assert rc == (EXIT_SAFETY if fired else 0), (rc, s["faults"])
    # the periods both loops logged: the controller runs the 1001 rows of the reference; the
    # plant ends at its StopCmd and skips the releases a stall made it miss (machine-dependent)
    assert s["mode"] == "realtime" and 0 < s["reference"]["periods"] <= 1001
    assert s["realtime"]["controller"]["rt_periods"] == 1001
    assert {"fig_latency.png", "latency_controller.csv", "latency_plant.csv"} <= set(s["files"])
    for node in ("controller", "plant"):
        r = s["realtime"][node]
        assert 0 <= r["p50_us"] <= r["p99_us"] <= r["p999_us"] <= r["max_us"]
        assert r["rt_latency_p99_us"] == pytest.approx(r["p99_us"], abs=1e-3)
        assert r["rt_periods"] > 0 and "rt_deadline_misses" in r and r["rt_setup"]
        assert "sleep, then spin 100 us" in r["rt_setup"]
    records = fl.read_node_log(out / "frames.rrrcan")
    # no Sync in real time: the controller sends VoltageCmd every period (and the heartbeats)
    tx = records[records["dir"] == 1]
    assert not np.any(tx["id"] == 0x080)
    assert np.count_nonzero(tx["id"] == 0x100) == s["realtime"]["controller"]["rt_periods"]
    # in real time the periods are 1 ms apart: the frames per wall-clock second mean something
    assert s["bus"]["frames_per_second"] > 0 and s["bus"]["duration_s"] > 0
    assert s["bus"]["by_id"]["0x100"]["per_second"] > 0
    load = s["bus"]["load"]
    assert load["schedule"] == "real time"
    assert load["schedule_worst_case_percent"] == load["realtime_schedule_worst_case_percent"]


# ---- rrr hil bench --mcap (jobs/test_mcap.py has the MCAP format's own tests) ----------------


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``rrr hil bench --mcap``: the C controller and plant nodes in lockstep."""
    out = tmp_path_factory.mktemp("mcap_hil") / "hil"
    subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "bench", "--scenario", "ctc",
                    "--no-figures", "--no-can-log", "--mcap", "--out", str(out), "-q"],
                   check=True, capture_output=True)
    return out


def test_the_bench_mcap_holds_its_frames_decoded_signals_and_faults(bench_run) -> None:
    from rrr_robot.hil.dbc.protocol import database
    from rrr_robot.hil.logs.frames import read_node_log
    from rrr_robot.hil.logs.specs import PLANT_LOG, read_log

    got, _ = rosbags_messages(bench_run / "bench.mcap")
    records = read_node_log(bench_run / "frames.rrrcan")
    log = read_log(bench_run / "plant.csv", PLANT_LOG)
    t_ns = np.rint(log.col("t") * 1e9).astype(np.int64)
    assert same(np.array([m[1].position for m in got["/joint_states"]]), log.group("q"))
    assert same(np.array([m[1].data for m in got["/bench/faults"]]), log.col("faults"))
    frames = [m[1] for m in got["/can/frames"]]
    assert len(frames) == records.size
    assert [f.id for f in frames] == (records["id"] & 0x1FFFFFFF).tolist()
    assert [f.dlc for f in frames] == records["dlc"].tolist()
    assert [f.header.frame_id for f in frames] == ["tx" if d else "rx" for d in records["dir"]]
    for f, r in zip(frames, records, strict=True):
        assert bytes(f.data[:f.dlc]) == bytes(r["data"][:r["dlc"]])
    stamps = np.array([m[0] for m in got["/can/frames"]])
    assert np.all(np.isin(stamps, t_ns)) and np.all(np.diff(stamps) >= 0)
    # the period of each frame, from its stamp, is the cycle the controller's Sync frame counts
    sync = got["/can/decoded/Sync"]
    cycle = np.array([m[1].data[0] for m in sync])
    period = np.searchsorted(t_ns, np.array([m[0] for m in sync]))
    assert [d.label for d in sync[0][1].layout.dim] == ["Cycle"]
    assert np.array_equal(cycle, period)
    # decoded values are cantools' of the frames' bytes
    db = database()
    state = got["/can/decoded/JointState1"]
    raw = [r for r in records if (r["id"] & 0x1FFFFFFF) == 0x201]
    msg = db.get_message_by_frame_id(0x201)
    assert [d.label for d in state[0][1].layout.dim] == [s.name for s in msg.signals]
    for k in (0, len(raw) // 2, len(raw) - 1):
        want = msg.decode(bytes(raw[k]["data"][:raw[k]["dlc"]]), decode_choices=False)
        assert state[k][1].data.tolist() == [float(want[s.name]) for s in msg.signals]
