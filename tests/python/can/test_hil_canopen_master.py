"""``rrr hil canopen`` (docs/canopen.md, "A master"): the Python CANopen master on the
unmodified ``canopen`` package, and the C controller node as master (``--master c``,
``rrr_hil_controller --profile canopen``), run the writing task's ctc scenario in lockstep against
``rrr_hil_plant --profile canopen``; it equals the co-simulation with the PDOs' quantisation bit
for bit, its tracking error is within 2x of the DBC bench's, and a drive that is not there is a
clear error."""

from __future__ import annotations

import json
import math
import os
import signal
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rrr_robot.cli.app import main
from rrr_robot.core.outputs import ResultSet
from rrr_robot.errors import HilError
from rrr_robot.hil.canopen import drives
from rrr_robot.hil.canopen.c_master import run_c_master
from rrr_robot.hil.canopen.drives import (
    EXPECTED_MAPPING,
    pdo_quantisation,
    rad_to_inc,
    torque_per_mille,
)
from rrr_robot.hil.canopen.master import MasterRun, run_canopen_master
from rrr_robot.hil.canopen.results import (
    WritingController,
    write_master_results,
    writing_controller,
)
from rrr_robot.hil.dbc.bench import run_c_bench
from rrr_robot.hil.nodes import PERIOD, NodeProcess, start_plant
from rrr_robot.hil.results import bench_result, read_plant_log, tracking
from rrr_robot.sim.cosim import CosimOptions, run_cosim


@pytest.fixture(scope="module")
def wc() -> WritingController:
    """The whole writing task (5.9 s, 5,901 periods: about 2 s over socketcand here)."""
    return writing_controller(None, "ctc")


def test_rounding_is_the_drives() -> None:
    assert rad_to_inc(2 * math.pi, 1 << 20) == 1 << 20
    assert rad_to_inc(-0.5 * 2 * math.pi / (1 << 20), 1 << 20) == -1  # half away from 0
    assert rad_to_inc(1e9, 1 << 20) == 2**31 - 1 and rad_to_inc(math.nan, 1 << 20) == 0
    assert torque_per_mille(10.0, 12.0, 120000) == 1000
    assert torque_per_mille(-0.005, 12.0, 120000) == -1  # -0.5 per mille: away from 0
    assert torque_per_mille(50.0, 12.0, 120000) == 1000  # within the range


def _master(kind: str, w: WritingController, ref: Any, work: Path,
            **kwargs: Any) -> MasterRun:
    """A lockstep run of the master ``kind`` (python: the canopen package's; c: the C node)."""
    if kind == "c":
        return run_c_master(ref.t, ref.q, ref.qd, ref.qdd, w.controller_model,
                            w.controller_values, work, **kwargs)
    return run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd, w.controller_model, w.gains,
                              work, **kwargs)


@pytest.mark.parametrize("kind", ["python", "c"])
def test_writing_task_over_canopen(kind: str, wc: WritingController, tmp_path: Path) -> None:
    ref, n = wc.ref, wc.ref.t.shape[0]
    with ResultSet(tmp_path / "out", kind="hil") as rs:
        mrun = _master(kind, wc, ref, rs.staging)
        summary = write_master_results(rs, wc, mrun, scenario="ctc", figures=False)
    ps = mrun.plant_summary
    # every axis was OPERATION ENABLED in every period (the master checks each statusword),
    # then disabled and stopped by the master: exit 0, no fault
    assert ps["exit"] == 0 and ps["drive_faults"] == 0, ps
    assert [d["node_id"] for d in ps["drives"]] == [1, 2, 3]
    assert all(d["rpdo_timeouts"] == 0 and d["sdo_aborts"] == 0 for d in ps["drives"])
    assert [d.rated_torque_mNm for d in mrun.drives] == [120000, 110000, 47000]
    assert all(d.mapping == EXPECTED_MAPPING for d in mrun.drives)
    out = tmp_path / "out"
    saved = json.loads((out / "summary.json").read_text())
    assert saved["side"] == "canopen" and saved["reference"]["periods"] == n
    assert {"plant.csv", "controller.csv", "summary.json", "frames.rrrcan", "frames.blf"} <= {
        p.name for p in out.iterdir()}
    by_id = saved["bus"]["by_id"]  # the plant's frame log: one SYNC and 3 RPDOs per period
    assert by_id["0x080"]["frames"] == n and by_id["0x201"]["frames"] == n
    plant_log = read_plant_log(out / "plant.csv")
    assert plant_log.shape[0] == n  # the initial row and one per stepping SYNC
    assert np.abs(mrun.torque_pm).max() > 10  # the law did command torque
    if kind == "c":  # the C master's own account: one SYNC and one decoded state per period
        cs = mrun.run.controller_summary
        assert cs["exit"] == 0 and cs["syncs"] == n and cs["states"] == n, cs
        assert cs["tpdo_bad_length"] == 0 and cs["ctc_failed"] == 0, cs
        assert cs["target_torque_per_mille_max_abs"] == np.abs(mrun.torque_pm).max(
            axis=0).tolist()

    # the co-simulation with the PDOs' quantisation: bit for bit
    kt = [float(v) for v in wc.controller_model.kt]
    measure, actuate = pdo_quantisation(kt, [float(v) for v in wc.model.kt],
                                        [d.rated_torque_mNm for d in mrun.drives])
    cosim = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                      CosimOptions(step=PERIOD, controller_values=wc.controller_values,
                                   measure=measure, actuate=actuate))
    bench = bench_result(ref, mrun.run, plant_log)
    assert np.array_equal(bench.q, cosim.q) and np.array_equal(bench.qd, cosim.qd)
    assert np.array_equal(mrun.run.u, cosim.u)
    assert np.array_equal(bench.tip, cosim.tip)

    # within 2x of the DBC bench on the same reference
    (tmp_path / "dbc").mkdir()
    dbc = run_c_bench(ref.t, ref.q, ref.qd, ref.qdd, workdir=tmp_path / "dbc",
                      controller_values=wc.controller_values)
    dbc_res = bench_result(ref, dbc, read_plant_log(tmp_path / "dbc" / "plant.csv"))
    over, base = tracking(bench), tracking(dbc_res)
    assert math.isfinite(over["tip_error_max"]) and math.isfinite(over["tip_error_rms"])
    assert over["tip_error_max"] <= 2 * base["tip_error_max"], (over, base)
    assert over["tip_error_rms"] <= 2 * base["tip_error_rms"], (over, base)
    assert summary["bench"]["tip_error_max"] == over["tip_error_max"]
    print(f"tip error max over CANopen {over['tip_error_max']:.6e} m, DBC bench "
          f"{base['tip_error_max']:.6e} m; rms {over['tip_error_rms']:.6e} against "
          f"{base['tip_error_rms']:.6e} m; master wall time {mrun.run.wall_time:.2f} s")


@pytest.mark.parametrize(("timeout", "within"), [(None, ("5 s", "5000 ms")),
                                                 ("1", ("1 s", "1000 ms"))])
@pytest.mark.parametrize("kind", ["python", "c"])
def test_a_missing_drive_is_one_line_naming_it(kind: str, timeout: str | None,
                                              within: tuple[str, str], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """``--node-ids 1,2,9``: the master's boot-up wait (``--timeout``, 5 s by default) ends
    before the plant's idle timeout (drives.plant_idle_ms), so the one line names drive 9, and no
    traceback of python-can's receive thread (which cannot read the server's "< error idle
    timeout >") comes before it (before: the two 5 s timeouts raced, issue 38)."""
    argv = ["hil", "canopen", "--master", kind, "--node-ids", "1,2,9", "--duration", "1",
            "--no-figures", "--out", str(tmp_path / "out")]
    rc = main(argv + (["--timeout", timeout] if timeout else []))
    err = capsys.readouterr().err
    lines = [x for x in err.strip().splitlines() if not x.startswith(("INFO ", "DEBUG "))]
    sent = (f"drive(s) 9 sent no boot-up within {within[0] if kind == 'python' else within[1]}"
            " after NMT reset node")
    assert rc == 2 and len(lines) == 1 and sent in lines[0], err
    assert "Traceback" not in err and "Exception in thread" not in err, err
    assert not (tmp_path / "out" / "summary.json").exists()


def test_library_errors(wc: WritingController, tmp_path: Path) -> None:
    ref = wc.ref
    with pytest.raises(HilError, match=r"drive\(s\) 5, 6 sent no boot-up"):
        run_canopen_master(ref.t[:10], ref.q[:10], ref.qd[:10], ref.qdd[:10],
                           wc.controller_model, wc.gains, tmp_path, node_ids=(1, 5, 6),
                           timeout=1.0)


# python-can's receive thread (canopen's Notifier) ends with the broken socket: its exception is
# kept by the master (nodes.quiet_bus_threads), never an unhandled one (pytest's warning)
@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_plant_killed_mid_run_is_named(wc: WritingController, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The plant node killed at period 1000: the master stops with an error that says so
    (not a hang, not a traceback of the bus's thread)."""
    started: list[NodeProcess] = []

    def start(**kwargs: Any) -> NodeProcess:
        node = start_plant(**kwargs)
        started.append(node)
        return node

    def kill_at(k: int, n: int) -> None:
        if k >= 1000 and started and started[0].running():
            os.kill(started[0].pid, signal.SIGKILL)

    monkeypatch.setattr(drives, "start_plant", start)
    ref = wc.ref
    # the kill is seen either while the master waits for the TPDOs or when it sends
    with pytest.raises(HilError, match=r"SYNC \d+: .*plant node (ended|was killed).*SIGKILL|"
                       r"plant node ended .* SYNC \d+: was killed by SIGKILL"):
        run_canopen_master(ref.t, ref.q, ref.qd, ref.qdd, wc.controller_model, wc.gains,
                           tmp_path, timeout=5.0, progress=kill_at)


@pytest.mark.parametrize("kind", ["python", "c"])
def test_mismatch_scenario_equals_its_quantised_cosim(kind: str, tmp_path: Path) -> None:
    """The mismatch scenario: the controller's k_t (its model's) differs from the plant's by
    10 %, so the master's target torque k_t u and the plant's u = tau / k_t do not cancel; the
    run still equals the co-simulation with the same quantisation, bit for bit (1 s of it)."""
    from rrr_robot.hil.results import extend_reference

    w = writing_controller(None, "mismatch")
    assert not np.array_equal(w.controller_model.kt, w.model.kt)
    ref = extend_reference(w.ref, 1.0)
    mrun = _master(kind, w, ref, tmp_path)
    measure, actuate = pdo_quantisation([float(v) for v in w.controller_model.kt],
                                        [float(v) for v in w.model.kt],
                                        [d.rated_torque_mNm for d in mrun.drives])
    cosim = run_cosim(ref.t, ref.q, ref.qd, ref.qdd, ref.x,
                      CosimOptions(step=PERIOD, controller_values=w.controller_values,
                                   measure=measure, actuate=actuate))
    bench = bench_result(ref, mrun.run, read_plant_log(tmp_path / "plant.csv"))
    assert np.array_equal(bench.q, cosim.q) and np.array_equal(mrun.run.u, cosim.u)
    assert np.abs(bench.q - ref.q).max() > 1e-5  # the mismatch shows in the tracking
