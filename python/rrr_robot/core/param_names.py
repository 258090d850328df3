"""The model's parameters under the FMUs' variable names (the same for plant and controller)."""

from __future__ import annotations

from .model import Model


def model_fmu_values(model: Model) -> dict[str, float]:
    """The model's parameters under the FMUs' variable names (same for plant and controller)."""
    values: dict[str, float] = {k: v for k, v in model.dh.items()}
    values["g"] = model.g
    values["u_max"] = model.u_max
    values |= {f"p[{k + 1}]": float(v) for k, v in enumerate(model.p)}
    values |= {f"kt[{i + 1}]": float(v) for i, v in enumerate(model.kt)}
    values |= {f"b[{i + 1}]": float(v) for i, v in enumerate(model.b)}
    for name, arr in (("f", model.f), ("w", model.w)):
        values |= {f"{name}[{i + 1},{k + 1}]": float(arr[i, k])
                   for i in range(3) for k in range(3)}
    return values
