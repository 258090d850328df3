"""The sweep spec, the runs' values and what a run records, without a Dask cluster: every bad
spec is refused with a message naming the file and the key; each run's values depend on the
spec and the run's index only; a run's values go through the scenario file's own checks; a
failing run is a row; the sensitivity ranking finds the input that matters; the results
dataset reads back as written (tests/python/jobs/test_sweep_dask.py runs sweeps on Dask)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.cli import main
from rrr_robot.core.checked import load_toml
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.sweep import runs as sweep_runs
from rrr_robot.sweep.job import make_plan
from rrr_robot.sweep.results import read_results, schema, write_part
from rrr_robot.sweep.runs import METRICS, run_one
from rrr_robot.sweep.sampling import RunInput, design, run_seed
from rrr_robot.sweep.sensitivity import Input, rank
from rrr_robot.sweep.spec import read_spec, spec_from_dict
from rrr_robot.writing.scenarios import scenario_from_dict

HEAD = '[sweep]\nbase = "ctc"\nsamples = 5\nseed = 3\n'


def spec_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(("text", "message"), [
    # the [sweep] table
    ('[vary]\n', r"missing table \[sweep\]"),
    ('[sweep]\nsamples = 3\n', r"missing key 'base' in \[sweep\]"),
    ('[sweep]\nbase = "ctc"\n', r"missing key 'samples' in \[sweep\]"),
    ('[sweep]\nbase = "ctc"\nsamples = 0\n', r"\[sweep\] samples must be a whole number >= 1"),
    ('[sweep]\nbase = "ctc"\nsamples = -4\n', r"\[sweep\] samples must be a whole number >= 1"),
    ('[sweep]\nbase = "ctc"\nsamples = 2.5\n', r"\[sweep\] samples must be a whole number"),
    ('[sweep]\nbase = "ctc"\nsamples = "10"\n', r"\[sweep\] samples must be a whole number"),
    ('[sweep]\nbase = "ctc"\nsamples = 2000000\n', r"samples must be .*<= 1e6"),
    ('[sweep]\nbase = "ctc"\nsamples = 3\nseed = -1\n', r"\[sweep\] seed must be"),
    ('[sweep]\nbase = "ctc"\nsamples = 3\nseed = 1.5\n', r"\[sweep\] seed must be"),
    ('[sweep]\nbase = "ctc"\nsamples = 3\nmethod = "sobol"\n',
     r'\[sweep\] method must be one of "random", "lhs", "grid", got "sobol"'),
    ('[sweep]\nbase = 3\nsamples = 3\n', r"\[sweep\] base must be"),
    ('[sweep]\nbase = "ctc"\nsamples = 3\nworkers = 2\n', r"unknown key workers in \[sweep\]"),
    ('[sweep]\nbase = "ctc"\nsamples = 3\n[runs]\n', r"unknown table \[runs\]"),
    # [vary] keys and distributions
    (HEAD + '[vary]\n"mismatch.q_rel" = { uniform = [0, 1] }\n',
     r'\[vary\] "mismatch.q_rel": unknown key \(keys: .*mismatch.p_rel'),
    (HEAD + '[vary]\n"scenario.name" = { values = ["a", "b"] }\n',
     r'\[vary\] "scenario.name": unknown key'),
    (HEAD + '[vary]\n"mismatch.p_rel" = { unifrom = [0, 0.1] }\n',
     r'"mismatch.p_rel": unknown distribution "unifrom" \(one of uniform, loguniform, normal, '
     r'values'),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [0, 0.1], normal = [0, 1] }\n',
     r'"mismatch.p_rel": needs exactly one distribution .*got 2'),
    (HEAD + '[vary]\n"mismatch.p_rel" = { per_element = true }\n',
     r'"mismatch.p_rel": needs exactly one distribution'),
    (HEAD + '[vary]\n"mismatch.p_rel" = 0.1\n', r'"mismatch.p_rel": must be a table'),
    # wrong types and values
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [0.2, 0.1] }\n',
     r"uniform needs low < high, got \[0.2, 0.1\]"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [0.1] }\n',
     r"uniform must be \[low, high\], two finite numbers, got \[0.1\]"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = ["a", 1] }\n',
     r"uniform must be \[low, high\], two finite numbers"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [0, nan] }\n',
     r"uniform must be \[low, high\], two finite numbers"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [-1.5, 0.1] }\n',
     r"uniform low must be a finite number > -1 and <= 10 \(a value of mismatch.p_rel\), "
     r"got -1.5"),
    (HEAD + '[vary]\n"mismatch.kt_rel" = { normal = [0, 0] }\n', r"normal std must be > 0"),
    (HEAD + '[vary]\n"mismatch.kt_rel" = { normal = [12, 1] }\n', r"normal mean must be"),
    (HEAD + '[vary]\n"gains.kp" = { loguniform = [0, 10], per_element = true }\n',
     r"loguniform needs low > 0"),
    (HEAD + '[vary]\n"gains.kp" = { uniform = [10, 20] }\n',
     r"gains.kp is an array of 3 numbers: draw each element with per_element = true"),
    (HEAD + '[vary]\n"gains.kp" = { values = [[1, 2]] }\n',
     r'"gains.kp": values\[1\] must be an array of 3 numbers \(a value of gains.kp\)'),
    (HEAD + '[vary]\n"gains.kp" = { values = [[1, 2, -3]] }\n',
     r'"gains.kp": values\[1\]\[3\] must be a finite number >= 0'),
    (HEAD + '[vary]\n"gains.kp" = { values = [] }\n', r"values must be an array of 1 to"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { values = [0.1, [0.1, 0.1]] }\n',
     r"values\[2\] must be an array of 16 numbers"),
    (HEAD + '[vary]\n"mismatch.kt_rel" = { values = [0.1, [0.1, 0.1, 0.1]] }\n',
     r"values must all be numbers or all be arrays"),
    (HEAD + '[vary]\n"mismatch.u_max_rel" = { uniform = [0, 1], per_element = true }\n',
     r"per_element applies to fields with several numbers; mismatch.u_max_rel is a finite "
     r"number"),
    (HEAD + '[vary]\n"mismatch.p_rel" = { uniform = [0, 0.1], per_element = "yes" }\n',
     r'per_element must be true or false, got "yes"'),
    (HEAD + '[vary]\n"writing.text" = { uniform = [0, 1] }\n',
     r"writing.text is a non-blank string .*: list its values with values = \[...\]"),
    (HEAD + '[vary]\n"writing.text" = { values = ["ok", 3] }\n',
     r"values\[2\] must be a non-blank string"),
    (HEAD + '[vary]\n"writing.scale" = { uniform = [0, 2] }\n', r"uniform low must be"),
    (HEAD + '[vary]\n"scenario.feedforward" = { values = [true, "no"] }\n',
     r"values\[2\] must be true or false"),
    # grids
    ('[sweep]\nbase = "ctc"\nmethod = "grid"\n[vary]\n"mismatch.p_rel" = { uniform = [0, 1] }\n',
     r"a grid varies whole values: give values"),
    ('[sweep]\nbase = "ctc"\nmethod = "grid"\nsamples = 3\n[vary]\n'
     '"mismatch.p_rel" = { values = [0, 0.1] }\n"gains.kd" = { values = [[1, 1, 1], [2, 2, 2]] }'
     '\n', r"\[sweep\] samples = 3, but the grid has 4 points"),
    # the file itself
    ("[sweep\nbase = 1\n", r"malformed sweep spec: not valid TOML"),
])
def test_a_bad_spec_is_refused_naming_the_file_and_the_key(tmp_path: Path, text: str,
                                                           message: str) -> None:
    path = spec_file(tmp_path, text)
    with pytest.raises(rr.SweepSpecError, match=message) as info:
        read_spec(path)
    assert str(info.value).startswith(f"{path}: ")


def test_a_bad_spec_stops_the_command_with_exit_2_before_anything_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = spec_file(tmp_path, HEAD + '[vary]\n"mismatch.p_rel" = { gauss = [0, 1] }\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rrr: error: ") and "gauss" in err[0], err
    assert not out.exists()
    # a base scenario that does not exist, and a base run that cannot run: the same
    for head, needle in (('base = "nowhere.toml"', "unknown scenario"),
                         ('base = "ctc"\nrobot = "missing.toml"', "missing.toml")):
        path = spec_file(tmp_path, HEAD.replace('base = "ctc"', head))
        assert main(["sweep", str(path), "--out", str(out), "-q"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], err
        assert not out.exists()


def test_dotted_keys_without_quotes_and_vary_subtables_are_the_same_keys(tmp_path: Path) -> None:
    quoted = read_spec(spec_file(tmp_path, HEAD + '[vary]\n"mismatch.p_rel" = { uniform = '
                                 '[0, 0.1] }\n"gains.kp" = { uniform = [1, 9], per_element = '
                                 'true }\n'))
    dotted = read_spec(spec_file(tmp_path, HEAD + "[vary]\nmismatch.p_rel = { uniform = "
                                 "[0, 0.1] }\n[vary.gains]\nkp = { uniform = [1, 9], "
                                 "per_element = true }\n"))
    assert quoted.identity() == dotted.identity()
    assert [v.key for v in dotted.vary] == ["mismatch.p_rel", "gains.kp"]


# ---- the runs' values -----------------------------------------------------------------------
VARY = ('[vary]\n"mismatch.p_rel" = { uniform = [-0.1, 0.1] }\n'
        '"mismatch.kt_rel" = { normal = [0.0, 0.05] }\n'
        '"mismatch.f_rel" = { normal = [0.0, 0.1], per_element = true }\n'
        '"gains.kp" = { values = [[20.0, 50.0, 20.0], [40.0, 100.0, 40.0]] }\n'
        '"gains.kd" = { loguniform = [1.0, 5.0], per_element = true }\n'
        '"writing.text" = { values = ["am", "ma"] }\n'
        '"scenario.feedforward" = { values = [true, false] }\n')


def test_each_runs_values_come_from_the_seed_and_its_index_only(tmp_path: Path) -> None:
    spec = read_spec(spec_file(tmp_path, HEAD + VARY))
    runs = design(spec)
    assert [r.run for r in runs] == list(range(5))
    assert runs == design(spec)  # the same spec: the same values
    more = design(dataclasses.replace(spec, samples=40))
    assert more[:5] == runs  # run k does not depend on the number of runs
    other = design(dataclasses.replace(spec, seed=4))
    assert all(a.values != b.values for a, b in zip(runs, other, strict=True))
    assert len({r.seed for r in more}) == 40 and runs[2].seed == run_seed(3, 2)
    # run k's draws are numpy's default_rng(seed_k) in [vary] order
    rng = np.random.default_rng(runs[1].seed)
    values = dict(runs[1].values)
    assert values["mismatch.p_rel"] == rng.uniform(-0.1, 0.1, size=1)[0]
    assert values["mismatch.kt_rel"] == rng.normal(0.0, 0.05, size=1)[0]
    f = rng.normal(0.0, 0.1, size=9)
    assert values["mismatch.f_rel"] == tuple(tuple(f[3 * i:3 * i + 3]) for i in range(3))
    assert {r.values[3][1] for r in more} == {(20.0, 50.0, 20.0), (40.0, 100.0, 40.0)}
    assert all(1.0 <= kd <= 5.0 for r in more for kd in dict(r.values)["gains.kd"])
    assert {dict(r.values)["writing.text"] for r in more} == {"am", "ma"}


def test_a_latin_hypercube_has_one_run_in_each_stratum_of_each_draw(tmp_path: Path) -> None:
    text = HEAD.replace("samples = 5", "samples = 50\nmethod = \"lhs\"") + VARY
    spec = read_spec(spec_file(tmp_path, text))
    runs = design(spec)
    assert runs == design(spec) and len(runs) == 50
    p = np.array([dict(r.values)["mismatch.p_rel"] for r in runs])
    strata = np.floor((p + 0.1) / 0.2 * 50).astype(int)
    assert sorted(strata) == list(range(50))
    kd = np.array([dict(r.values)["gains.kd"] for r in runs])  # each element its own dimension
    for j in range(3):
        u = np.log(kd[:, j]) / np.log(5.0)
        assert sorted(np.floor(u * 50).astype(int)) == list(range(50))
    texts = [dict(r.values)["writing.text"] for r in runs]
    assert texts.count("am") == texts.count("ma") == 25


def test_a_grid_is_every_combination_last_key_fastest(tmp_path: Path) -> None:
    spec = read_spec(spec_file(tmp_path, '[sweep]\nbase = "ctc"\nmethod = "grid"\n[vary]\n'
                               '"mismatch.p_rel" = { values = [0.0, 0.1] }\n'
                               '"writing.text" = { values = ["am", "ma", "mm"] }\n'))
    assert spec.samples == 6
    runs = design(spec)
    assert [tuple(v for _, v in r.values) for r in runs] == [
        (0.0, "am"), (0.0, "ma"), (0.0, "mm"), (0.1, "am"), (0.1, "ma"), (0.1, "mm")]


def test_every_drawn_value_is_one_a_scenario_file_may_hold(tmp_path: Path) -> None:
    spec = read_spec(spec_file(tmp_path, HEAD.replace("samples = 5", "samples = 30") + VARY))
    base = load_toml(Path(rr.__file__).parent / "data/scenarios/ctc.toml", "s", rr.ScenarioError)
    for r in design(spec):
        tables = {k: dict(v) for k, v in base.items()}
        for key, value in r.values:
            table, name = key.split(".")
            if table != "writing":
                tables.setdefault(table, {})[name] = value
        scn = scenario_from_dict(tables, "run")
        values = dict(r.values)
        assert scn.kp == values["gains.kp"] and scn.kd == values["gains.kd"]
        assert scn.mismatch["f_rel"] == values["mismatch.f_rel"]


# ---- one run ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def plan() -> sweep_runs.SweepPlan:
    spec = spec_from_dict({"sweep": {"base": "ctc", "samples": 1}}, "spec.toml")
    return make_plan(spec, "native")


def test_a_runs_value_out_of_range_is_refused_as_a_scenario_file_refuses_it(
        plan: sweep_runs.SweepPlan) -> None:
    row = run_one(plan, RunInput(7, 1, (("mismatch.kt_rel", -1.5),)))
    assert row["status"] == "invalid" and row["run"] == 7
    assert row["error"] == ("ScenarioError: scenario ctc (run 7): [mismatch] kt_rel must be a "
                            "finite number > -1 and <= 10, got -1.5")
    assert all(row[m] is None for m in METRICS if m != "wall_time") and row["wall_time"] > 0
    bad = run_one(plan, RunInput(8, 1, (("mismatch.p_rel", 5.0),)))
    assert bad["status"] == "invalid" and "RRR_NOT_POSITIVE_DEFINITE" in bad["error"]
    far = run_one(plan, RunInput(9, 1, (("writing.scale", 6.0),)))
    assert far["status"] == "invalid" and "writing area" in far["error"], far["error"]


def test_a_run_that_raises_in_the_closed_loop_is_a_failed_row(
        plan: sweep_runs.SweepPlan, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(engine: str, ref: object, options: object) -> None:
        raise rr.CosimError("plant: fmi2DoStep returned ERROR at t = 1.234 s")

    monkeypatch.setattr(sweep_runs, "run_engine", broken)
    row = run_one(plan, RunInput(3, 5, (("mismatch.p_rel", 0.05),)))
    assert row["status"] == "failed"
    assert row["error"] == "CosimError: plant: fmi2DoStep returned ERROR at t = 1.234 s"
    assert row["mismatch.p_rel"] == 0.05 and row["tip_error_max"] is None


def test_a_run_whose_motion_is_not_finite_is_a_diverged_row(
        plan: sweep_runs.SweepPlan, monkeypatch: pytest.MonkeyPatch) -> None:
    engine = sweep_runs.run_engine

    def blown_up(name: str, ref: object, options: object) -> object:
        res = engine(name, ref, options)  # type: ignore[arg-type]
        res.tip[100:, 2] = np.inf  # the tip leaves for infinity at sample 100
        return res

    monkeypatch.setattr(sweep_runs, "run_engine", blown_up)
    row = run_one(plan, RunInput(4, 2, ()))
    assert row["status"] == "diverged"
    assert row["error"] == "not finite: tip_error_max, tip_error_rms"
    assert row["tip_error_max"] is None and row["tip_error_rms"] is None
    assert row["rms_u_n[2]"] is not None and row["u_peak[1]"] is not None


def test_a_saturated_run_is_recorded_with_its_peak_voltage_and_time_at_the_limit(
        plan: sweep_runs.SweepPlan) -> None:
    ok = run_one(plan, RunInput(0, 1, ()))
    assert ok["status"] == "ok" and ok["saturated_fraction"] == 0.0 and ok["error"] is None
    u_max = rr.Model.default().u_max
    assert 0 < ok["u_peak[2]"] < u_max
    # the controller believes its voltage limit is 5 % of the true one: u is clipped there
    row = run_one(plan, RunInput(1, 1, (("mismatch.u_max_rel", -0.95),)))
    assert row["status"] == "saturated", row["error"]
    assert row["error"].startswith("u[1], u[2], u[3] reached +-0.5 V (the controller's model's "
                                   "u_max) on ") and row["error"].endswith(" % of the samples")
    limit = 0.05 * u_max
    assert max(row[f"u_peak[{i}]"] for i in (1, 2, 3)) == pytest.approx(limit, rel=1e-12)
    assert 0 < row["saturated_fraction[2]"] <= row["saturated_fraction"] <= 1
    assert row["tip_error_max"] > ok["tip_error_max"]


# ---- the ranking -----------------------------------------------------------------------------
def test_the_ranking_finds_the_input_that_matters() -> None:
    rng = np.random.default_rng(0)
    n = 400
    x1, x2, x3 = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    cat = rng.integers(0, 3, n)
    y = 3.0 * x1 ** 2 + 1.0 * x2 + 0.5 * cat + 0.05 * rng.normal(size=n)
    y[:7] = np.nan  # runs without a finite error do not count
    inps = [Input("x1", x1), Input("x2", x2), Input("x3", x3),
            Input("cat", cat.astype(float), ("a", "b", "c")), Input("const", np.ones(n))]
    ranking = rank(inps, y)
    assert [s.input for s in ranking] == ["x1", "x2", "cat", "x3"]  # const does not vary
    s = {r.input: r for r in ranking}
    assert s["x1"].s1 > 0.6 and s["x3"].s1 < 3 * s["x3"].noise_floor
    assert s["x1"].runs == n - 7 and s["cat"].groups == 3 and s["cat"].spearman is None
    assert abs(s["x1"].spearman) < 0.2 < s["x2"].spearman  # rho misses the even effect


# ---- the results dataset ---------------------------------------------------------------------
def test_parts_read_back_as_written_in_run_order(tmp_path: Path) -> None:
    import pandas as pd

    spec = read_spec(spec_file(tmp_path, HEAD + VARY))
    arrow_schema = schema(spec.vary)
    rows = []
    for r in design(spec):
        row = {"run": r.run, "seed": r.seed, "status": "ok", "error": None, **dict(r.values)}
        rows.append(row | {m: float(r.run) for m in METRICS})
    rows[4] |= {"status": "failed", "error": "CosimError: x", "tip_error_max": None}
    folder = tmp_path / "results.parquet"
    write_part(folder, rows[3:], arrow_schema)
    write_part(folder, rows[:3], arrow_schema)
    (folder / ".rrr-tmp-1-00000000-part-x.parquet.part").write_bytes(b"half a file")
    df = pd.read_parquet(folder)
    assert list(df.columns) == arrow_schema.names
    assert sorted(df["run"]) == list(range(5))
    table = read_results(folder, arrow_schema)
    assert table.column("run").to_pylist() == list(range(5))
    got = table.to_pylist()
    assert got[4]["tip_error_max"] is None and got[4]["error"] == "CosimError: x"
    assert got[1]["mismatch.f_rel"] == [list(row) for row in rows[1]["mismatch.f_rel"]]
    assert got[2]["gains.kp"] == list(rows[2]["gains.kp"])
    assert got[0]["writing.text"] in ("am", "ma") and got[0]["scenario.feedforward"] in (
        True, False)
    write_part(folder, rows[:1], arrow_schema)  # run 0 twice: not one sweep's results
    with pytest.raises(rr.BadInputError, match="the same run appears in two part files"):
        read_results(folder, arrow_schema)


def test_the_robot_file_is_read_once_on_the_client_for_the_workers(
        plan: sweep_runs.SweepPlan) -> None:
    assert plan.robot == load_toml(DEFAULT_ROBOT_TOML, "robot file", rr.RobotFileError)
    assert plan.base["scenario"]["name"] == "ctc" and plan.engine == "native"
    assert len(plan.fingerprint) == 64


def test_a_controller_robot_gives_every_run_the_controller_of_rrr_writing_controller_robot(
        tmp_path: Path, plan: sweep_runs.SweepPlan) -> None:
    """[sweep] controller_robot (relative to the spec's folder): a run is rrr writing --robot
    <robot> --controller-robot <file> bit for bit (its tip error and voltages), and the file's
    tables join the sweep's fingerprint; a spec without it keeps its identity as before."""
    from rrr_robot.writing.job import WritingJob, run_writing

    text = DEFAULT_ROBOT_TOML.read_text(encoding="utf-8")
    (tmp_path / "heavy.toml").write_text(text.replace("\nmass = 2.5\n", "\nmass = 4.0\n"),
                                         encoding="utf-8")
    (tmp_path / "default.toml").write_text(text, encoding="utf-8")
    spec = read_spec(spec_file(tmp_path, '[sweep]\nbase = "ctc"\nsamples = 1\nrobot = '
                               '"heavy.toml"\ncontroller_robot = "default.toml"\n'))
    assert spec.identity()["controller_robot"] == "default.toml"
    assert "controller_robot" not in spec_from_dict(
        {"sweep": {"base": "ctc", "samples": 1}}, "spec.toml").identity()
    mixed = make_plan(spec, "native")
    assert mixed.controller_robot == load_toml(tmp_path / "default.toml", "robot file",
                                               rr.RobotFileError)
    alone = make_plan(dataclasses.replace(spec, controller_robot=None), "native")
    assert alone.controller_robot is None and alone.fingerprint != mixed.fingerprint
    row = run_one(mixed, RunInput(0, 1, ()))
    writing = run_writing(WritingJob(out=tmp_path / "w", scenarios=["ctc"], engine="native",
                                     figures=False, robot=tmp_path / "heavy.toml",
                                     controller_robot=tmp_path / "default.toml"))
    ctc = writing["scenarios"]["ctc"]
    assert row["status"] == "ok" and row["tip_error_max"] == ctc["tip_error_max"]
    assert [row[f"rms_u_n[{i}]"] for i in (1, 2, 3)] == ctc["rms_u_n"]
    # the mismatch the user asked for: far from the plant's own model (the base plan's run)
    assert row["tip_error_max"] > 10 * run_one(plan, RunInput(0, 1, ()))["tip_error_max"]


def test_a_scheduler_that_cannot_be_reached_stops_the_sweep_before_anything_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    from rrr_robot.sweep import execution

    monkeypatch.setattr(execution, "CONNECT_TIMEOUT", 1.0)
    path = spec_file(tmp_path, HEAD)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--scheduler", "tcp://127.0.0.1:1",
                 "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["rrr: error: cannot connect to the Dask scheduler at tcp://127.0.0.1:1: "
                   "[Errno 111] Connection refused"], err
    assert not out.exists()


def test_a_lost_batch_is_not_recorded_and_resume_runs_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A task that does not come back (its worker died more often than Dask retries) ends the
    command with an error after the other batches are recorded; --resume runs the rest. Here
    the cluster is in this process, so that the task can be made to fail."""
    import contextlib
    from collections.abc import Iterator

    from distributed import Client, LocalCluster
    from rrr_robot.sweep import execution

    @contextlib.contextmanager
    def in_process(workers: int | None = None, scheduler: str | None = None) -> Iterator[Client]:
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            yield client

    def lost_at_run_2(plan: sweep_runs.SweepPlan, inputs: list[RunInput]) -> list[dict]:
        if inputs[0].run == 2:
            raise RuntimeError("the worker running it died")
        return sweep_runs.run_batch(plan, inputs)

    monkeypatch.setattr(execution, "dask_client", in_process)
    monkeypatch.setattr(execution, "run_batch", lost_at_run_2)
    path = spec_file(tmp_path, HEAD.replace("samples = 5", "samples = 4") +
                     '[vary]\n"mismatch.p_rel" = { uniform = [0.0, 0.1] }\n')
    out = tmp_path / "out"
    args = ["sweep", str(path), "--out", str(out), "--engine", "native", "--batch", "1", "-q",
            "--no-figures"]
    assert main(args) == 2
    # the last line is the command's one error line; before it, -q leaves the log's warnings
    # and errors (Dask's report of the failed task, the sweep's lost batch), no INFO line
    err = capsys.readouterr().err.strip().splitlines()
    assert [e for e in err if e.startswith("rrr: error:")] == [err[-1]], err
    assert err[-1].startswith("rrr: error: 1 of 4 runs were not recorded: 1 batch lost (first: "
                              "RuntimeError: the worker running it died)"), err
    assert "rerun with --resume" in err[-1]
    assert not any(e.startswith("INFO ") for e in err), err
    import pandas as pd

    assert sorted(pd.read_parquet(out / "results.parquet")["run"]) == [0, 1, 3]
    assert not (out / "summary.json").exists()
    monkeypatch.setattr(execution, "run_batch", sweep_runs.run_batch)  # the worker is back
    assert main([*args, "--resume"]) == 0
    assert sorted(pd.read_parquet(out / "results.parquet")["run"]) == [0, 1, 2, 3]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 4 and summary["this_invocation"]["runs"] == 1


def test_every_varied_key_has_its_panel_in_the_dependence_figure() -> None:
    from rrr_robot.sweep.figures import MAX_PANELS, _panels
    from rrr_robot.sweep.sensitivity import Sensitivity

    names = [f"mismatch.f_rel[{i},{k}]" for i in (1, 2, 3) for k in (1, 2, 3)]
    names += ["mismatch.p_rel[1]", "mismatch.p_rel[2]", "mismatch.p_rel[3]", "mismatch.p_rel[4]",
              "gains.kp", "writing.text"]
    ranking = [Sensitivity(n, 1.0 - 0.01 * i, None, 50, 7, 0.1) for i, n in enumerate(names)]
    shown = [s.input for s in _panels(ranking)]
    assert len(shown) == MAX_PANELS == 12
    assert {"gains.kp", "writing.text", "mismatch.p_rel[1]"} <= set(shown)
    assert shown == [n for n in names if n in shown]  # in ranking order
    assert "mismatch.f_rel[3,3]" in shown and "mismatch.p_rel[2]" not in shown
