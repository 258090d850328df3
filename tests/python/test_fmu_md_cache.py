"""The FMUs' model-description cache (rrr_robot.sim._md_cache): a slave made from a cached entry
is the slave made from FMPy's reading (the same variables, value references, types, the same
co-simulation bit for bit), a damaged or foreign entry is ignored and rebuilt, never trusted,
RRR_NO_CACHE=1 writes nothing, and a hit does not import lxml."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.sim import _md_cache
from rrr_robot.sim.fmu_slave import FmuSlave
from rrr_robot.sim.fmus import fmu_path


def _xml(which: str, version: int) -> bytes:
    with zipfile.ZipFile(fmu_path(which, version)) as z:
        return z.read("modelDescription.xml")


def _slave_facts(which: str, version: int) -> tuple[tuple[object, ...], str]:
    """What a slave of the FMU is (version, GUID, model identifier, its variables, some start
    values), and whether its description came from the cache or from FMPy."""
    kind = "cache" if _md_cache.load(_xml(which, version)) is not None else "fmpy"
    with FmuSlave(fmu_path(which, version), which) as s:
        fmu = s._api.fmu
        facts = (s.fmi_version, fmu.guid, fmu.modelIdentifier,
                 sorted((n, int(v.valueReference), v.type) for n, v in s._vars.items()))
        names = sorted(n for n, v in s._vars.items() if v.type in ("Real", "Float64"))[:8]
        s.initialize(0.0, {})
        values = s.get_values(names)
    return (*facts, values), kind


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("which", ["controller", "plant"])
def test_a_cached_description_is_fmpys(cache_folder: Path, which: str, version: int) -> None:
    built, kind = _slave_facts(which, version)
    assert kind == "fmpy"  # the cache was empty
    assert len(list(cache_folder.glob("fmu-md-*.json"))) == 1
    cached, kind = _slave_facts(which, version)
    assert kind == "cache"
    assert cached == built


def test_a_cosimulation_from_the_cache_is_the_same_bit_for_bit(
        cache_folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import rrr_robot as rr
    from rrr_robot.sim.fmu_slave import clear_pool
    from rrr_robot.writing.job import WritingJob, run_writing

    runs = []
    for k in range(2):  # the first reads the descriptions with FMPy, the second from the cache
        clear_pool()
        out = cache_folder.parent / f"out{k}"
        run_writing(WritingJob(out=out, scenarios=["ctc"], figures=False))
        runs.append(rr.read_table(out / "ctc.csv"))
    assert len(list(cache_folder.glob("fmu-md-*.json"))) == 2
    assert runs[0].keys() == runs[1].keys()
    assert all(np.array_equal(runs[0][c], runs[1][c]) for c in runs[0])


def _damage(file: Path, how: str) -> None:
    entry = json.loads(file.read_text())
    if how == "truncated":
        file.write_text(file.read_text()[:40])
    elif how == "value reference changed":
        entry["content"]["variables"][0][1] += 1
        file.write_text(json.dumps(entry))
    elif how == "another key":
        entry["key"] = "0" * 64
        file.write_text(json.dumps(entry))
    else:
        file.write_bytes(b"\xff\x00 not json")


@pytest.mark.parametrize("how", ["truncated", "value reference changed", "another key",
                                 "binary"])
def test_a_damaged_entry_is_rebuilt_never_trusted(cache_folder: Path, how: str) -> None:
    xml = _xml("plant", 2)
    built, _ = _slave_facts("plant", 2)
    (file,) = cache_folder.glob("fmu-md-*.json")
    _damage(file, how)
    assert _md_cache.load(xml) is None
    again, kind = _slave_facts("plant", 2)
    assert kind == "fmpy" and again == built  # FMPy's again, and stored again
    assert _md_cache.load(xml) is not None


def test_no_cache_writes_nothing(cache_folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RRR_NO_CACHE", "1")
    _slave_facts("controller", 2)
    assert not cache_folder.exists() or not list(cache_folder.glob("fmu-md-*"))
    assert _md_cache.load(_xml("controller", 2)) is None


def test_an_unwritable_cache_does_not_fail_the_slave(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("RRR_CACHE_DIR", str(blocker / "cache"))
    monkeypatch.delenv("RRR_NO_CACHE", raising=False)
    _slave_facts("controller", 2)
    _, kind = _slave_facts("controller", 2)
    assert kind == "fmpy"  # nothing was stored


def test_the_key_is_the_bytes(cache_folder: Path) -> None:
    xml = _xml("plant", 2)
    assert _md_cache.key(xml) == _md_cache.key(bytes(xml))
    assert _md_cache.key(xml) != _md_cache.key(xml + b" ")
    assert _md_cache.key(xml) != _md_cache.key(_xml("plant", 3))


def test_a_hit_imports_no_lxml(cache_folder: Path, tmp_path: Path) -> None:
    code = ("import sys\nfrom rrr_robot.sim.fmu_slave import FmuSlave\n"
            "from rrr_robot.sim.fmus import fmu_path\n"
            "with FmuSlave(fmu_path('plant', 2), 'plant'):\n    pass\n"
            "print('LXML' if 'lxml' in sys.modules else 'NO-LXML')\n")
    env = {**os.environ, "RRR_CACHE_DIR": str(cache_folder)}
    first, second = (subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                                    check=True, capture_output=True, text=True,
                                    timeout=120).stdout.split()[-1] for _ in range(2))
    assert (first, second) == ("LXML", "NO-LXML")
