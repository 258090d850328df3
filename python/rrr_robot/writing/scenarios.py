"""Scenarios of the writing task, read from TOML files (users add their own).

A scenario file has a ``[scenario]`` table (name, description, feedforward), optional ``[gains]``
(kp, kd: override the robot file's [control]) and optional ``[mismatch]`` (p_rel, kt_rel, f_rel:
relative errors of the controller's model). Built-in scenarios live in data/scenarios/.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core._package import DATA_DIR
from ..core.model import Model
from ..errors import BadInputError, ModelError

SCENARIO_DIR = DATA_DIR / "scenarios"
BUILTIN = ("pd", "ctc", "mismatch")
_ALLOWED = {
    "scenario": {"name", "description", "feedforward"},
    "gains": {"kp", "kd"},
    "mismatch": {"p_rel", "kt_rel", "f_rel"},
}


@dataclass(frozen=True)
class Scenario:
    """One controller configuration of the writing task."""

    name: str
    description: str
    feedforward: bool
    kp: tuple[float, float, float] | None = None
    kd: tuple[float, float, float] | None = None
    mismatch: Mapping[str, float] = field(default_factory=dict)
    source: str = ""

    def controller_model(self, true_model: Model) -> Model:
        """The model the controller believes in: the true one, perturbed by [mismatch]."""
        if not self.mismatch:
            return true_model
        signs = np.array([(-1.0) ** k for k in range(1, 17)])
        p = true_model.p * (1.0 + self.mismatch.get("p_rel", 0.0) * signs)
        kt = true_model.kt * (1.0 + self.mismatch.get("kt_rel", 0.0))
        f = true_model.f * (1.0 + self.mismatch.get("f_rel", 0.0))
        try:
            return true_model.with_params(p=p, kt=kt, f=f)
        except ModelError as exc:
            raise BadInputError(f"scenario {self.name}: the perturbed model is invalid: {exc}") \
                from exc


def _vector(table: Mapping[str, Any], key: str, src: str) -> tuple[float, float, float]:
    arr = np.asarray(table[key], dtype=float) if key in table else np.empty(0)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise BadInputError(f"{src}: {key} must be three finite non-negative numbers")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def scenario_from_dict(data: Mapping[str, Any], src: str) -> Scenario:
    """Validate a parsed scenario file; every error names the file and the key."""
    for table, entries in data.items():
        if table not in _ALLOWED or not isinstance(entries, Mapping):
            raise BadInputError(f"{src}: unknown table [{table}] (allowed: {sorted(_ALLOWED)})")
        unknown = set(entries) - _ALLOWED[table]
        if unknown:
            raise BadInputError(f"{src}: unknown key(s) {sorted(unknown)} in [{table}]")
    head = data.get("scenario")
    if head is None or "name" not in head or "feedforward" not in head:
        raise BadInputError(f"{src}: needs a [scenario] table with name and feedforward")
    if not isinstance(head["feedforward"], bool) or not isinstance(head["name"], str):
        raise BadInputError(f"{src}: name must be a string and feedforward true or false")
    gains = data.get("gains", {})
    mismatch = {k: float(v) for k, v in data.get("mismatch", {}).items()}
    if any(not np.isfinite(v) or v <= -1.0 for v in mismatch.values()):
        raise BadInputError(f"{src}: [mismatch] values must be finite and > -1")
    return Scenario(
        name=head["name"], description=str(head.get("description", "")),
        feedforward=head["feedforward"],
        kp=_vector(gains, "kp", src) if "kp" in gains else None,
        kd=_vector(gains, "kd", src) if "kd" in gains else None,
        mismatch=mismatch, source=src,
    )


def load_scenario(name_or_path: str) -> Scenario:
    """A built-in scenario by name (pd, ctc, mismatch) or a scenario TOML file by path."""
    path = SCENARIO_DIR / f"{name_or_path}.toml"
    if name_or_path not in BUILTIN:
        path = Path(name_or_path)
        if path.suffix != ".toml" or not path.is_file():
            raise BadInputError(
                f"unknown scenario {name_or_path!r}: use one of {', '.join(BUILTIN)} "
                "or the path of a scenario .toml file"
            )
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise BadInputError(f"{path}: malformed scenario file: {exc}") from exc
    except OSError as exc:
        raise BadInputError(f"cannot read scenario file {path}: {exc}") from exc
    return scenario_from_dict(data, str(path))
