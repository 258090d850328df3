"""The example sweep specs shipped with the package (``rrr_robot/data/sweeps/``): a Monte Carlo
one, a Latin hypercube one and a grid one, each a complete spec that ``rrr sweep`` runs as it is
(``rrr sweep --example NAME`` prints one). Loads nothing but the file system, so ``rrr sweep
--help`` can list them."""

from __future__ import annotations

from pathlib import Path

from ..core._package import DATA_DIR
from ..errors import BadInputError

__all__ = ["EXAMPLES_DIR", "example_path", "example_summary", "examples"]

#: The folder of the shipped example specs: ``rrr_robot/data/sweeps/``.
EXAMPLES_DIR = DATA_DIR / "sweeps"


def examples() -> dict[str, Path]:
    """Each shipped example spec by name (the file name without ``.toml``), sorted by name."""
    return {p.stem: p for p in sorted(EXAMPLES_DIR.glob("*.toml"))}


def example_path(name: str) -> Path:
    """The file of the example spec ``name``; BadInputError naming the examples if there is none
    of that name."""
    found = examples().get(name)
    if found is None:
        raise BadInputError(f"no example sweep spec {name!r} (examples: "
                            f"{', '.join(examples()) or 'none installed'})")
    return found


def example_summary(path: Path) -> str:
    """What an example sweeps: the first line of its leading comment, for ``--help``."""
    first = path.read_text(encoding="utf-8").split("\n", 1)[0]
    return first.removeprefix("#").strip().rstrip(".") if first.startswith("#") else ""
