"""The example sweep specs that ship with the package (rrr_robot/data/sweeps/): ``rrr sweep
--help`` names each, ``rrr sweep --example NAME`` prints it byte for byte, and each runs as it
is, whole (native engine, one local worker: seconds each), every run ``ok``."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from rrr_robot.cli import build_parser, main
from rrr_robot.sweep.examples import EXAMPLES_DIR, example_path, example_summary, examples
from rrr_robot.sweep.spec import read_spec
from support import REPO

REPO_SWEEPS = REPO / "python" / "rrr_robot" / "data" / "sweeps"
NAMES = ["grid", "lhs", "monte_carlo"]
METHODS = {"grid": "grid", "lhs": "lhs", "monte_carlo": "random"}


def sweep_help() -> str:
    sub = next(a for a in build_parser()._actions if hasattr(a, "choices") and a.choices
               and "sweep" in a.choices)
    return sub.choices["sweep"].format_help()


def test_the_package_ships_the_examples_of_the_repository():
    assert sorted(examples()) == NAMES
    for name, path in examples().items():
        assert path.parent == EXAMPLES_DIR
        assert path.read_bytes() == (REPO_SWEEPS / f"{name}.toml").read_bytes(), name


def test_rrr_sweep_help_names_every_example():
    text = " ".join(sweep_help().split())
    for name, path in examples().items():
        assert f"{name} {example_summary(path)}" in text
        assert example_summary(path)  # each has its one-line title
    assert "rrr sweep --example NAME" in text


@pytest.mark.parametrize("name", NAMES)
def test_rrr_sweep_example_prints_the_spec(name, capsys):
    assert main(["sweep", "--example", name]) == 0
    assert capsys.readouterr().out == example_path(name).read_text(encoding="utf-8")


@pytest.mark.parametrize(("argv", "message"), [
    (["--example", "nope"], "invalid choice: 'nope'"),
    (["--example", "grid", "spec.toml"], "--example prints an example spec: give it alone"),
    (["--example", "grid", "--out", "x"], "--example prints an example spec: give it alone"),
    ([], "the following arguments are required: spec, --out"),
    (["spec.toml"], "the following arguments are required: --out"),
])
def test_bad_example_arguments_are_usage_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["sweep", *argv])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("name", NAMES)
def test_each_example_runs_as_it_is(name, tmp_path, capsys):
    spec = read_spec(example_path(name))
    assert spec.method == METHODS[name]
    out = tmp_path / name
    assert main(["sweep", str(example_path(name)), "--out", str(out), "--engine", "native",
                 "--workers", "1", "--no-figures", "-q"]) == 0
    df = pd.read_parquet(out / "results.parquet").sort_values("run")
    assert df["run"].tolist() == list(range(spec.samples))
    assert (df["status"] == "ok").all(), df.loc[df["status"] != "ok", "error"].tolist()
    assert (df["tip_error_max"] > 0).all()
    for vary in spec.vary:
        assert vary.key in df.columns
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == spec.samples and summary["status"]["ok"] == spec.samples
    ranked = {s["input"].split("[")[0] for s in summary["sensitivity"]["ranking"]}
    assert ranked == {v.key for v in spec.vary}
    assert f"{spec.samples} runs: ok {spec.samples}" in capsys.readouterr().out
