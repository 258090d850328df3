"""``rrr sweep`` on real Dask clusters: a scheduler and two workers started as processes on
127.0.0.1 (``dask scheduler`` / ``dask worker``, as on separate machines), and a local cluster
of one worker process. A sweep with failing and saturated runs records them; a sweep killed
while it runs completes with --resume without repeating a run; the same spec gives the same
values on one worker and on two; the run with no variation is ``rrr writing --scenario <base>``
bit for bit (native engine and FMUs)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from rrr_robot.cli import main
from rrr_robot.writing.job import WritingJob, run_writing

DASK = Path(sys.executable).with_name("dask")
#: A random sweep with scalar, per-element and listed values (the resume and worker-count tests)
RANDOM_SPEC = """[sweep]
base = "mismatch"
samples = 48
seed = 7
[vary]
"mismatch.p_rel" = { uniform = [-0.1, 0.1] }
"mismatch.kt_rel" = { normal = [0.0, 0.05] }
"mismatch.f_rel" = { normal = [0.0, 0.2], per_element = true }
"gains.kp" = { values = [[20.0, 50.0, 20.0], [40.0, 100.0, 40.0]] }
"""
MOTION = ["tip_error_max", "tip_error_rms", *(f"rms_u_{k}[{i}]" for k in "nc" for i in (1, 2, 3))]


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=15)


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The address of a Dask scheduler with two single-thread workers, each its own process
    group (stopped, and killed if need be, at the end)."""
    from distributed import Client

    folder = tmp_path_factory.mktemp("dask")
    file = folder / "scheduler.json"
    procs: list[subprocess.Popen[bytes]] = []
    log = (folder / "dask.log").open("wb")
    try:
        procs.append(subprocess.Popen(
            [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(file)], stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True))
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            assert procs[0].poll() is None, (folder / "dask.log").read_text()
            time.sleep(0.1)
        time.sleep(0.2)  # the file is written whole, but give it the moment
        address = json.loads(file.read_text())["address"]
        for _ in range(2):
            procs.append(subprocess.Popen(
                [str(DASK), "worker", "--scheduler-file", str(file), "--nthreads", "1",
                 "--nworkers", "1", "--no-dashboard", "--host", "127.0.0.1",
                 "--local-directory", str(folder)], stdout=log, stderr=subprocess.STDOUT,
                start_new_session=True))
        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        assert address.startswith("tcp://127.0.0.1:")
        yield address
    finally:
        _stop(procs)
        log.close()


def _sweep(spec: Path, out: Path, *args: str) -> int:
    return main(["sweep", str(spec), "--out", str(out), "--engine", "native", "-q", *args])


def _results(out: Path) -> pd.DataFrame:
    return pd.read_parquet(out / "results.parquet").sort_values("run").reset_index(drop=True)


def test_a_sweep_through_a_running_scheduler_records_failing_and_saturated_runs(
        scheduler: str, tmp_path: Path) -> None:
    from distributed import Client

    spec = tmp_path / "grid.toml"
    spec.write_text('[sweep]\nbase = "ctc"\nmethod = "grid"\n[vary]\n'
                    '"mismatch.p_rel" = { values = [0.0, 0.1, 5.0] }\n'
                    '"mismatch.u_max_rel" = { values = [0.0, -0.95] }\n')
    out = tmp_path / "out"
    assert _sweep(spec, out, "--scheduler", scheduler) == 0
    df = _results(out)
    assert list(df.columns) == [
        "run", "seed", "status", "error", "mismatch.p_rel", "mismatch.u_max_rel",
        "tip_error_max", "tip_error_rms", *(f"rms_u_n[{i}]" for i in (1, 2, 3)),
        *(f"rms_u_c[{i}]" for i in (1, 2, 3)), *(f"u_peak[{i}]" for i in (1, 2, 3)),
        *(f"saturated_fraction[{i}]" for i in (1, 2, 3)), "saturated_fraction", "wall_time"]
    assert df["run"].tolist() == list(range(6))
    assert df["status"].tolist() == ["ok", "saturated", "ok", "saturated", "invalid", "invalid"]
    invalid = df[df["status"] == "invalid"]
    assert invalid["error"].str.contains("RRR_NOT_POSITIVE_DEFINITE").all()
    assert invalid["tip_error_max"].isna().all() and df.loc[[0, 2], "error"].isna().all()
    saturated = df[df["status"] == "saturated"]
    assert (saturated["saturated_fraction"] > 0).all()
    assert saturated["error"].str.fullmatch(
        r"u\[1\], u\[2\], u\[3\] reached \+-0\.5 V \(the controller's model's u_max\) on "
        r"[0-9.]+ % of the samples").all(), saturated["error"].tolist()
    assert (df.loc[[0, 2], "saturated_fraction"] == 0).all()
    assert (df["wall_time"] > 0).all()
    assert (out / "spec.toml").read_bytes() == spec.read_bytes()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == {"ok": 2, "saturated": 2, "diverged": 0, "invalid": 2,
                                 "failed": 0}
    assert summary["sensitivity"]["ranking"][0]["input"] == "mismatch.u_max_rel"
    for name in summary["files"]:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" or name == "summary.json"
    assert len(summary["files"]) == 4
    # the runs ran on the scheduler's workers: each keeps the references it planned, under the
    # sweep's fingerprint
    fingerprint = json.loads((out / "sweep.json").read_text())["fingerprint"]
    with Client(scheduler, timeout=30) as client:
        cached = client.run(lambda: [k[0] for k in __import__(
            "rrr_robot.sweep.runs", fromlist=["_references"])._references])
    assert len(cached) == 2 and any(fingerprint in keys for keys in cached.values())


def test_the_run_with_no_variation_is_rrr_writing_bit_for_bit(scheduler: str,
                                                              tmp_path: Path) -> None:
    for engine, base, samples in (("native", "mismatch", 2), ("fmpy", "ctc", 1)):
        spec = tmp_path / f"{engine}.toml"
        spec.write_text(f'[sweep]\nbase = "{base}"\nsamples = {samples}\n')
        out = tmp_path / engine
        assert main(["sweep", str(spec), "--out", str(out), "--engine", engine, "-q",
                     "--scheduler", scheduler, "--no-figures"]) == 0
        df = _results(out)
        writing = run_writing(WritingJob(out=tmp_path / f"writing-{engine}", scenarios=[base],
                                         engine=engine, figures=False))["scenarios"][base]
        assert len(df) == samples and (df["status"] == "ok").all()
        for _, row in df.iterrows():
            assert row["tip_error_max"] == writing["tip_error_max"]
            assert row["tip_error_rms"] == writing["tip_error_rms"]
            for i in (1, 2, 3):
                assert row[f"rms_u_n[{i}]"] == writing["rms_u_n"][i - 1]
                assert row[f"rms_u_c[{i}]"] == writing["rms_u_c"][i - 1]
        assert json.loads((out / "summary.json").read_text())["files"] == ["summary.json"]


def _parts(out: Path) -> dict[str, tuple[bytes, int]]:
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted((out / "results.parquet").glob("part-*.parquet"))}


@pytest.fixture(scope="module")
def resumed(scheduler: str, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """RANDOM_SPEC run by a client killed (SIGKILL) while its runs go on, then completed with
    --resume: (the spec, the output folder); the test below checks how."""
    folder = tmp_path_factory.mktemp("resume")
    spec = folder / "spec.toml"
    spec.write_text(RANDOM_SPEC)
    out = folder / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "rrr_robot", "sweep", str(spec), "--out", str(out), "--engine",
         "native", "--scheduler", scheduler, "--batch", "2", "-q"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(_parts(out)) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.kill()
    proc.wait(timeout=30)
    before = _parts(out)
    assert 3 <= len(before) < 24 and proc.returncode == -signal.SIGKILL, (
        len(before), proc.returncode, proc.stderr.read() if proc.stderr else "")
    assert not (out / "summary.json").exists()  # an interrupted sweep is not complete
    assert _sweep(spec, out, "--scheduler", scheduler, "--resume", "--batch", "2",
                  "--no-figures") == 0
    after = _parts(out)
    assert all(after[name] == data for name, data in before.items())  # not rewritten
    old = set(pd.concat([pd.read_parquet(out / "results.parquet" / n) for n in before])["run"])
    new = [r for n in set(after) - set(before)
           for r in pd.read_parquet(out / "results.parquet" / n)["run"]]
    assert old.isdisjoint(new) and len(new) == len(set(new)) == 48 - len(old)
    return spec, out


def test_resume_after_a_killed_sweep_completes_it_without_repeating_runs(
        resumed: tuple[Path, Path], scheduler: str, capsys: pytest.CaptureFixture[str]) -> None:
    spec, out = resumed
    df = _results(out)
    assert df["run"].tolist() == list(range(48))
    assert json.loads((out / "summary.json").read_text())["runs"] == 48
    assert set(df["status"]) <= {"ok", "saturated", "invalid"} and (df["status"] == "ok").any()
    capsys.readouterr()
    # a folder holding a sweep: refused without --resume, and with another spec
    assert _sweep(spec, out, "--scheduler", scheduler) == 2
    assert "already holds a sweep" in capsys.readouterr().err
    other = spec.with_name("other.toml")
    other.write_text(RANDOM_SPEC.replace("seed = 7", "seed = 8"))
    assert _sweep(other, out, "--scheduler", scheduler, "--resume") == 2
    err = capsys.readouterr().err
    assert "cannot resume the sweep" in err and "the spec's seed differs" in err, err
    assert _parts(out).keys() == {p.name for p in (out / "results.parquet").glob("part-*")}


def test_the_same_spec_gives_the_same_values_on_one_worker_and_on_two(
        resumed: tuple[Path, Path], tmp_path: Path) -> None:
    spec, two = resumed  # two workers (and an interruption)
    one = tmp_path / "one"
    assert _sweep(spec, one, "--workers", "1", "--no-figures") == 0  # a local cluster
    a, b = _results(one), _results(two)
    assert a.drop(columns="wall_time").equals(b.drop(columns="wall_time"))
    assert a[MOTION].notna().any().all()
