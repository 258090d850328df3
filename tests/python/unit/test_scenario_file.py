"""Scenario files of the writing task: one schema, unknown keys named, types and ranges checked,
names that are safe file names and unique within a run; hostile files give ScenarioError (a
BadInputError) naming the file and the key, and the CLI exits 2 before writing anything.

Property test (hypothesis): documents built from the built-in scenario files by perturbing one
field load to exactly the intended value or raise ScenarioError naming the key.
"""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rrr_robot.core.param_names import GROUPS
from rrr_robot.writing.job import WritingJob, prepare
from rrr_robot.writing.scenarios import (
    BUILTIN,
    MAX_SCENARIOS,
    SCENARIO_DIR,
    SCHEMA,
    Scenario,
    check_run,
    load_scenario,
    scenario_from_dict,
)
from toml_support import toml_document, values

BUILTIN_DOCS = {name: tomllib.loads((SCENARIO_DIR / f"{name}.toml").read_text())
                for name in BUILTIN}


def write(tmp_path: Path, doc: dict[str, Any] | str, name: str = "scn.toml") -> Path:
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else toml_document(doc), encoding="utf-8")
    return path


def scenario_error(path: Path) -> str:
    with pytest.raises(rr.ScenarioError) as info:
        load_scenario(str(path))
    assert isinstance(info.value, rr.BadInputError)
    assert str(path) in str(info.value)
    return str(info.value)


def test_builtin_scenarios() -> None:
    pd, ctc, mm = (load_scenario(n) for n in ("pd", "ctc", "mismatch"))
    assert (pd.name, pd.feedforward, ctc.feedforward) == ("pd", False, True)
    assert dict(mm.mismatch) == {"p_rel": 0.15, "kt_rel": -0.10, "f_rel": 0.30}


def test_mismatch_keys_come_from_the_c_parameter_table() -> None:
    assert set(SCHEMA["mismatch"]) == {f"{g}_rel" for g in GROUPS}
    assert {"p_rel", "kt_rel", "f_rel", "w_rel", "b_rel", "u_max_rel", "d1_rel"} <= set(
        SCHEMA["mismatch"])


def test_mismatch_model_is_the_documented_perturbation() -> None:
    """p_k (1 + p_rel (-1)^k), kt (1 + kt_rel), f (1 + f_rel), bit for bit."""
    true = rr.Model.default()
    believed = load_scenario("mismatch").controller_model(true)
    signs = np.array([(-1.0) ** k for k in range(1, 17)])
    np.testing.assert_array_equal(believed.p, true.p * (1.0 + 0.15 * signs))
    np.testing.assert_array_equal(believed.kt, true.kt * (1.0 + -0.10))
    np.testing.assert_array_equal(believed.f, true.f * (1.0 + 0.30))
    np.testing.assert_array_equal(believed.w, true.w)
    other = Scenario("x", "", True, mismatch={"u_max_rel": 0.5, "w_rel": -0.5})
    m = other.controller_model(true)
    assert m.u_max == true.u_max * 1.5
    np.testing.assert_array_equal(m.w, true.w * 0.5)
    with pytest.raises(rr.ScenarioError, match=r"scenario bad: \[mismatch\] makes the "
                       r"controller's model invalid"):
        Scenario("bad", "", True, mismatch={"p_rel": 5.0}).controller_model(true)


def test_a_controller_model_of_its_own_is_what_mismatch_perturbs() -> None:
    """Scenario.believing(model) (rrr writing --controller-robot): the controller starts from
    ``model`` instead of the true one, and [mismatch] perturbs ``model``, bit for bit."""
    true = rr.Model.default()
    own = true.with_params(p=true.p * 1.2, kt=true.kt * 0.9)
    ctc, mismatch = load_scenario("ctc"), load_scenario("mismatch")
    assert ctc.believing(own).controller_model(true) is own
    assert ctc.believing(None).controller_model(true) is true
    believed = mismatch.believing(own).controller_model(true)
    signs = np.array([(-1.0) ** k for k in range(1, 17)])
    np.testing.assert_array_equal(believed.p, own.p * (1.0 + 0.15 * signs))
    np.testing.assert_array_equal(believed.kt, own.kt * (1.0 + -0.10))
    np.testing.assert_array_equal(believed.f, own.f * (1.0 + 0.30))
    assert mismatch.believing(own) == mismatch  # the model is not part of the scenario's file


def test_mismatch_per_value_is_the_documented_perturbation(tmp_path: Path) -> None:
    """One error per value of a group (in its shape): v (1 + rel_v), no alternating sign."""
    true = rr.Model.default()
    rel_p = [0.01 * k - 0.08 for k in range(16)]
    rel_f = [[0.1, -0.2, 0.3], [0.0, 0.5, -0.5], [0.25, 0.0, 1.0]]
    path = tmp_path / "per_value.toml"
    path.write_text('[scenario]\nname = "pv"\nfeedforward = true\n[mismatch]\n'
                    f"p_rel = {rel_p!r}\nf_rel = {rel_f!r}\nkt_rel = [0.1, 0.0, -0.1]\n")
    scn = load_scenario(str(path))
    assert scn.mismatch["p_rel"] == tuple(rel_p)
    believed = scn.controller_model(true)
    np.testing.assert_array_equal(believed.p, true.p * (1.0 + np.array(rel_p)))
    np.testing.assert_array_equal(believed.f, true.f * (1.0 + np.array(rel_f)))
    np.testing.assert_array_equal(believed.kt, true.kt * (1.0 + np.array([0.1, 0.0, -0.1])))
    np.testing.assert_array_equal(believed.w, true.w)
    # the same error for every value, as one number or as an array, differs only for p's signs
    same = Scenario("s", "", True, mismatch={"kt_rel": (0.2, 0.2, 0.2), "p_rel": (0.1,) * 16})
    one = Scenario("o", "", True, mismatch={"kt_rel": 0.2, "p_rel": 0.1})
    np.testing.assert_array_equal(same.controller_model(true).kt, one.controller_model(true).kt)
    np.testing.assert_array_equal(same.controller_model(true).p, true.p * 1.1)


@pytest.mark.parametrize(("text", "message"), [
    # wrong types
    ('[scenario]\nname = 5\nfeedforward = true\n', r"\[scenario\] name must be a safe file name"),
    ('[scenario]\nname = "x"\nfeedforward = "yes"\n',
     r"\[scenario\] feedforward must be true or false, got \"yes\""),
    ('[scenario]\nname = "x"\nfeedforward = 1\n',
     r"\[scenario\] feedforward must be true or false"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = "x"\n',
     r"\[gains\] kp must be an array of 3 numbers, got \"x\""),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\np_rel = "0.1"\n',
     r"\[mismatch\] p_rel must be a finite number > -1 and <= 10, or an array of 16 numbers, "
     r"got \"0.1\""),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nkt_rel = [0.1, 0.2]\n',
     r"\[mismatch\] kt_rel must be an array of 3 numbers, got \[0.1, 0.2\]"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nkt_rel = [0.1, 0.2, -1.5]\n',
     r"\[mismatch\] kt_rel\[3\] must be a finite number > -1 and <= 10, got -1.5"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\n'
     'f_rel = [[0, 0, 0], [0, 0, 0], [0, 1]]\n',
     r"\[mismatch\] f_rel\[3\] must be an array of 3 numbers, got \[0, 1\]"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nu_max_rel = [0.1]\n',
     r"\[mismatch\] u_max_rel must be a finite number > -1 and <= 10, got \[0.1\]"),
    ('[scenario]\nname = "x"\ndescription = 3\nfeedforward = true\n',
     r"\[scenario\] description must be a string"),
    # wrong shapes
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = [1, 2]\n',
     r"\[gains\] kp must be an array of 3 numbers, got \[1, 2\]"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkd = [[1], [2], [3]]\n',
     r"\[gains\] kd\[1\] must be a finite number >= 0"),
    ('[scenario]\nname = ["x"]\nfeedforward = true\n', r"\[scenario\] name must be"),
    # NaN / Inf / huge
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = [1, nan, 1]\n',
     r"\[gains\] kp\[2\] must be .*got nan"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nkt_rel = inf\n',
     r"\[mismatch\] kt_rel must be .*got inf"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = [1e7, 1, 1]\n',
     r"\[gains\] kp\[1\] must be a finite number >= 0 and <= 1e6"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nf_rel = -1\n',
     r"\[mismatch\] f_rel must be a finite number > -1"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = [1, 1, '
     + "1" * 500 + "]\n", r"\[gains\] kp\[3\] .*an integer of about 500 digits"),
    # deep nesting
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\np_rel = ' + "[" * 50 + "0.1"
     + "]" * 50 + "\n", r"\[mismatch\] p_rel must be .*got \[\["),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\np_rel = ' + "[" * 5000 + "]" * 5000
     + "\n", r"malformed scenario file: not valid TOML \(arrays or tables nested too deeply\)"),
    # missing tables and keys, unknown ones
    ('[gains]\nkp = [1, 2, 3]\n', r"needs a \[scenario\] table with name and feedforward "
     r"\(missing: name, feedforward\)"),
    ('[scenario]\nname = "x"\n', r"needs a \[scenario\] table .*\(missing: feedforward\)"),
    ('[scenario]\nname = "x"\nfeedforward = true\ncolor = 1\n',
     r"unknown key color in \[scenario\] \(allowed: name, description, feedforward\)"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[mismatch]\nq_rel = 0.1\n',
     r"unknown key q_rel in \[mismatch\] \(allowed: d1_rel, .*u_max_rel\)"),
    ('[scenario]\nname = "x"\nfeedforward = true\n[plant]\nx = 1\n',
     r"unknown table \[plant\] \(allowed: scenario, gains, mismatch\)"),
    ('name = "x"\n[scenario]\nname = "x"\nfeedforward = true\n',
     r"unknown key name at the top level"),
    ('gains = 1\n[scenario]\nname = "x"\nfeedforward = true\n', r"\[gains\] must be a table"),
])
def test_bad_scenario_files(tmp_path: Path, text: str, message: str) -> None:
    got = scenario_error(write(tmp_path, text))
    assert re.search(message, got), got


@pytest.mark.parametrize("name", [
    "../evil", "a/b", "a\\b", "/abs", ".", "..", "", " x", "x ", "x.", ".hidden", "-x", "_x",
    "x" * 65, "a\nb", "a\x00b", "\u03c9", "C:x", "con", "NUL", "com1.txt", "lpt9",
])
def test_unsafe_scenario_names(tmp_path: Path, name: str) -> None:
    doc = {"scenario": {"name": name, "feedforward": True}}
    got = scenario_error(write(tmp_path, doc))
    assert "[scenario] name" in got


@pytest.mark.parametrize("name", ["a", "ctc_2", "my.scenario-1", "X" * 64, "9", "con2"])
def test_safe_scenario_names(tmp_path: Path, name: str) -> None:
    doc = {"scenario": {"name": name, "feedforward": True}}
    assert load_scenario(str(write(tmp_path, doc))).name == name


def test_duplicate_and_too_many_scenarios(tmp_path: Path) -> None:
    dup = write(tmp_path, {"scenario": {"name": "ctc", "feedforward": True}}, "dup.toml")
    upper = write(tmp_path, {"scenario": {"name": "CTC", "feedforward": True}}, "upper.toml")
    for scenarios, message in (
        (["ctc", str(dup)], r"scenarios 'ctc' \(.*ctc.toml\) and 'ctc' \(.*dup.toml\) have the "
                            "same name"),
        (["ctc", "ctc"], "have the same name"),
        (["ctc", str(upper)], "names that differ only in case"),
    ):
        with pytest.raises(rr.ScenarioError, match=message):
            prepare(WritingJob(out=tmp_path / "o", scenarios=scenarios))
    many = [Scenario(f"s{i}", "", True) for i in range(MAX_SCENARIOS + 1)]
    with pytest.raises(rr.ScenarioError, match=f"at most {MAX_SCENARIOS}"):
        check_run(many)
    with pytest.raises(rr.ScenarioError, match="at least one"):
        check_run([])
    assert not (tmp_path / "o").exists()


# ---- property test ----------------------------------------------------------------------------
@st.composite
def perturbed(draw: st.DrawFn) -> tuple[dict[str, Any], str, str, Any]:
    base = BUILTIN_DOCS[draw(st.sampled_from(BUILTIN))]
    doc = copy.deepcopy(base)
    doc.setdefault("gains", {"kp": [40.0, 100.0, 40.0], "kd": [1.5, 4.0, 1.5]})
    kind = draw(st.sampled_from(["replace", "element", "add", "drop_key", "drop_table",
                                 "nest", "name"]))
    paths = [(t, k) for t, table in doc.items() for k in table]
    table, key = draw(st.sampled_from(paths))
    if kind == "drop_table":
        del doc[table]
        return doc, table, "", None
    if kind == "drop_key":
        del doc[table][key]
        return doc, table, key, None
    if kind == "add":   # a known key of the schema (maybe a new one) or an unknown one
        table = draw(st.sampled_from(list(SCHEMA)))
        key = draw(st.sampled_from([*SCHEMA[table], "zz", "P_rel"]))
        new = draw(st.one_of(values, st.floats(min_value=-2, max_value=20)))
        doc.setdefault(table, {})[key] = new
        return doc, table, key, new
    if kind == "name":
        new = draw(st.one_of(
            st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=70),
            st.from_regex(r"[A-Za-z0-9_.\-/\\ ]{0,70}", fullmatch=True)))
        doc["scenario"]["name"] = new
        return doc, "scenario", "name", new
    old = doc[table][key]
    if kind == "nest":
        new = old
        for _ in range(draw(st.integers(min_value=1, max_value=40))):
            new = [new]
    elif kind == "element" and isinstance(old, list):
        new = copy.deepcopy(old)
        new[draw(st.integers(min_value=0, max_value=len(old) - 1))] = draw(values)
    else:
        new = draw(values)
    doc[table][key] = new
    return doc, table, key, new


def _same(loaded: Any, intended: Any) -> bool:
    if isinstance(intended, str | bool) or isinstance(loaded, str | bool):
        return loaded == intended and type(loaded) is type(intended)
    return bool(np.array_equal(np.asarray(loaded, dtype=float),
                               np.asarray(intended, dtype=float)))


@settings(max_examples=400, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=perturbed())
def test_property_perturbed_scenarios(tmp_path: Path, case: Any) -> None:
    doc, table, key, intended = case
    path = write(tmp_path, doc)
    try:
        scn = load_scenario(str(path))
    except rr.ScenarioError as exc:
        text = str(exc)
        assert str(path) in text
        if "nested too deeply" in text:
            return
        named = [f"[{table}]" if table.isidentifier() else table]
        if key:
            named.append(key if key.isidentifier() else json.dumps(key)[1:-1])
        assert all(n in text for n in named) or (table == "scenario" and key == "" and
                                                 "needs a [scenario] table" in text), text
        return
    except Exception as exc:  # pragma: no cover - the property's failure
        raise AssertionError(f"{type(exc).__name__}: {exc}") from exc
    assert key not in ("zz", "P_rel")
    loaded: dict[str, dict[str, Any]] = {
        "scenario": {"name": scn.name, "description": scn.description,
                     "feedforward": scn.feedforward},
        "gains": {k: v for k, v in (("kp", scn.kp), ("kd", scn.kd)) if v is not None},
        "mismatch": dict(scn.mismatch),
    }
    if intended is None:
        assert key not in loaded[table] or (table, key) == ("scenario", "description")
        if not key:
            assert not loaded[table] or table == "scenario"
        return
    assert _same(loaded[table][key], intended), (table, key, loaded[table][key], intended)
    if (table, key) == ("scenario", "name"):
        assert "/" not in intended and "\\" not in intended and intended not in (".", "..")
        assert re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}", intended)
    if table == "mismatch":  # one error, or one per value of the group
        errors = np.asarray(intended, dtype=float)
        assert np.all(np.isfinite(errors)) and np.all((errors > -1) & (errors <= 10))


@settings(max_examples=200, deadline=None)
@given(data=values)
def test_property_any_document_gives_the_packages_error(data: Any) -> None:
    try:
        scenario_from_dict(data if isinstance(data, dict) else {"scenario": data}, "doc")
    except rr.ScenarioError as exc:
        assert str(exc).startswith("doc: ")


# ---- the CLI ----------------------------------------------------------------------------------
@pytest.mark.parametrize(("scenario", "needles"), [
    ('[scenario]\nname = "../../escape"\nfeedforward = true\n', ["[scenario] name must be"]),
    ('[scenario]\nname = "x"\nfeedforward = "no"\n', ["[scenario] feedforward must be true"]),
    ('[scenario]\nname = "x"\nfeedforward = true\n[gains]\nkp = [1, nan, 1]\n', ["kp[2]"]),
    ('[scenario\n', ["malformed scenario file"]),
    ('[scenario]\nname = "ctc"\nfeedforward = true\n', ["have the same name"]),
])
def test_cli_bad_scenario_exits_2_and_writes_nothing(tmp_path: Path, scenario: str,
                                                     needles: list[str]) -> None:
    bad = write(tmp_path, scenario, "bad.toml")
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--quiet",
                             "--scenario", "ctc", "--scenario", str(bad), "--out", str(out)],
                            capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rrr: error: "), result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert str(bad) in lines[0]
    assert not out.exists() and not (tmp_path / "escape.csv").exists()
