"""The markers of a test folder: each folder of tests/python that holds test modules has a
``conftest.py`` that names them, so a module is classified by the folder it is saved in::

    pytest_ignore_collect = folder_markers(__file__, "slow", "bus", maybe=("vm",), ...)

``always``: the markers of every test of the folder. ``maybe``: markers that some of its tests
carry (a parameter's marks, or ``of_item``'s answer for an item), so that ``-m`` selects them.

Before import: with ``-m``, a module whose folder's markers the expression excludes for every
test it may hold is not even imported (``-m "not slow"`` does not pay for the imports of the
slow modules: Pinocchio, MuJoCo, Drake, FMPy's masters). After collection,
:func:`mark_items` (tests/python/conftest.py) gives each test its folder's markers and fails
the run for a test module in a folder that names none.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import pytest


@dataclass(frozen=True)
class Folder:
    always: frozenset[str]
    maybe: frozenset[str]
    of_item: Callable[[pytest.Item], Iterable[str]] | None


#: The folders whose conftest.py has named their markers (by absolute path).
FOLDERS: dict[Path, Folder] = {}


def _excluded(expression: str, folder: Folder) -> bool:
    """True when ``-m expression`` deselects every test the folder may hold."""
    from _pytest.mark.expression import Expression

    compiled = Expression.compile(expression)
    maybe = sorted(folder.maybe)
    for k in range(len(maybe) + 1):
        for extra in itertools.combinations(maybe, k):
            marks = folder.always | set(extra)
            if compiled.evaluate(marks.__contains__):
                return False
    return True


def folder_markers(conftest: str, *always: str, maybe: Iterable[str] = (),
                   of_item: Callable[[pytest.Item], Iterable[str]] | None = None
                   ) -> Callable[[Path, pytest.Config], bool | None]:
    """Name the markers of the folder of ``conftest`` (its ``__file__``); returns its
    ``pytest_ignore_collect`` hook (it decides for the modules saved directly in the folder)."""
    folder = Path(conftest).resolve().parent
    spec = Folder(frozenset(always), frozenset(maybe), of_item)
    FOLDERS[folder] = spec

    def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
        expression = config.getoption("markexpr")
        if (not expression or collection_path.suffix != ".py"
                or Path(collection_path).resolve().parent != folder):
            return None  # None, not False: pytest's own --ignore still decides
        return True if _excluded(expression, spec) else None

    return pytest_ignore_collect


def mark_items(items: list[pytest.Item], root: Path) -> None:
    """Each test gets its folder's markers; a test module in a folder without them (tests/python
    itself, or a new folder without its conftest.py) fails the run, naming it."""
    unclassified: set[str] = set()
    for item in items:
        path = Path(item.path).resolve()
        spec = FOLDERS.get(path.parent)
        if spec is None:
            unclassified.add(str(path.relative_to(root)) if path.is_relative_to(root) else
                             str(path))
            continue
        marks = set(spec.always) | set(spec.of_item(item) if spec.of_item else ())
        for mark in sorted(marks):
            item.add_marker(getattr(pytest.mark, mark))
    if unclassified:
        raise pytest.UsageError(
            f"tests/python: {sorted(unclassified)} in no folder whose conftest.py names its "
            "markers: move each into the folder of its area (CONTRIBUTING.md, 'Where a new test "
            "module goes')")
