"""The sweep spec (``rrr sweep SPEC.toml``), read once and checked whole before anything runs.

::

    [sweep]
    base = "ctc"          # a built-in scenario (pd, ctc, mismatch) or a scenario file
    samples = 200         # number of runs (grid: optional, the size of the grid)
    seed = 1              # 0 to 1e9 (default 0)
    method = "random"     # "random" (default), "lhs" (Latin hypercube) or "grid"
    robot = "robot.toml"  # optional: the robot file (default: the packaged robot)
    controller_robot = "identified.toml"  # optional: the controller's model from this file

    [vary]                # keys: rrr_robot.sweep.keys (scenario fields by dotted name)
    "mismatch.p_rel" = { uniform = [-0.2, 0.2] }
    "mismatch.kt_rel" = { normal = [0.0, 0.05] }
    "mismatch.f_rel" = { normal = [0.0, 0.1], per_element = true }
    "gains.kp" = { values = [[20.0, 50.0, 20.0], [40.0, 100.0, 40.0]] }
    "writing.text" = { values = ["am", "ma"] }

Distributions: ``uniform = [low, high]`` (low < high), ``loguniform = [low, high]`` (0 < low <
high), ``normal = [mean, std]`` (std > 0), ``values = [v1, v2, ...]`` (whole values of the field,
each checked as a scenario file's value; drawn with equal probability, or the axis of a grid).
``per_element = true`` draws each element of a field with several numbers (``gains.kp``,
``mismatch.p_rel``, ...) independently from the distribution. The bounds of uniform and
loguniform and the mean of normal must be valid values of the field; a normal draw may still
fall outside its range, which makes that run ``invalid`` (rrr_robot.sweep.runs).
``controller_robot``: every run's controller starts from this robot file's model instead of the
plant's (``rrr writing --controller-robot``), and ``mismatch.*`` perturbs it. Relative paths
(``base``, ``robot``, ``controller_robot``) are relative to the spec file's folder. Errors
(:class:`~rrr_robot.errors.SweepSpecError`) name the file, the table and the key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

from ..core.checked import Document, Invalid, Number, Text, key_text, load_toml, show
from ..errors import SweepSpecError
from .keys import Target, element_checks, target, targets

__all__ = [
    "DISTRIBUTIONS",
    "MAX_SAMPLES",
    "METHODS",
    "Distribution",
    "SweepSpec",
    "Vary",
    "read_spec",
    "spec_from_dict",
]

#: The designs of ``[sweep] method``: independent random draws, a Latin hypercube, a grid.
METHODS = ("random", "lhs", "grid")
#: The distributions of a ``[vary]`` entry.
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "values")
#: Runs of one sweep.
MAX_SAMPLES = 1_000_000
#: Entries of one ``values`` list.
MAX_VALUES = 10_000
SEED_MAX = 1_000_000_000

SWEEP_FIELDS = {
    "base": Text(max_len=4096, nonblank=True),
    "samples": Number(lo=1, hi=MAX_SAMPLES, integer=True),
    "seed": Number(lo=0, hi=SEED_MAX, integer=True),
    "method": Text(choices=METHODS),
    "robot": Text(max_len=4096, nonblank=True),
    "controller_robot": Text(max_len=4096, nonblank=True),
}


@dataclass(frozen=True)
class Distribution:
    """How a key's value is drawn: ``kind`` one of DISTRIBUTIONS; ``params`` (low, high) or
    (mean, std); ``values`` the checked values; ``per_element``: one draw per element."""

    kind: str
    params: tuple[float, float] = (0.0, 0.0)
    values: tuple[Any, ...] = ()
    per_element: bool = False

    def identity(self) -> dict[str, Any]:
        """The distribution as JSON values (for the sweep's fingerprint)."""
        value: Any = list(self.values) if self.kind == "values" else list(self.params)
        return {self.kind: value, "per_element": self.per_element}


@dataclass(frozen=True)
class Vary:
    """One [vary] entry: the field and its distribution."""

    target: Target
    dist: Distribution

    @property
    def key(self) -> str:
        return self.target.key

    @property
    def dims(self) -> int:
        """Independent draws of one run (the elements, with per_element)."""
        return self.target.size if self.dist.per_element else 1


@dataclass(frozen=True)
class SweepSpec:
    """A checked sweep spec. ``samples``: the number of runs (for a grid, its size)."""

    source: str
    base: str
    samples: int
    seed: int
    method: str
    robot: str | None
    vary: tuple[Vary, ...]
    controller_robot: str | None = None   # the controller's model from this robot file

    @property
    def folder(self) -> Path:
        """The folder that relative paths of the spec start from."""
        return Path(self.source).parent

    def resolve(self, name: str) -> str:
        """A path of the spec, relative to its folder."""
        path = Path(name)
        return str(path if path.is_absolute() else self.folder / path)

    def identity(self) -> dict[str, Any]:
        """What defines the runs, as JSON values: a resumed sweep must have the same."""
        out = {"base": self.base, "samples": self.samples, "seed": self.seed,
               "method": self.method, "robot": self.robot,
               "vary": {v.key: v.dist.identity() for v in self.vary}}
        if self.controller_robot is not None:  # absent otherwise: older sweeps keep their key
            out["controller_robot"] = self.controller_robot
        return out


class _Checker:
    """The [vary] entries of one spec, checked against their targets."""

    def __init__(self, doc: Document) -> None:
        self.doc = doc

    def fail(self, key: str, message: str) -> NoReturn:
        self.doc.fail("vary", key, f"[vary] {show(key)}: {message}")

    def entries(self, table: Mapping[str, Any]) -> list[tuple[str, Any]]:
        """The entries of [vary], with dotted TOML keys (mismatch.p_rel = {...} without quotes,
        a [vary.mismatch] table or an inline table mismatch = { p_rel = {...} }) joined back
        into one key; a key given twice in two spellings (TOML itself refuses one spelling
        twice) is refused, naming both."""
        out: list[tuple[str, Any]] = []
        spelled: dict[str, str] = {}
        for key, value, spelling in self._walk(table, (), ()):
            if key in spelled:
                self.fail(key, f"given twice, as {spelled[key]} and as {spelling} (two "
                          "spellings of one key); give it once")
            spelled[key] = spelling
            out.append((key, value))
        return out

    def _walk(self, table: Mapping[str, Any], parts: tuple[str, ...],
              path: tuple[str, ...]) -> list[tuple[str, Any, str]]:
        """(joined key, value, how it was spelled in the file) of each entry."""
        out: list[tuple[str, Any, str]] = []
        for name, value in table.items():
            key = ".".join((*parts, name))
            here = (*path, name)
            if target(key) is None and isinstance(value, Mapping) and \
                    any(k.startswith(f"{key}.") for k in targets()):
                out += self._walk(value, (*parts, name), here)
            else:
                out.append((key, value, ".".join(key_text(p) for p in here)))
        return out

    def vary(self, key: str, entry: Any) -> Vary:
        t = target(key)
        if t is None:
            groups = sorted({k.rsplit(".", 1)[0] for k in targets()})
            self.fail(key, f"unknown key (keys: {', '.join(groups)} fields by dotted name: "
                      f"{', '.join(targets())})")
        if not isinstance(entry, Mapping):
            self.fail(key, f"must be a table with one distribution ({', '.join(DISTRIBUTIONS)}),"
                      f" e.g. {{ uniform = [-0.1, 0.1] }}, got {show(entry)}")
        kinds = [k for k in entry if k in DISTRIBUTIONS]
        for name in entry:
            if name not in (*DISTRIBUTIONS, "per_element"):
                self.fail(key, f"unknown distribution {show(name)} (one of "
                          f"{', '.join(DISTRIBUTIONS)}; and per_element = true or false)")
        if len(kinds) != 1:
            self.fail(key, f"needs exactly one distribution ({', '.join(DISTRIBUTIONS)}), got "
                      f"{len(kinds)}")
        per_element = entry.get("per_element", False)
        if not isinstance(per_element, bool):
            self.fail(key, f"per_element must be true or false, got {show(per_element)}")
        kind = kinds[0]
        self._applies(t, kind, per_element)
        if kind == "values":
            return Vary(t, Distribution(kind, values=self._values(t, entry[kind], per_element),
                                        per_element=per_element))
        return Vary(t, Distribution(kind, self._params(t, kind, entry[kind], per_element),
                                    per_element=per_element))

    def _applies(self, t: Target, kind: str, per_element: bool) -> None:
        if per_element and not t.shape:
            self.fail(t.key, f"per_element applies to fields with several numbers; {t.key} is "
                      f"{t.describe()}")
        if kind == "values":
            return
        if t.kind != "number":
            self.fail(t.key, f"{t.key} is {t.describe()}: list its values with values = [...]")
        if not t.scalar and not per_element:
            self.fail(t.key, f"{t.key} is {t.describe()}: draw each element with per_element = "
                      "true, or list whole values with values = [...]")

    def _params(self, t: Target, kind: str, raw: Any, per_element: bool) -> tuple[float, float]:
        names = ("mean", "std") if kind == "normal" else ("low", "high")
        if not isinstance(raw, list) or len(raw) != 2 or not all(
                isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
                for x in raw):
            self.fail(t.key, f"{kind} must be [{', '.join(names)}], two finite numbers, got "
                      f"{show(raw)}")
        a, b = float(raw[0]), float(raw[1])
        if kind == "normal" and not b > 0:
            self.fail(t.key, f"normal std must be > 0, got {show(raw[1])}")
        if kind != "normal" and not a < b:
            self.fail(t.key, f"{kind} needs low < high, got {show(raw)}")
        if kind == "loguniform" and not a > 0:
            self.fail(t.key, f"loguniform needs low > 0, got {show(raw[0])}")
        checks = element_checks(t) if per_element else [t.field]
        for name, x in zip(names, (a, b), strict=True):
            if name == "std":
                continue
            for check in checks:
                try:
                    check.check(x)
                except Invalid as exc:
                    self.fail(t.key, f"{kind} {name} {exc.requirement} (a value of {t.key}), got "
                              f"{show(raw[names.index(name)])}")
        return a, b

    def _values(self, t: Target, raw: Any, per_element: bool) -> tuple[Any, ...]:
        if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_VALUES:
            self.fail(t.key, f"values must be an array of 1 to {MAX_VALUES} values, got "
                      f"{show(raw)}")
        checks = element_checks(t) if per_element else [t.field]
        out = []
        for j, value in enumerate(raw):
            for check in checks:
                try:
                    checked = check.check(value)
                except Invalid as exc:
                    what = "an element's value" if per_element else "a value"
                    self.fail(t.key, f"values[{j + 1}]{exc.index} {exc.requirement} ({what} of "
                              f"{t.key}), got {show(exc.value)}")
            out.append(checked)
        if len({isinstance(v, tuple) for v in out}) > 1:
            self.fail(t.key, "values must all be numbers or all be arrays (one column of the "
                      "results holds them)")
        return tuple(out)


def spec_from_dict(data: Mapping[str, Any], source: str) -> SweepSpec:
    """Check a parsed sweep spec (see the module doc). Raises SweepSpecError."""
    doc = Document(data, source, "sweep spec", SweepSpecError)
    doc.only_tables(("sweep", "vary"))
    head = doc.table("sweep", SWEEP_FIELDS, required=("base",), must_exist=True)
    assert head is not None
    method = head.get("method", "random")
    checker = _Checker(doc)
    vary = tuple(checker.vary(k, v) for k, v in checker.entries(doc.data.get("vary", {})))
    samples = head.get("samples")
    if method == "grid":
        samples = _grid_size(doc, vary, samples)
    elif samples is None:
        doc.fail("sweep", "samples", f"missing key 'samples' in [sweep] (the number of runs, "
                 f"1 to {MAX_SAMPLES}; only a grid has its own)")
    return SweepSpec(source=source, base=head["base"], samples=int(samples),
                     seed=int(head.get("seed", 0)), method=method, robot=head.get("robot"),
                     vary=vary, controller_robot=head.get("controller_robot"))


def _grid_size(doc: Document, vary: tuple[Vary, ...], samples: int | None) -> int:
    size = 1
    for v in vary:
        if v.dist.kind != "values" or v.dist.per_element:
            doc.fail("vary", v.key, f"[vary] {show(v.key)}: a grid varies whole values: give "
                     "values = [...] (without per_element), or use method = \"random\" or "
                     "\"lhs\"")
        size *= len(v.dist.values)
    if size > MAX_SAMPLES:
        doc.fail("vary", "", f"the grid has {size} points: at most {MAX_SAMPLES} runs")
    if samples is not None and samples != size:
        doc.fail("sweep", "samples", f"[sweep] samples = {samples}, but the grid has {size} "
                 "points (the product of the values lists): leave samples out or make it "
                 f"{size}")
    return size


def read_spec(path: str | Path) -> SweepSpec:
    """Read and check a sweep spec file; raises SweepSpecError naming the file and the key."""
    return spec_from_dict(load_toml(path, "sweep spec", SweepSpecError), str(path))
