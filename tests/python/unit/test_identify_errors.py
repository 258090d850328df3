"""Bad identification input gives a BadInputError naming the problem."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rrr_robot.core.model import Model
from rrr_robot.errors import BadInputError
from rrr_robot.identify.base_params import estimate_base_params
from rrr_robot.identify.friction import CurvePoints, fit_nls
from rrr_robot.identify.logs import Log, read_log

MODEL = Model.default()


def fake_log(n: int = 2000, moving: tuple[int, ...] = (0, 1, 2)) -> Log:
    t = np.arange(n) * 1e-3
    q = np.zeros((n, 3))
    for i in moving:
        q[:, i] = 0.5 * np.sin(2 * np.pi * (0.5 + 0.3 * i) * t + i) + 0.3 * np.sin(5 * t * (i + 1))
    u = np.random.default_rng(0).normal(size=(n, 3))
    return Log(t, q, u, source="fake")


def write(path: Path, header: str, rows: np.ndarray) -> Path:
    path.write_text(header + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return path


def test_missing_column(tmp_path: Path) -> None:
    p = write(tmp_path / "a.csv", "t,q[1],q[2],q[3],u[1],u[2]", np.zeros((300, 6)))
    with pytest.raises(BadInputError, match=r"missing column\(s\) u\[3\]"):
        read_log(p)


def test_friction_log_needs_joint(tmp_path: Path) -> None:
    lg = fake_log()
    lg.to_csv(tmp_path / "a.csv")
    with pytest.raises(BadInputError, match=r"missing column.*joint"):
        read_log(tmp_path / "a.csv", friction=True)


def test_nan_rows(tmp_path: Path) -> None:
    lg = fake_log()
    lg.u[17, 1] = np.nan
    lg.to_csv(tmp_path / "a.csv")
    with pytest.raises(BadInputError, match=r"NaN or Inf in u.*data row 18"):
        read_log(tmp_path / "a.csv")


def test_too_short(tmp_path: Path) -> None:
    fake_log(50).to_csv(tmp_path / "a.csv")
    with pytest.raises(BadInputError, match="too short: 50 samples"):
        read_log(tmp_path / "a.csv")


def test_non_uniform_time(tmp_path: Path) -> None:
    lg = fake_log()
    lg.t[500:] += 0.01
    lg.to_csv(tmp_path / "a.csv")
    with pytest.raises(BadInputError, match="non-uniform sampling"):
        read_log(tmp_path / "a.csv")


def test_not_a_file() -> None:
    with pytest.raises(BadInputError, match="does not exist"):
        read_log("/nonexistent/log.csv")


def test_rank_deficient_names_parameters() -> None:
    with pytest.raises(BadInputError, match=r"not exciting enough.*p\[1\]"):
        estimate_base_params(fake_log(moving=(1, 2)), MODEL)


def test_too_slow() -> None:
    lg = fake_log()
    slow = Log(lg.t, 1e-4 * lg.q, lg.u, source="slow")
    with pytest.raises(BadInputError, match="too short or too slow"):
        estimate_base_params(slow, MODEL)


def test_too_few_friction_levels() -> None:
    pts = CurvePoints(np.array([0.1, 0.2, 0.5]), np.array([0.1, 0.11, 0.12]))
    with pytest.raises(BadInputError, match="sweep at least 8 speeds"):
        fit_nls(pts)


def test_voltage_beyond_the_inverter_range_names_the_row() -> None:
    from rrr_robot.identify.pipeline import identify

    lg = fake_log()
    lg.u[123, 0] = 1e308
    with pytest.raises(BadInputError, match=r"row 124: u\[1\] = 1e\+308 V is outside"):
        identify(lg, MODEL)


def test_bad_settings_and_files(tmp_path: Path) -> None:
    from rrr_robot.identify.pipeline import Settings

    with pytest.raises(BadInputError, match="v_min must be a finite number"):
        Settings(v_min=float("nan"))
    dup = write(tmp_path / "d.csv", "t,q[1],q[1],q[2],q[3],u[1],u[2],u[3]", np.zeros((300, 8)))
    with pytest.raises(BadInputError, match=r"duplicated column\(s\) q\[1\]"):
        read_log(dup)
    binary = tmp_path / "b.csv"
    binary.write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(BadInputError, match="not a text"):
        read_log(binary)
    with pytest.raises(BadInputError, match="is a directory"):
        read_log(tmp_path)
    header_only = tmp_path / "h.csv"
    header_only.write_text("t,q[1],q[2],q[3],u[1],u[2],u[3]\n")
    with pytest.raises(BadInputError, match="no data rows"):
        read_log(header_only)


def test_a_huge_slope_tried_by_the_fit_stays_finite_and_silent() -> None:
    """An LM step of the friction fit may try ln w = 800: the slopes are bounded, so the
    residual stays finite and no overflow RuntimeWarning reaches a `rrr identify -q` user."""
    import warnings

    from rrr_robot.identify import friction

    pts = CurvePoints(np.linspace(0.1, 4.0, 10), np.linspace(0.2, 1.0, 10))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = friction._projected(np.array([800.0, 1.0, -800.0]), pts)
    assert np.all(np.isfinite(res))
