"""Scenarios of the writing task, read from TOML files (users add their own); built-in ones live
in data/scenarios/.

One schema, every table and key checked (unknown ones are errors that name them), errors
(:class:`~rrr_robot.errors.ScenarioError`) naming the file, the table and the key:

- ``[scenario]`` (required): ``name`` (required) names the output files (``<name>.csv``,
  ``fig_letters_<name>.png``), so it must be a safe file name: 1 to 64 characters, letters,
  digits, ``_``, ``.`` and ``-``, starting with a letter or digit, not ending with ``.``, not a
  Windows device name (con, nul, com1, ...); ``description`` (optional, at most 200
  characters); ``feedforward`` (required, true or false);
- ``[gains]`` (optional): ``kp``, ``kd``, three numbers >= 0 and <= 1e6 each, replacing the
  robot file's [control] gains;
- ``[mismatch]`` (optional): ``<group>_rel`` for each group of the C parameter table (p_rel,
  kt_rel, f_rel, w_rel, b_rel, u_max_rel, g_rel, d1_rel, a2_rel, ...), a relative error of the
  controller's model (the true one, or that of ``rrr writing --controller-robot``), > -1 and
  <= 10: every value of the group is scaled by (1 + rel), the base
  parameters with alternating sign, p_k (1 + rel (-1)^k). A group with several values (p, kt,
  f, w, b) also takes one error per value, in the group's shape (16 numbers for p, 3 arrays of 3
  for f): value v of the group becomes v (1 + rel_v), with no alternating sign.

The names of one run must differ (ignoring case: they name files) and a run has at most
:data:`MAX_SCENARIOS` scenarios (:func:`check_run`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..core import _lib
from ..core._package import DATA_DIR
from ..core.checked import (
    Document,
    Field,
    Flag,
    Matrix,
    Number,
    ScalarOrArray,
    Text,
    Vector,
    load_toml,
)
from ..core.model import Model
from ..core.param_names import GROUPS, PARAMS, ParamInfo, group_shape, set_values
from ..core.robot import GAIN
from ..errors import ModelError, ScenarioError

__all__ = [
    "BUILTIN",
    "MAX_SCENARIOS",
    "SCENARIO_DIR",
    "SCHEMA",
    "Scenario",
    "check_run",
    "load_scenario",
    "read_scenario_file",
    "scenario_from_dict",
]

#: The packaged scenario files (``<name>.toml``).
SCENARIO_DIR = DATA_DIR / "scenarios"
#: The built-in scenarios, by name: PD only, PD + feedforward (computed torque), and the latter
#: with a perturbed controller model.
BUILTIN = ("pd", "ctc", "mismatch")
#: Scenarios of one run (each is one co-simulation of the whole reference).
MAX_SCENARIOS = 20
#: A scenario name: a safe file name (it names output files).
NAME_PATTERN = r"[A-Za-z0-9](?:[A-Za-z0-9_.-]{0,62}[A-Za-z0-9_-])?"
_DEVICE_NAMES = frozenset({"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)),
                           *(f"lpt{i}" for i in range(10))})
#: A [mismatch] value: the factor 1 + rel stays positive and at most 11.
MISMATCH = Number(lo=-1.0, lo_open=True, hi=10.0)



def _mismatch_field(group: str) -> Field:
    """A [mismatch] key: one error for the group, or (a group of several values) one per value
    in the group's shape."""
    shape = group_shape(group)
    if not shape:
        return MISMATCH
    if len(shape) == 1:
        return ScalarOrArray(MISMATCH, Vector(shape[0], MISMATCH))
    return ScalarOrArray(MISMATCH, Matrix(shape[0], shape[1], lambda i, k: MISMATCH))


#: What a scenario file may hold: its tables, and each key's check (a sweep varies the same
#: fields by dotted name: rrr_robot.sweep.keys).
SCHEMA: dict[str, dict[str, Field]] = {
    "scenario": {
        "name": Text(max_len=64, pattern=NAME_PATTERN, pattern_text=(
            "a safe file name: 1 to 64 letters, digits, _ . -, starting with a letter or "
            "digit and not ending with '.'")),
        "description": Text(max_len=200),
        "feedforward": Flag(),
    },
    "gains": {"kp": Vector(3, GAIN), "kd": Vector(3, GAIN)},
    "mismatch": {f"{group}_rel": _mismatch_field(group) for group in GROUPS},
}


@dataclass(frozen=True)
class Scenario:
    """One controller configuration of the writing task."""

    name: str
    description: str
    feedforward: bool
    kp: tuple[float, float, float] | None = None
    kd: tuple[float, float, float] | None = None
    # <group>_rel: one relative error for the group, or one per value in the group's shape
    mismatch: Mapping[str, float | tuple[Any, ...]] = field(default_factory=dict)
    source: str = ""
    # the model the controller starts from, before [mismatch]: None for the true (plant's) one;
    # another robot file's model with rrr writing --controller-robot (:meth:`believing`)
    controller_base: Model | None = field(default=None, compare=False, repr=False)

    def believing(self, model: Model | None) -> Scenario:
        """This scenario with the controller's model built from ``model`` instead of the true one
        (a robot file of its own: ``rrr writing --controller-robot``); [mismatch] then perturbs
        ``model``. None: the true model again."""
        return replace(self, controller_base=model)

    def controller_model(self, true_model: Model) -> Model:
        """The model the controller believes in: the true one (or ``controller_base``, when the
        controller has a robot file of its own: :meth:`believing`), perturbed by [mismatch]."""
        base = true_model if self.controller_base is None else self.controller_base
        if not self.mismatch:
            return base
        changes: dict[str, float] = {}
        for info in PARAMS:
            rel = self.mismatch.get(f"{info.group}_rel")
            if rel is None:
                continue
            changes[info.name] = _lib.param_get(base.raw, info.row) * _factor(info, rel)
        try:
            return Model(set_values(base.raw, changes))
        except ModelError as exc:
            src = self.source or f"scenario {self.name}"
            raise ScenarioError(f"{src}: scenario {self.name}: [mismatch] makes the controller's "
                                f"model invalid: {exc}", src, "mismatch", "") from exc


def _factor(info: ParamInfo, rel: float | tuple[Any, ...]) -> float:
    """1 + rel for one parameter: rel for the whole group (p: with alternating sign, (-1)^k), or
    the parameter's own element of rel."""
    if isinstance(rel, tuple):
        element: Any = rel
        for i in info.index:
            element = element[i - 1]
        return 1.0 + float(element)
    sign = (-1.0) ** info.index[0] if info.group == "p" else 1.0
    return 1.0 + rel * sign


def scenario_from_dict(data: Mapping[str, Any], src: str) -> Scenario:
    """Check a parsed scenario file (see the module doc); every error names the file and the
    key. Raises ScenarioError."""
    doc = Document(data, src, "scenario file", ScenarioError)
    doc.only_tables(SCHEMA)
    head = doc.table("scenario", SCHEMA["scenario"]) or {}
    missing = [k for k in ("name", "feedforward") if k not in head]
    if missing:
        doc.fail("scenario", missing[0], "needs a [scenario] table with name and feedforward "
                 f"(missing: {', '.join(missing)})")
    name = head["name"]
    if name.split(".")[0].lower() in _DEVICE_NAMES:
        doc.fail("scenario", "name", f"[scenario] name {name!r} is a Windows device name "
                 "(con, prn, aux, nul, com0-9, lpt0-9): it cannot name an output file")
    gains = doc.table("gains", SCHEMA["gains"]) or {}
    mismatch = doc.table("mismatch", SCHEMA["mismatch"]) or {}
    return Scenario(
        name=name, description=head.get("description", ""), feedforward=head["feedforward"],
        kp=gains.get("kp"), kd=gains.get("kd"), mismatch=mismatch, source=src,
    )


def read_scenario_file(name_or_path: str) -> tuple[dict[str, Any], str]:
    """The parsed tables of a built-in scenario (pd, ctc, mismatch) or a scenario TOML file,
    not yet checked (:func:`scenario_from_dict` checks them), and the file's name for messages.
    Raises ScenarioError for an unknown name and a file that is not TOML."""
    path = SCENARIO_DIR / f"{name_or_path}.toml"
    if name_or_path not in BUILTIN:
        path = Path(name_or_path)
        if path.suffix != ".toml" or not path.is_file():
            raise ScenarioError(
                f"unknown scenario {name_or_path!r}: use one of {', '.join(BUILTIN)} "
                "or the path of a scenario .toml file", name_or_path, "", "")
    return load_toml(path, "scenario file", ScenarioError), str(path)


def load_scenario(name_or_path: str) -> Scenario:
    """A built-in scenario by name (pd, ctc, mismatch) or a scenario TOML file by path."""
    return scenario_from_dict(*read_scenario_file(name_or_path))


def check_run(scenarios: Sequence[Scenario]) -> None:
    """The scenarios of one run: at least one, at most MAX_SCENARIOS, names unique (ignoring
    case: they name output files). Raises ScenarioError."""
    if not scenarios:
        raise ScenarioError("no scenario to run: give at least one")
    if len(scenarios) > MAX_SCENARIOS:
        raise ScenarioError(f"{len(scenarios)} scenarios in one run: at most {MAX_SCENARIOS} "
                            "(each co-simulates the whole reference)")
    seen: dict[str, Scenario] = {}
    for s in scenarios:
        other = seen.get(s.name.lower())
        if other is not None:
            same = "the same name" if other.name == s.name else "names that differ only in case"
            raise ScenarioError(
                f"scenarios {other.name!r} ({other.source}) and {s.name!r} ({s.source}) have "
                f"{same}: the names of one run must differ, they name the output files",
                s.source, "scenario", "name")
        seen[s.name.lower()] = s
