"""The FMPy master reuses its FMU instances across runs (sim.fmu_slave.pooled_slave): a run on a
reused, reset instance gives the same results bit for bit as one on a fresh instance, whatever
the previous run set or how it ended (a failed run's instances are closed, not reused)."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.sim import fmu_slave
from rrr_robot.sim.cosim import CosimOptions, CosimResult, run_cosim
from rrr_robot.sim.fmus import fmu_path

T = np.arange(0.0, 0.2, 1e-3)
Q = 0.3 + 0.2 * np.sin(np.outer(T, [3.0, 5.0, 7.0]))
QD = 0.2 * np.cos(np.outer(T, [3.0, 5.0, 7.0])) * [3.0, 5.0, 7.0]
QDD = -0.2 * np.sin(np.outer(T, [3.0, 5.0, 7.0])) * [9.0, 25.0, 49.0]
X = np.zeros_like(Q)
FIELDS = ("q", "qd", "qdd", "tip", "u", "u_n", "u_c")


def run(fmi: int, **kw: object) -> CosimResult:
    return run_cosim(T, Q, QD, QDD, X, CosimOptions(fmi_version=fmi, **kw))  # type: ignore[arg-type]


def idle(fmi: int) -> list[fmu_slave.FmuSlave]:
    """The idle plant instances of FMI version ``fmi`` in the pool."""
    return fmu_slave._pool.get(fmu_slave._pool_key(fmu_path("plant", fmi), "plant"), [])


def nan_at(k: int) -> Callable[[np.ndarray], np.ndarray]:
    """A measurement hook that makes the controller refuse its input at step k."""
    calls = iter(range(10**9))
    return lambda x: x * np.nan if next(calls) == k else x


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_reused_instance_gives_the_results_of_a_fresh_one(fmi: int) -> None:
    fmu_slave.clear_pool()
    fresh = run(fmi)  # new instances, then pooled
    assert len(idle(fmi)) == 1
    pooled = idle(fmi)[0]
    # a run with other parameters, then one that fails inside the loop (instances closed)
    run(fmi, plant_values={"adaptive": False, "h_int": 2.5e-4, "kt[1]": 0.5},
        controller_values={"kt[2]": 0.7})
    assert idle(fmi) == [pooled]
    with pytest.raises(rr.CosimError, match="must be finite"):
        run(fmi, measure=nan_at(50))
    assert idle(fmi) == [] and pooled._closed  # the failed run's instances are not reused
    run(fmi, plant_values={"kt[3]": 0.9})
    again = run(fmi)  # on the instances of the run before, reset
    assert len(idle(fmi)) == 1
    for f in FIELDS:
        assert np.array_equal(getattr(fresh, f), getattr(again, f)), f
    assert np.ptp(fresh.q, axis=0).min() > 1e-3  # the arm moved: the comparison means something


def test_a_changed_fmu_file_is_instantiated_afresh(tmp_path: Path) -> None:
    """The pool is keyed by the file (path, size, modification time): a rebuilt FMU at the same
    path is never served by an instance of the old one."""
    copy = tmp_path / "plant.fmu"
    shutil.copy(fmu_path("plant"), copy)
    run(2, plant_fmu=copy)
    key = fmu_slave._pool_key(copy, "plant")
    assert len(fmu_slave._pool[key]) == 1
    copy.write_bytes(copy.read_bytes() + b"\0")  # another size: another key
    assert fmu_slave._pool_key(copy, "plant") != key


def test_reuse_can_be_turned_off(monkeypatch: pytest.MonkeyPatch) -> None:
    """$RRR_FMU_REUSE=0: every run on fresh instances, none kept; the same results."""
    fmu_slave.clear_pool()
    monkeypatch.setenv("RRR_FMU_REUSE", "0")
    off = run(2)
    assert idle(2) == []
    monkeypatch.delenv("RRR_FMU_REUSE")
    run(2)
    on = run(2)
    assert len(idle(2)) == 1
    for f in FIELDS:
        assert np.array_equal(getattr(off, f), getattr(on, f)), f


def test_the_direct_fmi2_calls_give_the_results_of_fmpys_wrappers(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The stepping loop's FMI 2 calls go to the library's functions directly (_Fmi2._raw);
    through FMPy's wrappers (its call logger on) the results are the same bit for bit, and a
    failed call is the same CosimError."""
    fmu_slave.clear_pool()
    direct = run(2)
    with pytest.raises(rr.CosimError) as direct_err:
        run(2, measure=nan_at(50))
    monkeypatch.setattr(fmu_slave._Fmi2, "_raw", lambda self, name: None)
    fmu_slave.clear_pool()
    wrapped = run(2)
    with pytest.raises(rr.CosimError) as wrapped_err:
        run(2, measure=nan_at(50))
    for name in FIELDS:
        assert np.array_equal(getattr(direct, name), getattr(wrapped, name)), name
    assert str(direct_err.value) == str(wrapped_err.value)
    assert "fmi2" in str(direct_err.value)
