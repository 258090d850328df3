"""Identification (issue 4) on simulated plant-FMU experiments: noise-free recovery, 95 %
intervals with quantisation and noise, the writing task with identified parameters, the CLI."""

from __future__ import annotations

import argparse
import json
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rrr_robot.cli.identify import register_cli
from rrr_robot.core.model import DEFAULT_ROBOT_TOML, Model
from rrr_robot.core.outputs import strict_json
from rrr_robot.core.robot import read_robot_file
from rrr_robot.errors import BadInputError
from rrr_robot.identify import experiments as ex
from rrr_robot.identify.base_params import estimate_base_params
from rrr_robot.identify.excitation import (
    ExcitationLimits,
    FourierTrajectory,
    design_excitation,
    stacked_regressor,
)
from rrr_robot.identify.jobs import IdentifyJob, run_identify
from rrr_robot.identify.pipeline import Settings, identify, write_robot
from rrr_robot.identify.validation import validate_writing

TRUE = Model.default()
#: a prior that is wrong in p and friction: only kinematics, g, k_t, u_max are taken from it
PRIOR = TRUE.with_params(p=TRUE.p * 1.3, f=TRUE.f * 0.5, w=TRUE.w * 0.7, b=TRUE.b * 2)
SWEEP = ex.SweepDesign(cruise=1.2, settle=0.4)


def rel_err(est: np.ndarray, true: np.ndarray, floor: float) -> np.ndarray:
    """Relative error, absolute where |true| < floor."""
    err = np.abs(est - true)
    return np.where(np.abs(true) > floor, err / np.maximum(np.abs(true), floor), err)


@pytest.fixture(scope="module")
def traj() -> tuple[FourierTrajectory, float]:
    return design_excitation(PRIOR, np.array(SWEEP.pose), maxiter=30, seed=0)


@pytest.fixture(scope="module")
def ideal_logs(traj: tuple[FourierTrajectory, float]) -> tuple:
    return (ex.friction_experiment(TRUE, SWEEP, sensors=ex.IDEAL),
            ex.excitation_experiment(TRUE, traj[0], sensors=ex.IDEAL))


@pytest.fixture(scope="module")
def noisy_logs(traj: tuple[FourierTrajectory, float]) -> tuple:
    return (ex.friction_experiment(TRUE, SWEEP, sensors=ex.NOISY),
            ex.excitation_experiment(TRUE, traj[0], sensors=replace(ex.NOISY, seed=2)))


def test_excitation_within_limits_and_well_conditioned(traj) -> None:
    trajectory, cond = traj
    lim = ExcitationLimits()
    t = np.linspace(0, trajectory.period, 2000)
    q, qd, qdd = trajectory.evaluate(t)
    assert np.all(np.abs(q - trajectory.q0) <= lim.q_amp * 1.01)
    assert np.all(np.abs(qd) <= lim.qd_max * 1.01)
    assert np.all(np.abs(qdd) <= lim.qdd_max * 1.01)
    assert cond < 20
    assert np.isclose(np.linalg.cond(stacked_regressor(PRIOR, trajectory)), cond)
    u = TRUE.nominal_voltage(q, qd, qdd)
    assert np.max(np.abs(u)) < 0.7 * TRUE.u_max


def test_noise_free_recovery(ideal_logs) -> None:
    fric, exc = ideal_logs
    res = identify(exc, PRIOR, fric, Settings(derivatives="log"))
    assert np.max(rel_err(res.model.p, TRUE.p, 1e-6)) < 1e-3
    for i, fit in enumerate(res.friction):
        assert np.max(rel_err(np.r_[fit.f, fit.w, fit.b],
                              np.r_[TRUE.f[i], TRUE.w[i], TRUE.b[i]], 1e-9)) < 0.01, fit


def test_noise_free_recovery_through_filters(ideal_logs) -> None:
    _, exc = ideal_logs
    exc = replace(exc, qd=None, qdd=None)       # positions only, as from an encoder
    res = estimate_base_params(exc, TRUE, method="savgol", cutoff=50.0)
    assert np.max(rel_err(res.ls.p, TRUE.p, 1e-6)) < 1e-3


def test_friction_ls_with_w_fixed(ideal_logs) -> None:
    fric, _ = ideal_logs
    res = identify(ideal_logs[1], TRUE, fric, Settings(derivatives="log", friction_method="ls"))
    for i, fit in enumerate(res.friction):
        np.testing.assert_allclose(fit.f, TRUE.f[i], rtol=0.01)
        assert fit.residual_rms < 1e-4


def test_noisy_intervals_and_writing(noisy_logs) -> None:
    fric, exc = noisy_logs
    assert exc.qd is None and fric.qd is None
    res = identify(exc, PRIOR, fric)
    est = res.base.ls
    assert np.array_equal(res.model.p, est.p)     # the default estimator
    inside = np.abs(est.p - TRUE.p) <= 1.96 * est.std
    assert inside.sum() >= 15, (est.p - TRUE.p) / est.std
    val = validate_writing(TRUE, res.model, read_robot_file(DEFAULT_ROBOT_TOML))
    assert val["tip_error_ratio"] < 2.0
    assert max(val["rms_u_n_error"]) < 0.05 * max(val["rms_u_n_true"])


def test_cli_writes_robot_file(tmp_path: Path, noisy_logs) -> None:
    fric, exc = noisy_logs
    fric.to_csv(tmp_path / "friction.csv")
    exc.to_csv(tmp_path / "excitation.csv", "simulated")
    parser = argparse.ArgumentParser()
    register_cli(parser.add_subparsers(dest="command"))
    out = tmp_path / "identified.toml"
    args = parser.parse_args(["identify", "--log", str(tmp_path / "excitation.csv"),
                              "--friction-log", str(tmp_path / "friction.csv"),
                              "--out", str(out), "--report", str(tmp_path / "r.json")])
    assert args.func(args) == 0
    model = read_robot_file(out).model
    assert np.max(np.abs(model.p - TRUE.p)) < 0.05
    data = tomllib.loads(out.read_text())
    assert {"base_parameters", "friction", "control", "identification"} <= set(data)
    assert len(data["identification"]["p_std"]) == 16


def test_library_job_equals_the_cli_and_checks_outputs_first(tmp_path: Path, noisy_logs) -> None:
    """``rrr identify`` is one library call: run_identify on the same logs writes the same robot
    file; an output that is an input log is refused before anything is estimated or written."""
    fric, exc = noisy_logs
    fric.to_csv(tmp_path / "friction.csv")
    exc.to_csv(tmp_path / "excitation.csv", "simulated")
    parser = argparse.ArgumentParser()
    register_cli(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["identify", "--log", str(tmp_path / "excitation.csv"),
                              "--friction-log", str(tmp_path / "friction.csv"),
                              "--out", str(tmp_path / "cli.toml")])
    assert args.func(args) == 0
    phases: list[str] = []
    job = IdentifyJob(log=tmp_path / "excitation.csv", out=tmp_path / "lib.toml",
                      friction_log=tmp_path / "friction.csv", report=tmp_path / "lib.json")
    outcome = run_identify(job, progress=lambda phase, done, total: phases.append(phase))
    assert (tmp_path / "lib.toml").read_text() == (tmp_path / "cli.toml").read_text()
    assert json.loads((tmp_path / "lib.json").read_text()) == json.loads(
        strict_json(outcome.report))
    assert phases and set(phases) == {"friction fits"}
    before = (tmp_path / "excitation.csv").read_bytes()
    with pytest.raises(BadInputError, match="is the input log"):
        run_identify(replace(job, out=tmp_path / "excitation.csv", report=None))
    assert (tmp_path / "excitation.csv").read_bytes() == before


def test_write_robot_roundtrip(tmp_path: Path, ideal_logs) -> None:
    res = identify(ideal_logs[1], PRIOR, None, Settings(derivatives="log"))
    write_robot(res, tmp_path / "r.toml")
    np.testing.assert_allclose(read_robot_file(tmp_path / "r.toml").model.p, res.model.p)


def test_truth_puts_each_estimate_beside_its_true_value(tmp_path: Path, noisy_logs,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """rrr identify --truth FILE: a line per base parameter with the estimate, its 95 %
    interval (estimate +/- 1.96 std), the true value and whether the interval holds it, the
    count inside, the friction beside the truth; the same in --report (``truth``) and in the
    robot file's [identification] (p_true, p_inside_95), which reads back; the truth cannot be
    an output."""
    from rrr_robot.identify.truth import friction_curve

    fric, exc = noisy_logs
    fric.to_csv(tmp_path / "friction.csv")
    exc.to_csv(tmp_path / "excitation.csv", "simulated")
    parser = argparse.ArgumentParser()
    register_cli(parser.add_subparsers(dest="command"))
    out, report = tmp_path / "identified.toml", tmp_path / "r.json"
    args = parser.parse_args(["identify", "--log", str(tmp_path / "excitation.csv"),
                              "--friction-log", str(tmp_path / "friction.csv"),
                              "--truth", str(DEFAULT_ROBOT_TOML), "--out", str(out),
                              "--report", str(report)])
    assert args.func(args) == 0
    printed = capsys.readouterr().out.splitlines()
    truth = json.loads(report.read_text())["truth"]
    data = tomllib.loads(out.read_text())
    est = np.array(data["identification"]["p"])
    std = np.array(data["identification"]["p_std"])
    inside = np.abs(est - TRUE.p) <= 1.96 * std
    assert truth["source"] == str(DEFAULT_ROBOT_TOML) and truth["estimator"] == "ls"
    assert truth["p_inside_95"] == int(inside.sum()) >= 15 and truth["p_count"] == 16
    for k, row in enumerate(truth["p"]):
        assert row["name"] == f"p[{k + 1}]" and row["truth"] == TRUE.p[k]
        assert row["estimate"] == est[k] and row["std"] == std[k]
        assert row["interval_95"] == pytest.approx([est[k] - 1.96 * std[k],
                                                    est[k] + 1.96 * std[k]], rel=1e-12)
        assert row["inside_95"] == bool(inside[k])
        line = next(ln for ln in printed if ln.startswith(f"  p[{k + 1}] "))
        assert line.split()[-1] == ("inside" if inside[k] else "OUTSIDE"), line
    assert f"{int(inside.sum())} of 16 true base parameters inside their 95 % intervals" in printed
    for j, joint in enumerate(truth["friction"]):
        assert joint["f_true"] == TRUE.f[j].tolist() and joint["b_true"] == TRUE.b[j]
        v = np.linspace(joint["speed_min"], joint["speed_max"], 50)
        diff = friction_curve(np.array(joint["f"]), np.array(joint["w"]), joint["b"], v) - \
            friction_curve(TRUE.f[j], TRUE.w[j], float(TRUE.b[j]), v)
        # the reported largest difference is taken on a finer grid of the same speeds
        assert np.abs(diff).max() <= 1.01 * joint["curve_error_max_V"] < 0.02
        assert sum(ln.startswith(f"friction joint {j + 1}: ") for ln in printed) == 1
    assert truth["prior_differs"] == []
    ident = read_robot_file(out).data.identification
    assert list(ident["p_true"]) == TRUE.p.tolist() and ident["p_inside_95"] == inside.sum()
    assert ident["truth"] == str(DEFAULT_ROBOT_TOML)
    (tmp_path / "true.toml").write_bytes(DEFAULT_ROBOT_TOML.read_bytes())
    with pytest.raises(BadInputError, match="is the truth"):
        run_identify(IdentifyJob(log=tmp_path / "excitation.csv", out=tmp_path / "true.toml",
                                 truth=tmp_path / "true.toml"))
    assert (tmp_path / "true.toml").read_bytes() == DEFAULT_ROBOT_TOML.read_bytes()


def test_truth_names_what_the_prior_gives_wrongly() -> None:
    """The parameters identification takes from the prior and in which it differs from the
    truth are listed (they bias the estimate); without a friction log the friction is the
    prior's too."""
    from rrr_robot.identify.base_params import Estimate
    from rrr_robot.identify.truth import compare_with_truth

    true = TRUE.with_params(kt=TRUE.kt * np.array([1.0, 1.1, 1.0]))
    est = Estimate(TRUE.p, np.full(16, 1e-3), np.zeros(3), "ls")
    cmp = compare_with_truth(est, [], PRIOR, true, "true.toml")
    assert cmp.prior_differs == ("kt[2]",) and cmp.friction == ()
    assert cmp.inside.all() and cmp.report()["p_inside_95"] == 16
    no_log = compare_with_truth(est, None, PRIOR, true, "true.toml")
    assert no_log.prior_differs[0] == "kt[2]" and "f[1,1]" in no_log.prior_differs
    assert any("kt[2]" in ln for ln in no_log.lines())


def test_validate_runs_the_truth_as_the_plant(tmp_path: Path, noisy_logs) -> None:
    """--validate with --truth: the writing task's plant is the truth (its ctc run is rrr
    writing --robot TRUTH --scenario ctc, bit for bit), the controller once the truth's model
    and once the identified one."""
    from rrr_robot.writing.job import WritingJob, run_writing

    fric, exc = noisy_logs
    fric.to_csv(tmp_path / "friction.csv")
    exc.to_csv(tmp_path / "excitation.csv", "simulated")
    text = DEFAULT_ROBOT_TOML.read_text(encoding="utf-8")
    truth = tmp_path / "truth.toml"  # the default robot's kinematics, a heavier forearm
    truth.write_text(text.replace("\nmass = 2.5\n", "\nmass = 4.0\n"), encoding="utf-8")
    outcome = run_identify(IdentifyJob(log=tmp_path / "excitation.csv", out=tmp_path / "i.toml",
                                       friction_log=tmp_path / "friction.csv", validate=True,
                                       truth=truth))
    writing = outcome.report["writing"]
    assert writing["plant"] == "truth"
    plain = run_writing(WritingJob(out=tmp_path / "w", robot=truth, scenarios=["ctc"],
                                   figures=False))["scenarios"]["ctc"]
    assert writing["true"]["tip_error_max"] == plain["tip_error_max"]
    assert writing["true"]["rms_u_n"] == plain["rms_u_n"]
    # the logs are of the default arm: its identified model is far from the heavy truth
    assert outcome.report["truth"]["p_inside_95"] < 16
    assert writing["tip_error_ratio"] > 2
