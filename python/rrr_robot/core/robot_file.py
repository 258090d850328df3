"""Robot files (TOML): read into the C model struct, write back. Format: data/default_robot.toml.

Every value is checked for presence, type and shape, and errors name the table and key.
"""

from __future__ import annotations

import ctypes as ct
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError, RrrError
from . import _lib


def _all_numbers(value: Any) -> bool:
    """True for an int or float, or nested lists of them (TOML booleans and strings are not
    numbers, although numpy would convert them)."""
    if isinstance(value, list):
        return all(_all_numbers(v) for v in value)
    return isinstance(value, int | float) and not isinstance(value, bool)


def _get(data: Mapping[str, Any], table: str, key: str, shape: tuple[int, ...], src: str) -> Any:
    section = data.get(table)
    if not isinstance(section, Mapping):
        raise ModelError(f"{src}: missing table [{table}]")
    if key not in section:
        raise ModelError(f"{src}: missing key {key!r} in [{table}]")
    if not _all_numbers(section[key]):
        raise ModelError(f"{src}: [{table}] {key} must be numbers, got {section[key]!r}")
    try:
        arr = np.asarray(section[key], dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{src}: [{table}] {key} is not numeric: {section[key]!r}") from exc
    if arr.shape != shape:
        raise ModelError(f"{src}: [{table}] {key} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{src}: [{table}] {key} contains NaN or Inf")
    return float(arr) if shape == () else arr


def _fill(target: Any, arr: np.ndarray) -> None:
    if arr.ndim == 1:
        for i, v in enumerate(arr):
            target[i] = float(v)
    else:
        for i in range(arr.shape[0]):
            _fill(target[i], arr[i])


def raw_model_from_dict(data: Mapping[str, Any], src: str) -> _lib.RawModel:
    """Build the C struct from a robot mapping; p from [base_parameters] or from the links."""
    raw = _lib.RawModel()
    for key in ("d1", "a2", "a3", "d2", "d3"):
        setattr(raw, key, _get(data, "kinematics", key, (), src))
    raw.g = _get(data, "gravity", "g", (), src)
    _fill(raw.kt, _get(data, "motors", "kt", (3,), src))
    raw.u_max = _get(data, "motors", "u_max", (), src)
    _fill(raw.f, _get(data, "friction", "f", (3, 3), src))
    _fill(raw.w, _get(data, "friction", "w", (3, 3), src))
    _fill(raw.b, _get(data, "friction", "b", (3,), src))
    if "base_parameters" in data:
        _fill(raw.p, _get(data, "base_parameters", "p", (16,), src))
    else:
        inertial = _lib.RawInertial()
        for i in range(3):
            table = f"link{i + 1}"
            link = inertial.link[i]
            link.mass = _get(data, table, "mass", (), src)
            _fill(link.com, _get(data, table, "com", (3,), src))
            diag = _get(data, table, "inertia_com", (3,), src)
            _fill(link.inertia_com, np.diag(diag))
        _fill(inertial.rotor_inertia, _get(data, "motors", "rotor_inertia", (3,), src))
        try:
            _lib.call("rrr_bps_from_inertia", ct.byref(raw), ct.byref(inertial), raw.p)
        except RrrError as exc:
            raise ModelError(f"{src}: inertial parameters rejected ({exc})") from exc
    return raw


def _fmt(value: Any) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float | int):
        return repr(float(value))
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def write_toml(data: Mapping[str, Mapping[str, Any]], path: Path, header: str = "") -> None:
    """Write a two-level mapping (tables of scalars and arrays) as TOML."""
    lines = [f"# {line}" for line in header.splitlines()]
    for table, entries in data.items():
        lines.append(f"\n[{table}]")
        lines.extend(f"{key} = {_fmt(value)}" for key, value in entries.items())
    path.write_text("\n".join(lines).lstrip("\n") + "\n")
