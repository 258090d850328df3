"""The writing task's tip-plan cache (rrr_robot.writing.plan_cache): a cached reference is the
built one bit for bit, a damaged, foreign or unwritable cache never changes a result nor fails a
run, failures are not cached, the cache is bounded, and a run that hits it needs no SciPy."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.writing import plan_cache
from rrr_robot.writing import trajectory as tr

SPEC = tr.WritingSpec(text="ab")
#: a text too wide for the writing area at its letter height: fitted (shrunk) when built
WIDE = tr.WritingSpec(text="abcdefghij")



@pytest.fixture(scope="module")
def model() -> rr.Model:
    return rr.Model.default()


def _assert_same(a: tr.Reference, b: tr.Reference) -> None:
    for f in dataclasses.fields(tr.Reference):
        va, vb = getattr(a, f.name), getattr(b, f.name)
        if isinstance(va, np.ndarray):
            assert va.dtype == vb.dtype and va.shape == vb.shape, f.name
            assert np.array_equal(va, vb), f.name  # bit for bit (no NaN in a reference)
        else:
            assert va == vb, f.name


def _entries(folder: Path) -> list[Path]:
    return sorted(folder.glob("plan-*.npz"))


@pytest.mark.parametrize("spec", [SPEC, WIDE], ids=["fits", "fitted"])
def test_a_cached_reference_is_the_built_one_bit_for_bit(cache_folder: Path, model: rr.Model,
                                                         monkeypatch: pytest.MonkeyPatch,
                                                         spec: tr.WritingSpec) -> None:
    built_laws = []
    real_law = tr.timing_law

    def counted(*args: object, **kwargs: object) -> tr.TimingLaw:
        built_laws.append(1)
        return real_law(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(tr, "timing_law", counted)
    built = tr.make_reference(model, spec, cache=False)
    assert not cache_folder.exists() and len(built_laws) == 1
    first = tr.make_reference(model, spec)          # a miss: builds and stores
    assert len(_entries(cache_folder)) == 1 and len(built_laws) == 2
    _assert_same(built, first)
    fonts_read = []
    real_strokes = tr._strokes

    def strokes(*args: object) -> object:
        fonts_read.append(1)
        return real_strokes(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(tr, "_strokes", strokes)
    second = tr.make_reference(model, spec)         # a hit: no spline built, no font read
    assert fonts_read == []
    assert len(built_laws) == 2
    _assert_same(built, second)
    # the robot-dependent part is not cached: another arm gets its own joint motion, as built
    other = model.with_params(a2=model.dh["a2"] * 1.01)
    own = tr.make_reference(other, spec, cache=False)
    _assert_same(own, tr.make_reference(other, spec))
    assert len(built_laws) == 3
    assert not np.array_equal(own.q, built.q)


def test_the_wide_text_is_fitted(model: rr.Model) -> None:
    assert tr.fitted_spec(WIDE).letter_height < WIDE.letter_height


def test_the_key_follows_every_spec_field(cache_folder: Path) -> None:
    keys = {plan_cache.plan_key(SPEC)}
    for change in ({"text": "ac"}, {"peak_speed": SPEC.peak_speed * (1 + 1e-15)},
                   {"x_range": (0.35, 0.650000001)}, {"dt": 2e-3}):
        keys.add(plan_cache.plan_key(dataclasses.replace(SPEC, **change)))
    assert len(keys) == 5
    assert plan_cache.plan_key(dataclasses.replace(SPEC)) == plan_cache.plan_key(SPEC)


@pytest.mark.parametrize("damage", ["truncated", "garbage", "other_key", "bad_shape", "nan"])
def test_a_damaged_entry_is_rebuilt_not_trusted(cache_folder: Path, model: rr.Model,
                                                damage: str) -> None:
    built = tr.make_reference(model, SPEC, cache=False)
    tr.make_reference(model, SPEC)
    [entry] = _entries(cache_folder)
    with np.load(entry) as z:
        arrays = {k: z[k] for k in z.files}
    if damage == "truncated":
        entry.write_bytes(entry.read_bytes()[:1000])
    elif damage == "garbage":
        entry.write_bytes(b"not an npz file at all")
    else:
        if damage == "other_key":
            arrays["key"] = np.array("0" * 64)
        elif damage == "bad_shape":
            arrays["x"] = arrays["x"][:-1]
        else:
            arrays["xdd"][5, 1] = np.nan
        with entry.open("wb") as f:
            np.savez(f, **arrays)
    assert plan_cache.load(SPEC) is None
    _assert_same(built, tr.make_reference(model, SPEC))      # rebuilt ...
    assert plan_cache.load(SPEC) is not None  # ... and stored again


def test_an_unwritable_cache_is_no_failure(tmp_path: Path, model: rr.Model,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("the cache folder cannot be created under a file")
    monkeypatch.setenv("RRR_CACHE_DIR", str(blocker / "cache"))
    ref = tr.make_reference(model, SPEC)
    _assert_same(tr.make_reference(model, SPEC, cache=False), ref)
    assert plan_cache.load(SPEC) is None


def test_no_cache_env_turns_it_off(cache_folder: Path, model: rr.Model,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RRR_NO_CACHE", "1")
    assert plan_cache.cache_dir() is None
    tr.make_reference(model, SPEC)
    assert not cache_folder.exists()
    monkeypatch.setenv("RRR_NO_CACHE", "0")
    assert plan_cache.cache_dir() == cache_folder


def test_failures_are_not_cached(cache_folder: Path, model: rr.Model) -> None:
    with pytest.raises(rr.BadInputError, match="outside the workspace"):
        tr.make_reference(model, tr.WritingSpec(x_range=(0.7, 1.0)))
    assert _entries(cache_folder) == []


def test_a_cached_plan_is_checked_against_each_robot(cache_folder: Path, model: rr.Model,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """A plan cached for one robot is still refused for a robot that cannot reach it."""
    tr.make_reference(model, SPEC)
    real = type(model).workspace_margin

    def shrunk(self: rr.Model, x: object) -> np.ndarray:
        return np.asarray(real(self, x)) - 1.0   # a robot with a workspace 1 m smaller

    monkeypatch.setattr(type(model), "workspace_margin", shrunk)
    with pytest.raises(rr.BadInputError, match="outside the workspace"):
        tr.make_reference(model, SPEC)


def test_the_cache_keeps_at_most_max_entries(cache_folder: Path, model: rr.Model,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(plan_cache, "MAX_ENTRIES", 2)
    for text in ("a", "b", "c"):
        tr.make_reference(model, tr.WritingSpec(text=text))
    entries = _entries(cache_folder)
    assert len(entries) == 2
    kept = {e.name for e in entries}
    assert all(f"plan-{plan_cache.plan_key(tr.WritingSpec(text=t))[:40]}.npz"
               in kept for t in ("b", "c"))
    assert not list(cache_folder.glob(".plan-*"))  # no temporary file left behind


def test_a_cached_writing_run_imports_no_scipy(cache_folder: Path, tmp_path: Path) -> None:
    """`rrr writing --no-figures` with the plan cached never imports SciPy (about 0.4 s of a
    run): a first process builds the plan (a miss), a second one reads it (a hit)."""
    code = """
import json, sys
from rrr_robot.cli import main
assert main(["writing", "--no-figures", "--scenario", "ctc", "--out", sys.argv[1]]) == 0
print("SCIPY:" + json.dumps("scipy" in sys.modules))
"""
    env = {**os.environ, "RRR_CACHE_DIR": str(cache_folder)}
    loaded = []
    for out in ("miss", "hit"):
        run = subprocess.run([sys.executable, "-c", code, str(tmp_path / out)], cwd=tmp_path,
                             env=env, check=True, capture_output=True, text=True, timeout=300)
        line = [x for x in run.stdout.splitlines() if x.startswith("SCIPY:")][-1]
        loaded.append(json.loads(line.removeprefix("SCIPY:")))
    assert loaded == [True, False]
    miss, hit = (json.loads((tmp_path / out / "summary.json").read_text())["scenarios"]["ctc"]
                 for out in ("miss", "hit"))
    for k in ("rms_u_n", "rms_u_c", "tip_error_max", "tip_error_rms"):
        assert miss[k] == hit[k], k
