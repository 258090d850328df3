"""The one robot file reader (rrr_robot.core.robot): every table checked once, the
errors name the file, the table and the key; hostile files give the package's error and nothing
else; the default robot loads with the same numbers as the C defaults.

Property tests (hypothesis): documents built from the valid default robot (and from its
[base_parameters] form) by perturbing one field -- wrong types, wrong shapes, NaN/Inf, huge
values, deep nesting, missing tables, unknown keys, valid changes -- either load to exactly the
intended value or raise RobotFileError naming the key; never another exception.
"""

from __future__ import annotations

import copy
import datetime
import json
import math
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
from rrr_robot.core import param_names
from rrr_robot.core.checked import MAX_FILE_BYTES, write_toml
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.core.robot import (
    DEFAULT_SAMPLE_TIME,
    MAX_MAGNITUDE,
    PARAM_TABLES,
    WRITING_FIELDS,
    ControlGains,
    read_robot_file,
)
from rrr_robot.writing.trajectory import WritingSpec
from toml_support import toml_document, values

DEFAULT = tomllib.loads(DEFAULT_ROBOT_TOML.read_text())


def _bp_document() -> dict[str, Any]:
    """The default robot with [base_parameters] instead of the link tables."""
    doc = {k: copy.deepcopy(v) for k, v in DEFAULT.items() if not k.startswith("link")}
    doc["motors"] = {k: v for k, v in doc["motors"].items() if k != "rotor_inertia"}
    doc["base_parameters"] = {"p": rr.Model.default().p.tolist()}
    return doc


BP_DEFAULT = _bp_document()


def write(tmp_path: Path, doc: dict[str, Any] | str, name: str = "robot.toml") -> Path:
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else toml_document(doc), encoding="utf-8")
    return path


def load_error(path: Path) -> str:
    with pytest.raises(rr.RobotFileError) as info:
        rr.read_robot_file(path)
    assert str(info.value).startswith(f"{path}: ") or str(path) in str(info.value)
    return str(info.value)


# ---- the default robot -----------------------------------------------------------------------
def test_default_robot_loads_with_the_c_defaults_numbers() -> None:
    robot = rr.read_robot_file()
    default = rr.Model.default()
    np.testing.assert_array_equal(robot.model.p, default.p)   # bit for bit
    for name in ("kt", "f", "w", "b"):
        np.testing.assert_array_equal(getattr(robot.model, name), getattr(default, name))
    assert robot.model.dh == default.dh and robot.model.g == default.g
    assert robot.control == ControlGains((40.0, 100.0, 40.0), (1.5, 4.0, 1.5), 1e-3)
    assert robot.sample_time == DEFAULT_SAMPLE_TIME == 1e-3
    assert robot.links is not None and robot.links[1].mass == 6.0
    assert dict(robot.writing)["x_range"] == (0.35, 0.65)
    assert WritingSpec.from_robot(robot) == WritingSpec()
    with pytest.raises(AttributeError):
        robot.model = default  # type: ignore[misc]  # frozen


def test_the_same_reader_everywhere(tmp_path: Path) -> None:
    """read_robot_file reads a file and its parsed tables alike: same checks, same numbers."""
    m1 = rr.read_robot_file(DEFAULT_ROBOT_TOML).model
    m2 = rr.read_robot_file(DEFAULT).model
    np.testing.assert_array_equal(m2.p, m1.p)
    bad = copy.deepcopy(DEFAULT)
    bad["control"]["kp"][1] = "abc"
    path = write(tmp_path, bad)
    with pytest.raises(rr.RobotFileError, match=r'\[control\] kp\[2\] must be a finite '
                       r'number >= 0.*got "abc"'):
        rr.read_robot_file(path)
    with pytest.raises(rr.RobotFileError, match=r"^x.toml: \[control\] kp\[2\]"):
        rr.read_robot_file(bad, "x.toml")


def test_no_module_of_the_package_parses_toml_itself() -> None:
    package = Path(rr.__file__).parent
    users = sorted(str(p.relative_to(package)) for p in package.rglob("*.py")
                   if "tomllib" in p.read_text())
    assert users == ["core/checked.py"]


def test_base_parameters_form_loads(tmp_path: Path) -> None:
    robot = rr.read_robot_file(write(tmp_path, BP_DEFAULT))
    np.testing.assert_array_equal(robot.model.p, rr.Model.default().p)
    assert robot.links is None and robot.rotor_inertia is None


def test_round_trips_through_tables(tmp_path: Path) -> None:
    for doc in (DEFAULT, BP_DEFAULT):
        robot = rr.read_robot_file(write(tmp_path, doc))
        again = rr.read_robot_file(write(tmp_path, robot.data.tables(), "again.toml"))
        assert again.data.tables() == robot.data.tables()
        np.testing.assert_array_equal(again.model.p, robot.model.p)


def test_parameter_table_placement_covers_the_c_table() -> None:
    placed = [g for groups in PARAM_TABLES.values() for g in groups]
    assert sorted(placed) == sorted(param_names.GROUPS)
    assert len(param_names.PARAMS) == 47
    assert param_names.param("f[2,3]").unit == "V" and param_names.param_index("p[17]") == -1
    assert param_names.group_shape("f") == (3, 3) and param_names.group_shape("p") == (16,)
    fmu = param_names.model_fmu_values(rr.Model.default())
    assert list(fmu) == [p.name for p in param_names.PARAMS]


def test_writing_schema_matches_writing_spec() -> None:
    from dataclasses import fields

    spec_fields = {f.name for f in fields(WritingSpec)}
    assert set(WRITING_FIELDS) - {"duration_hint"} == spec_fields - {"dt"}


# ---- regressions, one per class of hostile input --------------------------------------------
@pytest.mark.parametrize(("table", "key", "value", "message"), [
    # wrong types
    ("control", "kp", "abc", r"\[control\] kp must be an array of 3 numbers, got \"abc\""),
    ("kinematics", "d1", True, r"\[kinematics\] d1 must be a finite number.*got true"),
    ("kinematics", "a2", datetime.date(2020, 1, 1), r"\[kinematics\] a2 .*got a date"),
    ("gravity", "g", {"x": 1.0}, r"\[gravity\] g must be .*got a table"),
    ("writing", "text", 5, r"\[writing\] text must be a non-blank string"),
    ("writing", "shoulder", "sideways", r"\[writing\] shoulder must be one of \"front\""),
    ("control", "sample_time", "1ms", r"\[control\] sample_time must be a finite number"),
    # wrong shapes
    ("friction", "f", [[0.1, 0.1, 0.1]], r"\[friction\] f must be an array of 3 arrays of 3"),
    ("friction", "w", [[1.0, 1.0, 1.0], [1.0, 1.0], [1.0, 1.0, 1.0]],
     r"\[friction\] w\[2\] must be an array of 3 numbers, got \[1.0, 1.0\]"),
    ("motors", "kt", [1.0, 2.0], r"\[motors\] kt must be an array of 3 numbers"),
    ("motors", "u_max", [10.0], r"\[motors\] u_max must be a finite number > 0"),
    ("writing", "x_range", [0.6, 0.4], r"\[writing\] x_range must be \[low, high\]"),
    # NaN / Inf
    ("link2", "com", [0.1, math.nan, 0.0], r"\[link2\] com\[2\] must be a finite number.*nan"),
    ("control", "kd", [1.0, 1.0, math.inf], r"\[control\] kd\[3\] must be .*got inf"),
    # huge values
    ("kinematics", "a3", 1e300, r"\[kinematics\] a3 must be a finite number > 0 and <= 1e6"),
    ("motors", "kt", [10**400, 1.0, 1.0], r"\[motors\] kt\[1\] .*an integer of about 401 digits"),
    ("control", "kp", [1e7, 1.0, 1.0], r"\[control\] kp\[1\] must be .*<= 1e6"),
    ("writing", "smoothing", 1e6, r"\[writing\] smoothing must be a finite number > 0 and <= 1"),
    ("writing", "text", "a" * 201, r"\[writing\] text must be .*at most 200 characters"),
    # deep nesting
    ("friction", "b", [[[[0.02]]], 0.02, 0.02], r"\[friction\] b\[1\] must be .*got \[\["),
    # C table ranges
    ("friction", "w", [[1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
     r"\[friction\] w\[1,2\] must be a finite number >= 0"),
    ("motors", "kt", [12.0, 0.0, 4.7], r"\[motors\] kt\[2\] must be a finite number > 0"),
    # physically inconsistent inertia
    ("link1", "inertia_com", [0.05, 0.20, 0.05], r"\[link1\] inertia_com = \[0.05, 0.2, 0.05\] "
     r"are not the principal moments of a rigid body.*triangle inequality"),
    ("link3", "inertia_com", [0.0, 0.03, 0.03], r"\[link3\] inertia_com\[1\] must be .*> 0"),
    ("link3", "mass", 0.0, r"\[link3\] mass must be a finite number > 0"),
])
def test_bad_values_are_named(tmp_path: Path, table: str, key: str, value: Any,
                              message: str) -> None:
    doc = copy.deepcopy(DEFAULT)
    doc[table][key] = value
    text = load_error(write(tmp_path, doc))
    assert text.startswith(f"{tmp_path / 'robot.toml'}: ")
    assert re.search(message, text), text


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d.pop("kinematics"), r"missing table \[kinematics\] \(keys: d1, a2, a3, d2, d3\)"),
    (lambda d: d.pop("friction"), r"missing table \[friction\]"),
    (lambda d: d.pop("link2"), r"missing table \[link2\]"),
    (lambda d: [d.pop(k) for k in ("link1", "link2", "link3")],
     r"missing table \[link1\].*\[base_parameters\]"),
    (lambda d: d["motors"].pop("rotor_inertia"), r"missing key 'rotor_inertia' in \[motors\]"),
    (lambda d: d["control"].pop("kd"), r"missing key 'kd' in \[control\]"),
    (lambda d: d["control"].update(kq=1.0),
     r"unknown key kq in \[control\] \(allowed: kp, kd, sample_time\)"),
    (lambda d: d.update(contrl={"kp": 1}), r"unknown table \[contrl\] \(allowed: kinematics"),
    (lambda d: d.update(name="x"), r"unknown key name at the top level"),
    (lambda d: d.update(control=5), r"\[control\] must be a table, got 5"),
    (lambda d: d["writing"].update(dt=1e-3),
     r"unknown key dt in \[writing\].*the sample period is \[control\] sample_time"),
    (lambda d: d.update(base_parameters={"p": [0.0] * 16}),
     r"\[base_parameters\] and \[link1\] are both given"),
    (lambda d: d["writing"].update(min_speed=0.5), r"\[writing\] WritingSpec.min_speed"),
])
def test_missing_unknown_and_conflicting_tables(tmp_path: Path, change: Any,
                                                message: str) -> None:
    doc = copy.deepcopy(DEFAULT)
    change(doc)
    path = write(tmp_path, doc)
    try:
        robot = rr.read_robot_file(path)
    except rr.RobotFileError as exc:
        assert re.search(message, str(exc)), str(exc)
        return
    # cross-field checks of [writing] are WritingSpec's (built in rrr_robot.writing)
    with pytest.raises(rr.RobotFileError, match=message):
        WritingSpec.from_robot(robot)


def test_optional_tables(tmp_path: Path) -> None:
    doc = copy.deepcopy(DEFAULT)
    del doc["control"], doc["writing"]
    robot = rr.read_robot_file(write(tmp_path, doc))
    assert robot.control is None and robot.sample_time == DEFAULT_SAMPLE_TIME
    with pytest.raises(rr.RobotFileError, match=r"missing table \[control\]"):
        robot.require_control()
    assert WritingSpec.from_robot(robot) == WritingSpec()
    doc = copy.deepcopy(DEFAULT)
    doc["control"]["sample_time"] = 5e-4
    robot = rr.read_robot_file(write(tmp_path, doc))
    assert robot.sample_time == 5e-4 and WritingSpec.from_robot(robot).dt == 5e-4


def test_base_parameters_that_are_not_positive_definite(tmp_path: Path) -> None:
    doc = copy.deepcopy(BP_DEFAULT)
    doc["base_parameters"]["p"][6] = -10.0   # p7: the waist inertia
    text = load_error(write(tmp_path, doc))
    assert "[base_parameters] p gives an inertia matrix D(q) that is not positive definite" in text


@pytest.mark.parametrize(("content", "message"), [
    (b"\xff\xfe\x00", "not valid TOML (not UTF-8"),
    (b"[kinematics\n", "not valid TOML"),
    (b"a = " + b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    (b"a = " + b"1" * 5000, "not valid TOML"),
    (b"# " + b"x" * (MAX_FILE_BYTES + 10), f"larger than {MAX_FILE_BYTES} bytes"),
])
def test_unreadable_files(tmp_path: Path, content: bytes, message: str) -> None:
    path = tmp_path / "robot.toml"
    path.write_bytes(content)
    assert message in load_error(path)


def test_missing_and_directory(tmp_path: Path) -> None:
    with pytest.raises(rr.RobotFileError, match="does not exist"):
        rr.read_robot_file(tmp_path / "nope.toml")
    with pytest.raises(rr.RobotFileError, match="is a directory"):
        rr.read_robot_file(tmp_path)


# ---- property tests ---------------------------------------------------------------------------
def _paths(doc: dict[str, Any]) -> list[tuple[str, str]]:
    return [(t, k) for t, table in doc.items() for k in table]


def _nest(value: Any, depth: int) -> Any:
    for _ in range(depth):
        value = [value]
    return value


@st.composite
def perturbed(draw: st.DrawFn, base: dict[str, Any]) -> tuple[dict[str, Any], str, str, Any]:
    """(document, table, key, intended value); key "" for a table-level change, value None for
    a removal."""
    doc = copy.deepcopy(base)
    kind = draw(st.sampled_from(["replace", "element", "scale", "nest", "drop_table",
                                 "drop_key", "unknown_key", "unknown_table", "wrap"]))
    table, key = draw(st.sampled_from(_paths(doc)))
    if kind == "drop_table":
        del doc[table]
        return doc, table, "", None
    if kind == "drop_key":
        del doc[table][key]
        return doc, table, key, None
    if kind == "unknown_key":
        name = draw(st.sampled_from(["zz", "kp ", "P", "d1x", "a.b", "\u03c9"]))
        doc[table][name] = draw(values)
        return doc, table, name, "unknown"
    if kind == "unknown_table":
        name = draw(st.sampled_from(["Control", "link4", "zz"]))
        doc[name] = {"x": 1.0}
        return doc, name, "", "unknown"
    if kind == "wrap":   # the table becomes an array of tables, or a value
        doc[table] = draw(st.sampled_from([[doc[table]], 1.0, "x"]))
        return doc, table, "", "unknown"
    old = doc[table][key]
    if kind == "replace":
        new = draw(values)
    elif kind == "nest":
        new = _nest(old, draw(st.integers(min_value=1, max_value=40)))
    elif kind == "scale":   # a nearby value of the same shape: often valid
        factor = draw(st.sampled_from([0.5, 1.1, -1.0, 2.0, 1e3, 1e9]))
        new = (np.asarray(old, dtype=float) * factor).tolist() if not isinstance(old, str) \
            else old
    else:  # one element of an array (or the scalar itself)
        new = copy.deepcopy(old)
        v = draw(values)
        if isinstance(new, list) and new:
            i = draw(st.integers(min_value=0, max_value=len(new) - 1))
            if isinstance(new[i], list) and new[i]:
                new[i][draw(st.integers(min_value=0, max_value=len(new[i]) - 1))] = v
            else:
                new[i] = v
        else:
            new = v
    doc[table][key] = new
    return doc, table, key, new


def _same(loaded: Any, intended: Any) -> bool:
    if isinstance(intended, str):
        return loaded == intended
    if isinstance(intended, bool) or isinstance(loaded, bool):
        return loaded is intended
    return bool(np.array_equal(np.asarray(loaded, dtype=float),
                               np.asarray(intended, dtype=float)))


def check_property(tmp_path: Path, case: tuple[dict[str, Any], str, str, Any]) -> None:
    doc, table, key, intended = case
    path = write(tmp_path, doc)
    try:
        robot = rr.read_robot_file(path)
    except rr.RobotFileError as exc:
        text = str(exc)
        assert str(path) in text, text
        named = [f"[{table}]" if table.isidentifier() else table]
        if key:
            named.append(key if key.isidentifier() else json.dumps(key)[1:-1])
        if "nested too deeply" in text:   # the parser's own limit: the file is named
            return
        assert all(n in text for n in named) or (
            # a perturbed link or base parameter that makes D(q) indefinite names the table
            "positive definite" in text and table in ("base_parameters", *PARAM_TABLES)) or (
            # the plant's stiffness is k_t |f| w over the inertia: a perturbed motor, link or
            # base parameter can make the friction too stiff; the message names f and w
            "too stiff for its integrator" in text and "[friction]" in text
            and table in ("friction", "motors", "base_parameters", *PARAM_TABLES)), text
        return
    except Exception as exc:  # pragma: no cover - the property's failure
        raise AssertionError(f"{type(exc).__name__}: {exc}") from exc
    assert intended != "unknown", "an unknown table or key was accepted"
    tables = robot.data.tables()
    if intended is None:
        if key:
            assert key not in tables.get(table, {}) or (table, key) == ("control", "sample_time")
        else:
            assert table not in tables or table in ("control", "writing", "identification")
        return
    assert _same(tables[table][key], intended), (table, key, tables[table][key], intended)
    # the model holds what the file says
    group_table = {g: t for t, groups in PARAM_TABLES.items() for g in groups}
    if group_table.get(key) == table:
        assert _same(robot.data.group(key), intended)
        assert abs(np.asarray(intended, dtype=float)).max() <= MAX_MAGNITUDE


@settings(max_examples=400, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=perturbed(DEFAULT))
def test_property_perturbed_default_robot(tmp_path: Path, case: Any) -> None:
    check_property(tmp_path, case)


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=perturbed(BP_DEFAULT))
def test_property_perturbed_base_parameter_robot(tmp_path: Path, case: Any) -> None:
    check_property(tmp_path, case)


@settings(max_examples=200, deadline=None)
@given(data=values)
def test_property_any_document_gives_the_packages_error(data: Any) -> None:
    """Whatever the parsed tables are, read_robot_file raises RobotFileError (or loads)."""
    try:
        read_robot_file(data if isinstance(data, dict) else {"kinematics": data}, "doc")
    except rr.RobotFileError as exc:
        assert str(exc).startswith("doc: ")


# ---- absurd sample counts and the CLI --------------------------------------------------------
def _run_writing(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--quiet", *args],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)


def _assert_one_line_error(result: subprocess.CompletedProcess[str], *needles: str) -> str:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rrr: error: "), result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize(("change", "needles"), [
    (lambda d: d["control"]["kp"].__setitem__(1, "abc"),
     ['[control] kp[2] must be a finite number >= 0', 'got "abc"']),
    (lambda d: d.pop("control"), ["missing table [control]"]),
    (lambda d: d["link1"].update(inertia_com=[0.05, 0.20, 0.05]), ["triangle inequality"]),
    (lambda d: d["control"].update(sample_time=1e-5) or d["writing"].update(peak_speed=0.1),
     ["samples at the sample time 1e-05 s", "bounded to 1000 s and 1,000,000 samples",
      "[control] sample_time"]),
    (lambda d: d["writing"].update(peak_speed=5e-4, min_speed=1e-4),
     ["bounded to 1000 s"]),
    (lambda d: d["writing"].update(x_range=[-10.0, 10.0], z_range=[-10.0, 10.0],
                                   letter_height=1.0, text="mmmmmmmmmm\nmmmmmmmmmm\nmmmmmmmmmm"),
     ["bounded to 100 m"]),
])
def test_cli_bad_robot_exits_2_and_writes_nothing(tmp_path: Path, change: Any,
                                                  needles: list[str]) -> None:
    doc = copy.deepcopy(DEFAULT)
    change(doc)
    robot = write(tmp_path, doc, "bad_robot.toml")
    out = tmp_path / "out"
    result = _run_writing(tmp_path, "--robot", str(robot), "--out", str(out), "--no-figures")
    line = _assert_one_line_error(result, *needles)
    if not any("bounded" in n for n in needles):   # the bounds speak of the text, not the file
        assert f"rrr: error: {robot}: " in line
    assert not out.exists()


def test_cli_unreadable_robot(tmp_path: Path) -> None:
    for name, content in (("deep.toml", b"a = " + b"[" * 5000 + b"]" * 5000),
                          ("bin.toml", b"\x00\xff")):
        (tmp_path / name).write_bytes(content)
        out = tmp_path / "out"
        result = _run_writing(tmp_path, "--robot", name, "--out", str(out))
        _assert_one_line_error(result, name, "not valid TOML")
        assert not out.exists()


def test_cli_identification_experiment_bound(tmp_path: Path) -> None:
    out = tmp_path / "exp"
    result = subprocess.run([sys.executable, "-m", "rrr_robot", "identify-experiment", "--out",
                             str(out), "--periods", "101"],
                            capture_output=True, text=True, timeout=300)
    _assert_one_line_error(result, "1,010,000 samples", "bounded to 1,000,000 samples")
    assert not out.exists()
    doc = copy.deepcopy(DEFAULT)
    doc["control"]["sample_time"] = 1e-5
    robot = write(tmp_path, doc)
    result = subprocess.run([sys.executable, "-m", "rrr_robot", "identify-experiment", "--out",
                             str(out), "--robot", str(robot)],
                            capture_output=True, text=True, timeout=300)
    _assert_one_line_error(result, "the friction sweep would have")
    assert not out.exists()


def test_whole_numbers_of_the_schema_are_written_as_integers(tmp_path: Path) -> None:
    """[identification] rows is a whole number (Number(integer=True)): written `rows = 846`,
    not 846.0; the other numbers stay floats and read back bit for bit."""
    path = tmp_path / "t.toml"
    write_toml({"identification": {"rows": 846, "cond": 12.0, "p": [0.1, 2.0]}}, path)
    text = path.read_text()
    assert "rows = 846\n" in text and "cond = 12.0\n" in text
    assert tomllib.loads(text)["identification"] == {"rows": 846, "cond": 12.0, "p": [0.1, 2.0]}
