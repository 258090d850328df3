"""Hostile sweep inputs (issue 21: N4, N5, N6, N7, N8, N16, N18, N20): a key given twice in two
TOML spellings, resumed folders whose parts are not this sweep's exactly, a second sweep into a
folder that one is using, and peers that are no Dask scheduler; each is one line, exit 2, and
leaves the folder as it was."""

from __future__ import annotations

import http.server
import itertools
import json
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import rrr_robot as rr
from rrr_robot.cli import main
from rrr_robot.core.outputs import folder_lock
from rrr_robot.sweep.job import SweepJob, _write_description, make_plan
from rrr_robot.sweep.results import RESULTS, schema, write_part
from rrr_robot.sweep.runs import METRICS
from rrr_robot.sweep.sampling import design
from rrr_robot.sweep.spec import read_spec

HEAD = '[sweep]\nbase = "ctc"\nsamples = 6\nseed = 3\n'
DIST = "{ uniform = [0.0, 0.1] }"
#: One key, mismatch.kt_rel, in each TOML spelling of a [vary] entry.
SPELLINGS = {
    "quoted": f'[vary]\n"mismatch.kt_rel" = {DIST}\n',
    "dotted": f"[vary]\nmismatch.kt_rel = {DIST}\n",
    "table": f"[vary.mismatch]\nkt_rel = {DIST}\n",
    "inline": f"[vary]\nmismatch = {{ kt_rel = {DIST} }}\n",
}


def _spec(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _merge(a: str, b: str) -> str:
    """Two [vary] fragments as one document (one [vary] header, tables last)."""
    lines: list[str] = []
    tables: list[str] = []
    for frag in (a, b):
        head, _, body = frag.partition("\n")
        (lines if head == "[vary]" else tables).append(body if head == "[vary]" else frag)
    return HEAD + "[vary]\n" + "".join(lines) + "".join(tables)


@pytest.mark.parametrize("one", list(SPELLINGS))
def test_each_spelling_alone_is_the_key(tmp_path: Path, one: str) -> None:
    spec = read_spec(_spec(tmp_path, HEAD + SPELLINGS[one]))
    assert [v.key for v in spec.vary] == ["mismatch.kt_rel"]


@pytest.mark.parametrize(("a", "b"), list(itertools.permutations(SPELLINGS, 2)))
def test_a_key_given_twice_in_any_two_spellings_is_refused(tmp_path: Path, a: str, b: str,
                                                           capsys: pytest.CaptureFixture[str],
                                                           ) -> None:
    path = _spec(tmp_path, _merge(SPELLINGS[a], SPELLINGS[b]))
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--engine", "native", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0], err
    # TOML itself refuses some pairs (a table defined twice); ours name both spellings
    assert "given twice" in err[0] or "TOML" in err[0] or "not valid" in err[0], err
    assert not out.exists()


# ---- resumed folders -------------------------------------------------------------------------

SPEC = HEAD + f'[vary]\n"mismatch.kt_rel" = {DIST}\n'


@pytest.fixture
def folder(tmp_path: Path) -> tuple[Path, Path, list[dict[str, Any]]]:
    """A sweep folder as rrr sweep leaves it after runs 0-2 of 6 (its description and one
    part), and the rows of every run."""
    spec_path = _spec(tmp_path, SPEC)
    spec = read_spec(spec_path)
    plan = make_plan(spec, "native")
    out = tmp_path / "out"
    out.mkdir()
    _write_description(out, SweepJob(spec=spec_path, out=out, engine="native"), plan, spec)
    rows = [{"run": r.run, "seed": r.seed, "status": "ok", "error": None, **dict(r.values),
             **{m: 0.001 for m in METRICS}} for r in design(spec)]
    write_part(out / RESULTS, rows[:3], schema(spec.vary))
    return spec_path, out, rows


def _write_table(path: Path, rows: list[dict[str, Any]], change: Callable[[Any], Any]) -> None:
    """A part of the rows with the sweep's own schema, then ``change``d."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrow_schema = schema(read_spec(_spec(path.parents[2], SPEC)).vary)
    pq.write_table(change(pa.Table.from_pylist(rows, schema=arrow_schema)), path)


def _string_run(t: Any) -> Any:
    import pyarrow as pa

    return t.set_column(0, "run", pa.array([str(r) for r in t.column("run").to_pylist()]))


def _with(column: str, value: Any) -> Callable[[Any], Any]:
    def change(t: Any) -> Any:
        import pyarrow as pa

        i = t.schema.get_field_index(column)
        field = t.schema.field(i).with_nullable(True)
        return t.set_column(i, field, pa.array([value] * t.num_rows, field.type))
    return change


def _typed(t: Any) -> Any:
    return t


BAD_PARTS: dict[str, tuple[str, Callable[[Path, list[dict[str, Any]]], None], str]] = {
    "N5 run outside the sweep": (
        "part-0000008-1.parquet",
        lambda p, rows: _write_table(p, [rows[3] | {"run": 8}], _typed),
        "run 8 is not a run of this sweep (runs 0 to 5)"),
    "N6 run column of strings": (
        "part-0000003-1.parquet", lambda p, rows: _write_table(p, [rows[3]], _string_run),
        "column run holds string, this sweep's holds int64"),
    "N16 unknown status": (
        "part-0000003-1.parquet",
        lambda p, rows: _write_table(p, [rows[3] | {"status": "great"}], _typed),
        "status 'great' is none of ok, saturated, diverged, invalid, failed"),
    "another sweep's seed": (
        "part-0000003-1.parquet",
        lambda p, rows: _write_table(p, [rows[3] | {"seed": 12345}], _typed),
        "run 3 has the seed of another sweep"),
    "name and runs differ": (
        "part-0000004-2.parquet",
        lambda p, rows: _write_table(p, [rows[3]], _typed),
        "holds 1 runs from run 3, its name says otherwise"),
    "empty status": (
        "part-0000003-1.parquet", lambda p, rows: _write_table(p, [rows[3]],
                                                               _with("status", None)),
        "column status has empty values"),
    "N18 a part that is a folder": (
        "part-0000003-1.parquet", lambda p, rows: p.mkdir(),
        "is not a file: a part of the results must be a Parquet file"),
    "a file that is no part": (
        "notes.txt", lambda p, rows: p.write_text("mine"),
        "not a part of this sweep's results"),
    "not Parquet": (
        "part-0000003-1.parquet", lambda p, rows: p.write_bytes(b"PAR1 no"),
        "not a Parquet file of this sweep"),
}


def _listing(root: Path) -> list[tuple[str, int]]:
    return sorted((p.relative_to(root).as_posix(), p.stat().st_size if p.is_file() else -1)
                  for p in root.rglob("*"))


@pytest.mark.parametrize("case", list(BAD_PARTS))
def test_resume_accepts_only_this_sweeps_parts(folder: tuple[Path, Path, list[dict[str, Any]]],
                                               case: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    spec, out, rows = folder
    name, make, message = BAD_PARTS[case]
    make(out / RESULTS / name, rows)
    before = _listing(out)
    assert main(["sweep", str(spec), "--out", str(out), "--engine", "native", "--resume",
                 "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert name in err[0]  # names the part
    assert _listing(out) == before


def test_results_that_are_a_file_are_named(folder: tuple[Path, Path, list[dict[str, Any]]],
                                           capsys: pytest.CaptureFixture[str]) -> None:
    import shutil

    spec, out, _ = folder
    shutil.rmtree(out / RESULTS)
    (out / RESULTS).write_text("not a folder")
    assert main(["sweep", str(spec), "--out", str(out), "--engine", "native", "--resume",
                 "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rrr: error: {out / RESULTS} is not a folder: it must be the dataset folder "
                   "of this sweep's results; move it away or choose another --out"], err


def test_a_complete_folder_resumes_without_a_cluster(
        folder: tuple[Path, Path, list[dict[str, Any]]],
        capsys: pytest.CaptureFixture[str]) -> None:
    """The parts of runs 3-5 added as rrr sweep writes them: --resume only summarises."""
    spec, out, rows = folder
    write_part(out / RESULTS, rows[3:], schema(read_spec(spec).vary))
    assert main(["sweep", str(spec), "--out", str(out), "--engine", "native", "--resume", "-q",
                 "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 6 and summary["status"]["ok"] == 6
    assert summary["this_invocation"]["runs"] == 0
    assert not list(out.glob(".rrr-lock-*"))


# ---- one sweep per folder ----------------------------------------------------------------------


def test_a_folder_in_use_by_a_sweep_is_refused_at_once(
        folder: tuple[Path, Path, list[dict[str, Any]]],
        capsys: pytest.CaptureFixture[str]) -> None:
    spec, out, _ = folder
    before = _listing(out)
    with folder_lock(out, "sweep"):  # held by this process: a sweep that waited would hang
        assert main(["sweep", str(spec), "--out", str(out), "--engine", "native", "--resume",
                     "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rrr: error: {out} is in use by another rrr sweep (process "
                   f"{__import__('os').getpid()}): wait for it to end or choose another --out"]
    assert _listing(out) == before


def test_two_sweeps_started_at_once_into_one_new_folder(tmp_path: Path) -> None:
    """N20: one runs the sweep, the other is refused at once; the folder holds one sweep."""
    import pandas as pd

    spec = _spec(tmp_path, SPEC.replace("samples = 6", "samples = 4"))
    out = tmp_path / "new" / "out"
    cmds = [[sys.executable, "-m", "rrr_robot", "sweep", str(spec), "--out", str(out),
             "--engine", "native", "--workers", "1", "--batch", str(b), "-q", "--no-figures"]
            for b in (1, 3)]
    procs = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for c in cmds]
    results = [p.communicate(timeout=300) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes == [0, 2], results
    refused = next(err for p, (_, err) in zip(procs, results, strict=True) if p.returncode)
    errors = [x for x in refused.splitlines() if not x.startswith("INFO ")]  # its log lines
    assert len(errors) == 1 and "Traceback" not in refused, refused
    assert "is in use by another rrr sweep" in errors[0] or "already holds a sweep" in errors[0]
    assert sorted(pd.read_parquet(out / RESULTS)["run"]) == [0, 1, 2, 3]
    assert json.loads((out / "summary.json").read_text())["runs"] == 4


# ---- peers that are no Dask scheduler ------------------------------------------------------------


@pytest.fixture
def silent_peer() -> Iterator[str]:
    """A TCP server that accepts connections and never sends a byte."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    for s in held:
        s.close()
    server.close()


@pytest.fixture
def http_peer() -> Iterator[str]:
    """An HTTP server (what --scheduler reaches when given a dashboard's port)."""
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


@pytest.mark.parametrize("peer", ["silent_peer", "http_peer"])
def test_a_peer_that_is_no_dask_scheduler_is_one_line(peer: str, tmp_path: Path,
                                                      request: pytest.FixtureRequest,
                                                      capsys: pytest.CaptureFixture[str],
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from rrr_robot.sweep import execution

    monkeypatch.setattr(execution, "HANDSHAKE_TIMEOUT", 1.0)
    address = request.getfixturevalue(peer)
    out = tmp_path / "out"
    assert main(["sweep", str(_spec(tmp_path, SPEC)), "--out", str(out), "--scheduler",
                 address, "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rrr: error: the Dask scheduler at {address} does not speak Dask: no "
                   "handshake within 1 s (is it a Dask scheduler, e.g. not its dashboard's "
                   "HTTP port?)"], err
    assert not out.exists()


def test_probe_refuses_a_peer_that_claims_a_huge_message() -> None:
    """What a scheduler's comm would allocate (N8: 3.07 EiB from "HTTP/1.1") is refused."""
    from rrr_robot.sweep.execution import probe_scheduler

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def answer() -> None:
        conn, _ = server.accept()
        conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")
        time.sleep(0.5)
        conn.close()

    threading.Thread(target=answer, daemon=True).start()
    try:
        with pytest.raises(rr.BadInputError, match=r"does not speak Dask: its first message "
                           r"claims \d+ bytes"):
            probe_scheduler(f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=5)
    finally:
        server.close()
