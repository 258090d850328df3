"""Hostile zip archives (issue 21, N9, N10, N11, N14): the one reader (rrr_robot.core.archives)
refuses names that leave the extraction folder, links, duplicates, sizes and ratios beyond its
bounds and data that does not match its headers, before anything is written; ``rrr run-ssp``
checks an archive's parameter values and step count before any tool runs it, runs only what the
SSD references, and leaves no temporary folder behind (also when it is killed by SIGTERM)."""

from __future__ import annotations

import io
import os
import re
import signal
import stat
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rrr_robot.cli import main
from rrr_robot.core.archives import (
    CheckedZip,
    Limits,
    check_entry_name,
    extract_to_temp,
    extracted,
)
from rrr_robot.errors import ArchiveError, BadInputError
from rrr_robot.ssp.archive import MAX_STEPS, read_ssp
from rrr_robot.ssp.export import SspJob, export_ssp
from rrr_robot.ssp.run import CHILD_STOP_GRACE
from rrr_robot.ssp.table import TABLE_COLUMNS

TOOLS = ("libcosim", "fmpy")


# ---- the reader -------------------------------------------------------------------------------


def _zip(path: Path, entries: list[tuple[str | zipfile.ZipInfo, bytes]],
         method: int = zipfile.ZIP_DEFLATED) -> Path:
    with zipfile.ZipFile(path, "w", method) as z, _quiet():
        for name, data in entries:
            z.writestr(name, data)
    return path


class _quiet:
    """zipfile warns about duplicate names; the tests write them on purpose."""

    def __enter__(self) -> None:
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("ignore")

    def __exit__(self, *exc: Any) -> None:
        self._ctx.__exit__(*exc)


def _link(name: str, target: bytes) -> zipfile.ZipInfo:
    info = zipfile.ZipInfo(name)
    info.create_system = 3
    info.external_attr = (stat.S_IFLNK | 0o777) << 16
    return info


def _set_size(path: Path, name: str, size: int) -> None:
    """Overwrite the uncompressed size of ``name`` in the central directory (a lying header)."""
    data = bytearray(path.read_bytes())
    pos = 0
    while True:
        pos = data.index(b"PK\x01\x02", pos)
        n = struct.unpack_from("<H", data, pos + 28)[0]
        if data[pos + 46:pos + 46 + n].decode() == name:
            struct.pack_into("<I", data, pos + 24, size)
            break
        pos += 4
    path.write_bytes(bytes(data))


NAMES_REFUSED = {
    "parent": ("../../../../x", "'..'"),
    "parent inside": ("a/../../x", "'..'"),
    "absolute": ("/etc/x", "absolute path"),
    "drive": ("C:/x", "drive letter"),
    "backslash": ("a\\..\\x", "backslash"),
    "empty part": ("a//x", "''"),
    "dot": ("./x", "'.'"),
    "control": ("a\nb", "control character"),
    "too long": ("a/" * 600 + "x", "more than 1024"),
}


@pytest.mark.parametrize("case", list(NAMES_REFUSED))
def test_entry_names_that_leave_the_folder_are_refused(tmp_path: Path, case: str) -> None:
    name, message = NAMES_REFUSED[case]
    arch = _zip(tmp_path / "a.zip", [("ok.txt", b"1"), (name, b"2")])
    before = set(tmp_path.parent.iterdir())
    with pytest.raises(ArchiveError, match=re.escape(message)):
        extract_to_temp(arch)
    assert set(tmp_path.parent.iterdir()) == before


def _junk(path: Path) -> Path:
    path.write_bytes(b"PK but no zip")
    return path


KINDS_REFUSED: dict[str, tuple[Callable[[Path], Path], str]] = {
    "symlink": (lambda d: _zip(d / "a.zip", [(_link("x", b"/etc/passwd"), b"/etc/passwd")]),
                "symbolic link"),
    "duplicate": (lambda d: _zip(d / "a.zip", [("x", b"1"), ("x", b"2")]), "the same name"),
    "case duplicate": (lambda d: _zip(d / "a.zip", [("a/X", b"1"), ("a/x", b"2")]),
                       "differs only in case"),
    "file and folder": (lambda d: _zip(d / "a.zip", [("a", b"1"), ("a/b", b"2")]),
                        "is a file and a folder"),
    "bzip2": (lambda d: _zip(d / "a.zip", [("x", b"1" * 100)], zipfile.ZIP_BZIP2),
              "compression method"),
    "not a zip": (lambda d: _junk(d / "a.zip"), "not an archive"),
}


@pytest.mark.parametrize("case", list(KINDS_REFUSED))
def test_links_duplicates_and_odd_entries_are_refused(tmp_path: Path, case: str) -> None:
    make, message = KINDS_REFUSED[case]
    with pytest.raises(ArchiveError, match=message):
        CheckedZip(make(tmp_path))


def test_sizes_and_ratios_are_bounded_from_the_directory(tmp_path: Path) -> None:
    bomb = _zip(tmp_path / "bomb.zip", [("zeros", bytes(8 << 20))])  # 8 MiB -> ~8 kB
    assert bomb.stat().st_size < 100_000
    with pytest.raises(ArchiveError, match=r"entry 'zeros': 8388608 bytes from \d+ compressed "
                       r"\(ratio \d+\): at most 200 \(a zip bomb\?\)"):
        CheckedZip(bomb)
    many = _zip(tmp_path / "many.zip", [(f"f{i}", b"x") for i in range(5)])
    with pytest.raises(ArchiveError, match="5 entries: at most 4"):
        CheckedZip(many, limits=Limits(max_entries=4))
    big = _zip(tmp_path / "big.zip", [("f", b"abcd")])
    with pytest.raises(ArchiveError, match="4 bytes uncompressed: at most 3 per entry"):
        CheckedZip(big, limits=Limits(max_entry_bytes=3))
    with pytest.raises(ArchiveError, match="5 bytes uncompressed in all: at most 4"):
        CheckedZip(many, limits=Limits(max_total_bytes=4))


@pytest.mark.parametrize("declared", [100, 1_000_000])
def test_headers_that_lie_are_caught_while_streaming(tmp_path: Path, declared: int) -> None:
    arch = _zip(tmp_path / "a.zip", [("x", bytes(range(256)) * 2000)])  # 512 kB
    _set_size(arch, "x", declared)
    with CheckedZip(arch) as z, pytest.raises(ArchiveError, match="entry 'x'"):
        z.copy("x", tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_extraction_folder_goes_on_success_error_and_interrupt(tmp_path: Path) -> None:
    arch = _zip(tmp_path / "a.zip", [("a/b/c.txt", b"data"), ("d.txt", b"more")])
    with extracted(arch) as folder:
        assert (folder / "a" / "b" / "c.txt").read_bytes() == b"data"
    assert not folder.exists()
    for exc in (RuntimeError, KeyboardInterrupt):
        with pytest.raises(exc), extracted(arch) as folder:
            raise exc
        assert not folder.exists()
    broken = _zip(tmp_path / "b.zip", [("a", b"1" * 5000), ("b", b"2" * 5000)])
    _set_size(broken, "b", 10)
    made: list[str] = []
    real = tempfile.mkdtemp

    def spy(**kw: Any) -> str:
        made.append(real(**kw))
        return made[-1]

    tempfile.mkdtemp = spy  # type: ignore[assignment]
    try:
        with pytest.raises(ArchiveError):
            extract_to_temp(broken)
    finally:
        tempfile.mkdtemp = real
    assert made and not Path(made[0]).exists()


_PART = st.sampled_from(["a", "B", "..", ".", "", "c:", "d\\e", "f.fmu", "\x00", "\u00e9"])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(parts=st.lists(_PART, min_size=1, max_size=5), lead=st.booleans())
def test_a_name_passes_only_when_it_stays_inside(parts: list[str], lead: bool) -> None:
    name = ("/" if lead else "") + "/".join(parts)
    body = name[:-1] if name.endswith("/") else name  # a folder's name ends with /
    safe = (not lead and bool(body) and all(p not in ("", ".", "..") for p in body.split("/"))
            and "\\" not in name and ":" not in name and "\x00" not in name)
    try:
        check_entry_name(name)
        accepted = True
    except ArchiveError:
        accepted = False
    assert accepted == safe
    if accepted:
        root = Path("/x/root")
        assert Path(os.path.normpath(root.joinpath(*name.split("/")))).is_relative_to(root)


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(names=st.lists(st.lists(_PART, min_size=1, max_size=3).map("/".join).filter(
    lambda n: bool(n) and "\x00" not in n),
                      min_size=1, max_size=4))
def test_random_archives_extract_inside_or_not_at_all(tmp_path: Path, names: list[str]) -> None:
    base = Path(tempfile.mkdtemp(dir=tmp_path))
    arch = _zip(base / "a.zip", [(n, n.encode(errors="replace")) for n in names])
    with zipfile.ZipFile(arch) as z:
        written = sorted(n for n in z.namelist() if not n.endswith("/"))
    try:
        with extracted(arch) as folder:
            got = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                         if p.is_file())
            assert got == written
    except ArchiveError:
        pass
    assert sorted(p.name for p in base.iterdir()) == ["a.zip"]


# ---- SSP archives -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ssp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short archive of rrr ssp (the letter l, 0.9 s)."""
    out = tmp_path_factory.mktemp("ssp") / "l.ssp"
    export_ssp(SspJob(out=out, text="l"))
    return out


def _rewrite(src: Path, dst: Path, *, add: tuple[tuple[str, bytes], ...] = (),
             ssd: Callable[[str], str] | None = None,
             fmu: tuple[str, Callable[[Path, Path], None]] | None = None) -> Path:
    """A copy of an archive with entries added, the SSD edited, or one FMU rebuilt."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout, \
            _quiet():
        for item in zin.infolist():
            data = zin.read(item.filename)
            if ssd is not None and item.filename == "SystemStructure.ssd":
                text = data.decode()
                edited = ssd(text)
                assert edited != text
                data = edited.encode()
            if fmu is not None and item.filename == fmu[0]:
                a, b = dst.with_suffix(".in.fmu"), dst.with_suffix(".out.fmu")
                a.write_bytes(data)
                fmu[1](a, b)
                data = b.read_bytes()
            zout.writestr(item, data)
        for name, data in add:
            zout.writestr(name, data)
    return dst


def _bind(name: str, value: str, comp: str = "") -> Callable[[str], str]:
    """An SSD edit: the value bound to the parameter ``name`` (of the component ``comp``, else
    of the first that binds it)."""
    def edit(text: str) -> str:
        at = text.index(f'<ssd:Component name="{comp}"') if comp else 0
        return text[:at] + re.sub(rf'(<ssv:Parameter name="{re.escape(name)}">\s*'
                                  r'<ssv:(?:Real|Boolean) value=")[^"]*', rf"\g<1>{value}",
                                  text[at:], count=1)
    return edit


def _as_real(name: str, value: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        return re.sub(rf'(<ssv:Parameter name="{re.escape(name)}">\s*)<ssv:Boolean value="[^"]*"',
                      rf'\g<1><ssv:Real value="{value}"', text, count=1)
    return edit


def _add_to_fmu(name: str, data: bytes) -> Callable[[Path, Path], None]:
    def rebuild(a: Path, b: Path) -> None:
        with zipfile.ZipFile(a) as zin, zipfile.ZipFile(b, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                zout.writestr(item, zin.read(item.filename))
            zout.writestr(name, data)
    return rebuild


def _stop_time(seconds: float) -> Callable[[str], str]:
    def edit(text: str) -> str:
        return re.sub(r'stopTime="[^"]*"', f'stopTime="{seconds!r}"', text, count=1)
    return edit


HOSTILE: dict[str, tuple[dict[str, Any], str]] = {
    "N9 entry outside": ({"add": (("../../../../x", b"pwned"),)},
                         "entry '../../../../x': a path part '..'"),
    "N11 unreferenced bomb": ({"add": (("resources/bomb.bin", bytes(16 << 20)),)},
                              "entry 'resources/bomb.bin': 16777216 bytes from"),
    "N11 bomb in an FMU": ({"fmu": ("resources/rrr_plant.fmu",
                                    _add_to_fmu("resources/bomb.bin", bytes(16 << 20)))},
                           "resources/rrr_plant.fmu: entry 'resources/bomb.bin'"),
    "link in an FMU": ({"fmu": ("resources/rrr_controller.fmu",
                                _add_to_fmu("binaries/linux64/../../../x", b"1"))},
                       "rrr_controller.fmu: entry 'binaries/linux64/../../../x'"),
    "N10 negative gain": ({"ssd": _bind("kp[1]", "-40")},
                          "component controller: parameter kp[1] must be a finite number >= 0 "
                          "and <= 1e6, got -40.0"),
    "gain too large": ({"ssd": _bind("kd[3]", "1e7")}, "parameter kd[3] must be"),
    "k_t zero": ({"ssd": _bind("kt[2]", "0", "plant")},
                 "component plant: parameter kt[2] must be a finite number > 0"),
    "length too large": ({"ssd": _bind("a2", "-2e6")}, "parameter a2 must be a finite number"),
    "base parameters not positive definite": (
        {"ssd": _bind("p[1]", "-5", "plant")}, "component plant: its model parameters are "
        "refused: invalid model parameter p (RRR_NOT_POSITIVE_DEFINITE)"),
    "controller's friction": ({"ssd": _bind("b[1]", "-1", "controller")},
                              "component controller: parameter b[1] must be a finite number "
                              ">= 0"),
    "lead beyond 1 s": ({"ssd": _bind("lead", "2")}, "parameter lead must be a finite number "
                                                       ">= 0 and <= 1, got 2.0"),
    "lookahead negative": ({"ssd": _bind("lookahead", "-0.001")},
                           "component reference: parameter lookahead must be"),
    "start angle": ({"ssd": _bind("q0[2]", "1e300")}, "parameter q0[2] must be"),
    "Boolean as a Real": ({"ssd": _as_real("feedforward", "0.5")},
                          "parameter feedforward is a Boolean variable, the archive binds a "
                          "Real value"),
    "N14 too many steps": ({"ssd": _stop_time(1000.5)},
                           f"steps of 0.001 s from 0 to 1000.5 s: at most {MAX_STEPS:,}"),
    "beyond the table": ({"ssd": _stop_time(5.0)},
                         "the default experiment [0, 5] s is not within the reference table"),
}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_hostile_archive_is_refused_before_anything_runs(ssp: Path, tmp_path: Path, case: str,
                                                         capsys: pytest.CaptureFixture[str],
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    how, message = HOSTILE[case]
    bad = _rewrite(ssp, tmp_path / "bad.ssp", **how)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    before = sorted(p.name for p in tmp_path.iterdir())
    for tool in TOOLS:
        assert main(["run-ssp", str(bad), "--tool", tool, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert err.startswith("rrr: error: ") and message in err, err
        assert len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no out, nothing beside
    assert list(scratch.iterdir()) == []  # no extraction or tool folder left


def test_only_referenced_entries_reach_the_tools(ssp: Path, tmp_path: Path) -> None:
    extra = _rewrite(ssp, tmp_path / "extra.ssp", add=(("resources/notes.txt", b"x" * 1000),))
    work = tmp_path / "work"
    work.mkdir()
    arch = read_ssp(extra, workdir=work)
    got = sorted(p.relative_to(work).as_posix() for p in work.rglob("*") if p.is_file())
    assert got == ["SystemStructure.ssd", *sorted(arch.sources.values())]


def _long_archive(src: Path, dst: Path, seconds: float) -> Path:
    """The archive with its reference held at the last sample up to ``seconds``."""
    def longer(a: Path, b: Path) -> None:
        with zipfile.ZipFile(a) as zin, zipfile.ZipFile(b, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "resources/reference.csv":
                    rows = np.loadtxt(data.decode().splitlines()[1:], delimiter=",", ndmin=2)
                    step = rows[1, 0] - rows[0, 0]
                    t = np.arange(rows.shape[0], round(seconds / step) + 1) * step
                    hold = np.repeat(rows[-1:], t.size, axis=0)
                    hold[:, 0] = t
                    hold[:, 4:10] = 0.0  # at rest: no velocity or acceleration
                    hold[:, 13:] = 0.0
                    body = io.StringIO()
                    np.savetxt(body, hold, delimiter=",", fmt="%.17g")
                    data = data.rstrip(b"\n") + b"\n" + body.getvalue().encode()
                zout.writestr(item, data)
    assert list(TABLE_COLUMNS[4:10]) == [f"{s}[{i}]" for s in ("qd_ref", "qdd_ref")
                                          for i in (1, 2, 3)]
    return _rewrite(src, dst, ssd=_stop_time(seconds),
                    fmu=("resources/rrr_reference.fmu", longer))


def test_sigterm_ends_a_libcosim_run_at_once_and_leaves_nothing(ssp: Path,
                                                                tmp_path: Path) -> None:
    """In libcosim's real-time mode a run of 40 s lasts 40 s at least, on any machine: SIGTERM
    ends it well before (the wait's bound, 30 s, is more than ten times what the stop takes
    here), with the stop line, exit 143 and nothing left behind."""
    long = _long_archive(ssp, tmp_path / "long.ssp", 40.0)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "rrr_robot", "run-ssp", str(long), "--tool",
                             "libcosim", "--real-time", "--out", str(out), "-q"],
                            env={**os.environ, "TMPDIR": str(scratch), "PYTHONUNBUFFERED": "1"},
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines: list[tuple[float, str]] = []  # stderr lines with the time each arrived

    def read() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append((time.monotonic(), line.rstrip("\n")))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    deadline = time.monotonic() + 120
    while not list(scratch.glob("rrr-run-ssp-*/tmp/libcosim_*")):  # libcosim has loaded it
        assert proc.poll() is None and time.monotonic() < deadline, lines
        time.sleep(0.05)
    assert proc.poll() is None  # still running (40 s of real time)
    start = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 143  # before the run's end, which is 40 s away at least
    reader.join(timeout=30)
    assert lines and lines[-1][1] == "rrr: terminated", lines
    # from the signal to the command's stop line (not to the interpreter's exit): the child's
    # documented grace (libcosim acts on no signal during a call), then the clean-up; printed,
    # not asserted (a loaded machine takes longer)
    print(f"SIGTERM to 'rrr: terminated': {lines[-1][0] - start:.3f} s (the child's grace: "
          f"{CHILD_STOP_GRACE} s)")
    assert list(scratch.iterdir()) == []
    assert not out.exists() or [p.name for p in out.iterdir()] == []


def test_a_libcosim_that_dies_is_one_line(ssp: Path, tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """libcosim aborts the process when an FMU throws in its threads: the child's signal is
    reported, the scratch folder goes."""
    import rrr_robot.ssp.run as run

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    real = subprocess.Popen

    def aborting(args: list[str], **kw: Any) -> Any:
        return real([sys.executable, "-c", "import os; os.abort()"], **kw)

    monkeypatch.setattr(run.subprocess, "Popen", aborting)  # type: ignore[attr-defined]
    assert main(["run-ssp", str(ssp), "--tool", "libcosim", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "libcosim ended by the signal SIGABRT" in err and len(err.strip().splitlines()) == 1
    assert list(scratch.iterdir()) == [] and not (tmp_path / "o").exists()


def test_reader_error_types(ssp: Path, tmp_path: Path) -> None:
    """ArchiveError is a BadInputError (exit 2, one line)."""
    bad = _rewrite(ssp, tmp_path / "bad.ssp", add=(("/abs", b"1"),))
    with pytest.raises(BadInputError, match="absolute path"):
        read_ssp(bad)


def test_a_good_run_leaves_no_temporary_folder(ssp: Path, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """The tools' own extraction folders (FMPy's, libcosim's) go into the run's scratch folder,
    which goes at the end."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    for tool in TOOLS:
        assert main(["run-ssp", str(ssp), "--tool", tool, "--out", str(tmp_path / tool),
                     "-q"]) == 0, capsys.readouterr().err
        assert (tmp_path / tool / "summary.json").is_file()
        assert list(scratch.iterdir()) == []


def test_an_fmu_with_a_hostile_entry_is_refused_by_every_loader(tmp_path: Path) -> None:
    """The co-simulation's slave, the CAN bench's plant node and rrr fmus read FMUs through
    the same reader."""
    from rrr_robot.errors import CosimError
    from rrr_robot.hil.nodes import start_plant
    from rrr_robot.sim.fmu_slave import FmuSlave
    from rrr_robot.sim.fmus import fmu_path

    bad = tmp_path / "bad.fmu"
    _add_to_fmu("../outside.txt", b"x")(fmu_path("plant"), bad)
    with pytest.raises(CosimError, match=r"cannot read the FMU .*bad.fmu: .*entry "
                       r"'../outside.txt': a path part '..'"):
        FmuSlave(bad, "plant")
    with pytest.raises(ArchiveError, match=re.escape("'../outside.txt'")):
        start_plant(fmu=bad)
    assert not (tmp_path.parent / "outside.txt").exists()
