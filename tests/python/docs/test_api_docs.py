"""The Python API page (docs/api/python.md, built by Sphinx's autodoc): every public name, that
is every name in the ``__all__`` of the package and of each public module, has a docstring (a
``#:`` comment for data, as autodoc reads it) and is documented on the page by an autodoc
directive, once, where it is defined. The Sphinx build (-W -n) checks that the directives and
every cross-reference resolve; this test checks that nothing public is left out."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import types
from typing import Any

import pytest
from support import REPO

PAGE = REPO / "docs" / "api" / "python.md"

#: The modules a user imports names from (each has __all__): the package, the subpackages that
#: re-export, and the modules of the subpackages that do not.
PUBLIC_MODULES = [
    "rrr_robot",
    "rrr_robot.errors",
    "rrr_robot.core",
    "rrr_robot.identify",
    "rrr_robot.core.fmu_vars",
    "rrr_robot.core.batch",
    "rrr_robot.sim.cosim",
    "rrr_robot.sim.native",
    "rrr_robot.sim.fmus",
    "rrr_robot.writing.trajectory",
    "rrr_robot.writing.scenarios",
    "rrr_robot.writing.job",
    "rrr_robot.ssp.export",
    "rrr_robot.ssp.archive",
    "rrr_robot.ssp.run",
    "rrr_robot.sweep.job",
    "rrr_robot.sweep.spec",
    "rrr_robot.sweep.examples",
    "rrr_robot.hil",
    "rrr_robot.hil.dbc.protocol",
    "rrr_robot.hil.dbc.bench",
    "rrr_robot.hil.dbc.controller",
    "rrr_robot.hil.dbc.results",
    "rrr_robot.hil.results",
    "rrr_robot.hil.logs.specs",
    "rrr_robot.writing.reference_table",
    "rrr_robot.core.summary",
    "rrr_robot.cli",
]
DIRECTIVE = re.compile(r"^\.\. auto(class|function|data|exception|method|attribute):: (\S+)$",
                       re.M)


def public_names() -> list[tuple[str, str, Any]]:
    out = []
    for name in PUBLIC_MODULES:
        mod = importlib.import_module(name)
        assert hasattr(mod, "__all__"), f"{name} has no __all__"
        assert len(set(mod.__all__)) == len(mod.__all__), name
        out += [(name, n, getattr(mod, n)) for n in mod.__all__]
    return out


def resolve(path: str) -> Any:
    """The object a directive documents: the longest importable module, then attributes."""
    parts = path.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for p in parts[k:]:
            obj = getattr(obj, p)
        return obj
    raise AssertionError(path)


def documented() -> dict[tuple[int, str], str]:
    """(id of the object, its name) -> the directive's target, for every directive."""
    text = PAGE.read_text(encoding="utf-8")
    out: dict[tuple[int, str], str] = {}
    for _, target in DIRECTIVE.findall(text):
        key = (id(resolve(target)), target.rsplit(".", 1)[1])
        assert key not in out, f"{target} is documented twice (also as {out.get(key)})"
        out[key] = target
    return out


def _defining_module(module: str, name: str) -> str:
    """Where a data name is assigned: follow ``from X import name`` from the module it is
    exported by (a ``#:`` comment sits at the assignment)."""
    mod = importlib.import_module(module)
    tree = ast.parse(inspect.getsource(mod))
    package = module if hasattr(mod, "__path__") else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if (alias.asname or alias.name) == name:
                    source = importlib.util.resolve_name("." * node.level + (node.module or ""),
                                                         package)
                    return _defining_module(source, alias.name)
    return module


def attribute_doc(module: str, name: str) -> str:
    """The ``#:`` comment of a module-level assignment (the lines above it, or on its line)."""
    where = _defining_module(module, name)
    source = inspect.getsource(importlib.import_module(where)).split("\n")
    for node in ast.parse("\n".join(source)).body:
        targets = (node.targets if isinstance(node, ast.Assign) else
                   [node.target] if isinstance(node, ast.AnnAssign) else [])
        if any(isinstance(t, ast.Name) and t.id == name for t in targets):
            line = source[node.lineno - 1]
            if "#:" in line:
                return line.split("#:", 1)[1].strip()
            above = []
            k = node.lineno - 2
            while k >= 0 and source[k].lstrip().startswith("#:"):
                above.insert(0, source[k].lstrip()[2:].strip())
                k -= 1
            return " ".join(above)
    raise AssertionError(f"no assignment of {name} in {where}")


def docstring(obj: Any) -> str:
    doc = inspect.getdoc(obj) or ""
    if inspect.isclass(obj) and doc.startswith(f"{obj.__name__}("):
        return ""  # the signature a dataclass or NamedTuple writes when it has no docstring
    return doc


NAMES = public_names()


@pytest.mark.parametrize(("module", "name", "obj"), NAMES,
                         ids=[f"{m}.{n}" for m, n, _ in NAMES])
def test_every_public_name_has_a_docstring_and_is_on_the_page(module, name, obj):
    assert not isinstance(obj, types.ModuleType), (
        f"{module}.{name} is a module (a submodule of the same name shadows the name)")
    if inspect.isclass(obj) or inspect.isroutine(obj) or hasattr(obj, "__wrapped__"):
        assert docstring(obj), f"{module}.{name} has no docstring"
    else:
        assert attribute_doc(module, name), f"{module}.{name} has no #: comment"
    assert (id(obj), name) in documented(), (
        f"{module}.{name} is not on docs/api/python.md: add an autodoc directive for it where "
        "it is defined")


def test_every_directive_documents_a_documented_object():
    for target in documented().values():
        obj = resolve(target)
        if inspect.isclass(obj) or inspect.isroutine(obj):
            assert docstring(obj), target
            assert target == f"{obj.__module__}.{obj.__qualname__}", (
                f"{target}: document it where it is defined ({obj.__module__})")


def test_the_checks_can_fail():
    """A name without a docstring, and data without a #: comment, are found."""
    def undocumented() -> None:
        pass

    assert not docstring(undocumented)
    with pytest.raises(AssertionError, match="no assignment"):
        attribute_doc("rrr_robot.sweep.spec", "NO_SUCH_NAME")
    assert attribute_doc("rrr_robot.sweep.spec", "MAX_VALUES")
    assert not attribute_doc("rrr_robot.sweep.spec", "SEED_MAX")
