"""Run-time parameter changes (control op set_params) as a new scene.

A parameter change is applied by building a new scene and compiling it like
any other, so the checks are the same and a refused change leaves nothing
half-applied.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from stiction.errors import ParamError
from stiction.scene.load import MAX_FRICTION, MAX_NUMBER
from stiction.scene.model import Scene
from stiction.userfiles import shown

MATERIAL_PARAMS = ("mu_s", "mu_k", "k", "m", "C_l")
GLOBAL_PARAMS = (*MATERIAL_PARAMS, "g")


def apply_params(
    scene: Scene, defaults: Mapping[str, float], values: Mapping[str, Any], material: str | None
) -> tuple[Scene, dict[str, float]]:
    """The scene and defaults with `values` applied to one material or to all."""
    if not values:
        raise ParamError(f"set_params needs at least one of {', '.join(GLOBAL_PARAMS)}")
    allowed = MATERIAL_PARAMS if material is not None else GLOBAL_PARAMS
    clean: dict[str, float] = {}
    for key, value in values.items():
        if key == "rate":
            raise ParamError("rate cannot change while running; set daemon.rate in the config")
        if key not in allowed:
            raise ParamError(f"unknown parameter {shown(repr(key))}; known: {', '.join(allowed)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParamError(f"parameter {key} must be a number, got {shown(repr(value))}")
        # The same bounds a scene file has: a huge integer must not overflow float().
        limit = MAX_FRICTION if key in ("mu_s", "mu_k") else MAX_NUMBER
        if isinstance(value, int) and abs(value) > limit:
            raise ParamError(f"parameter {key} must be at most {limit:g}, got {value}")
        if not math.isfinite(value) or abs(value) > limit:
            raise ParamError(f"parameter {key} must be finite and at most {limit:g}, got {value!r}")
        clean[key] = float(value)
    new_defaults = dict(defaults)
    materials = dict(scene.materials)
    if material is None:
        new_defaults.update(clean)
        targets = list(materials)
    else:
        if material not in materials:
            known = ", ".join(sorted(materials)) or "none"
            raise ParamError(f"unknown material {shown(repr(material))}; the scene has: {known}")
        targets = [material]
    per_material = {k: v for k, v in clean.items() if k in MATERIAL_PARAMS}
    for name in targets:
        changes: dict[str, Any] = per_material
        materials[name] = dataclasses.replace(materials[name], **changes)
    return dataclasses.replace(scene, materials=materials), new_defaults
