"""The reference FMU (rrr_reference): validation, its table in resources/, the quintic Hermite
interpolation (consistent q, qd, qdd; samples exact), the look-ahead, and refused tables.

Each test copies the unzipped FMU and writes its own resources/reference.csv, then drives it
through FMPy's FMU2Slave (tests/python/support/fmu_support.py keeps the FMU's log messages).
"""

from __future__ import annotations

import itertools
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu
from rrr_robot.sim.fmus import fmu_path
from rrr_robot.ssp.table import TABLE_COLUMNS
from support.fmu_support import (
    COMMITTED_XML,
    STEP,
    FMICallException,
    Slave,
    fmu_file,
    joint,
    unzipped,
)

OUT = joint("q_ref") + joint("qd_ref") + joint("qdd_ref") + ["x_ref.x", "x_ref.y", "x_ref.z"]


def smooth(t: np.ndarray) -> np.ndarray:
    """(n, 19) table rows of a smooth motion with exact derivatives: joint j and tip axis j move
    as a_j sin(w_j t + c_j)."""
    rows = [t]
    for base in (0.0, 10.0):  # joints, then the tip (other amplitudes)
        a = np.array([0.7, 0.4, 1.1]) + base
        w = np.array([3.0, 5.0, 2.0])
        c = np.array([0.1, 0.2, 0.3])
        ph = np.outer(t, w) + c
        rows += [a * np.sin(ph), a * w * np.cos(ph), -a * w * w * np.sin(ph)]
    return np.column_stack([rows[0], *rows[1:]])


def write_table(folder: Path, rows: np.ndarray | None = None, text: str | None = None) -> None:
    path = folder / "resources" / "reference.csv"
    if text is None:
        assert rows is not None
        body = "\n".join(",".join(f"{v:.17g}" for v in r) for r in rows)
        text = ",".join(TABLE_COLUMNS) + "\n" + body + "\n"
    path.write_text(text)


@pytest.fixture
def fmu_copy(tmp_path: Path) -> Path:
    """An unzipped copy of the FMI 2.0 reference FMU whose table the test replaces."""
    dst = tmp_path / "rrr_reference"
    shutil.copytree(unzipped(fmu_file("reference")), dst)
    return dst


def play(folder: Path, times: np.ndarray, params: dict[str, float] | None = None) -> np.ndarray:
    """The outputs at each time (doStep to it from 0), (n, 12)."""
    with Slave("reference", unzip_dir=folder).instantiate() as s:
        s.to_step_mode(params)
        out = [s.get(OUT)]
        for a, b in itertools.pairwise(times):
            s.fmu.doStep(float(a), float(b - a))
            out.append(s.get(OUT))
    return np.array(out)


@pytest.mark.parametrize("version", [2, 3])
def test_fmpy_validates_the_reference_fmu(version: int) -> None:
    assert validate_fmu(str(fmu_path("reference", version))) == []


def test_archive_holds_the_generated_xml_and_a_table() -> None:
    with zipfile.ZipFile(fmu_file("reference")) as z:
        assert z.read("modelDescription.xml") == COMMITTED_XML["reference"].read_bytes()
        names = z.namelist()
    assert "resources/reference.csv" in names
    assert "binaries/linux64/rrr_reference.so" in names
    assert any(n.startswith("sources/") and n.endswith("model.c") for n in names)


def test_default_experiment_plays_the_packaged_table() -> None:
    res = simulate_fmu(str(fmu_file("reference")), validate=True)
    assert len(res) == 1001
    for name in OUT:
        assert np.all(np.isfinite(res[name])), name


def test_samples_exact_and_hermite_between(fmu_copy: Path) -> None:
    h = 0.01  # the table's sample period
    t_tab = np.arange(0.0, 1.0 + h / 2, h)
    tab = smooth(t_tab)
    write_table(fmu_copy, tab)
    t = np.arange(0.0, 0.9 + STEP / 2, STEP)  # 10 outputs per interval
    got = play(fmu_copy, t)
    exact = smooth(t)
    # at the sample times: the samples bit for bit (q, qd, qdd, x)
    on = np.arange(0, t.size, 10)
    cols = [*range(1, 10), 10, 11, 12]
    assert np.array_equal(got[on], tab[: on.size][:, cols])
    # between: the quintic Hermite error O(h^6) on q, O(h^5) on qd, O(h^4) on qdd
    err = np.abs(got - exact[:, cols])
    assert err[:, 0:3].max() < 1e-10 and err[:, 9:12].max() < 1e-9
    assert err[:, 3:6].max() < 1e-8 and err[:, 6:9].max() < 1e-5
    assert err[:, 6:9].max() > 1e-12  # the interpolant, not the samples, between samples
    # consistency: qd is the derivative of q, qdd of qd (central differences, 1 ms)
    dq = (got[2:, 0:3] - got[:-2, 0:3]) / (2 * STEP)
    ddq = (got[2:, 3:6] - got[:-2, 3:6]) / (2 * STEP)
    assert np.abs(dq - got[1:-1, 3:6]).max() < 1e-4
    assert np.abs(ddq - got[1:-1, 6:9]).max() < 1e-3


def test_lookahead_shifts_the_reference(fmu_copy: Path) -> None:
    t_tab = np.arange(0.0, 1.0 + 0.005, 0.01)
    write_table(fmu_copy, smooth(t_tab))
    t = np.arange(0.0, 0.5 + STEP / 2, STEP)
    plain = play(fmu_copy, t)
    ahead = play(fmu_copy, t, {"lookahead": 3 * STEP})
    np.testing.assert_allclose(ahead[:-3], plain[3:], rtol=0, atol=1e-12)
    assert np.abs(ahead - plain).max() > 1e-3


def test_outside_the_table_the_end_is_held_at_rest(fmu_copy: Path) -> None:
    rows = smooth(np.array([0.0, 0.01, 0.02]))
    write_table(fmu_copy, rows)
    got = play(fmu_copy, np.array([0.0, 0.01, 0.02, 0.05]))
    assert np.array_equal(got[2, 0:3], rows[2, 1:4])
    assert np.array_equal(got[3, 0:3], rows[2, 1:4])  # held
    assert np.all(got[3, 3:9] == 0.0)  # at rest


def bad(rows: np.ndarray) -> Callable[[], str]:
    def text() -> str:
        return ",".join(TABLE_COLUMNS) + "\n" + "\n".join(
            ",".join(f"{v:.17g}" for v in r) for r in rows) + "\n"
    return text


_GOOD = smooth(np.array([0.0, 0.01, 0.02]))
_NAN = _GOOD.copy()
_NAN[1, 5] = np.nan
_UNSORTED = _GOOD[[0, 2, 1]]
_HEADER = ",".join(TABLE_COLUMNS[:-1]) + "\n" + "\n".join(
    ",".join(f"{v:.17g}" for v in r[:-1]) for r in _GOOD) + "\n"
_SHORT_ROW = bad(_GOOD)().replace("\n0.01,", "\n0.01,,", 1)

CASES = {
    "nan": (bad(_NAN)(), "line 3, column qd_ref[2]: \"nan\" is not a finite decimal number"),
    "unsorted": (bad(_UNSORTED)(), "line 4: t = 0.01 is not after t = 0.02 of line 3"),
    "wrong columns": (_HEADER, "line 1: column 18 must be \"xdd_ref.y\""),
    "empty field": (_SHORT_ROW, "line 3, column q_ref[1]: \"\" is not a finite decimal number"),
    "one sample": (bad(_GOOD[:1])(), "has 1 sample(s): a reference needs at least 2"),
    "overflow": (bad(_GOOD)().replace("0.01,", "1e999,", 1),
                           "is not a finite decimal number"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_table_is_refused_with_a_message(fmu_copy: Path, case: str) -> None:
    text, message = CASES[case]
    write_table(fmu_copy, text=text)
    with Slave("reference", unzip_dir=fmu_copy).instantiate() as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        with pytest.raises(FMICallException) as exc:
            s.fmu.exitInitializationMode()
        assert exc.value.status == 3  # fmi2Error
        assert any(message in m for m in s.errors()), s.errors()


def test_missing_table_is_refused_with_a_message(fmu_copy: Path) -> None:
    (fmu_copy / "resources" / "reference.csv").unlink()
    with Slave("reference", unzip_dir=fmu_copy).instantiate() as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        with pytest.raises(FMICallException):
            s.fmu.exitInitializationMode()
        assert any("cannot open the reference table" in m and "reference.csv" in m
                   for m in s.errors()), s.errors()


def test_bad_lookahead_is_refused(fmu_copy: Path) -> None:
    write_table(fmu_copy, _GOOD)
    with Slave("reference", unzip_dir=fmu_copy).instantiate() as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.set({"lookahead": -1e-3})
        s.fmu.enterInitializationMode()
        with pytest.raises(FMICallException):
            s.fmu.exitInitializationMode()
        assert any("parameter lookahead must be in [0, 1] s" in m for m in s.errors())
