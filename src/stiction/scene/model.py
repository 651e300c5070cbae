"""What a validated scene is: materials, regions in display pixels, effects.

These objects are immutable and already checked, so everything downstream
(the compiled pipeline, the wire form, the renderer) can trust them without
re-validating. Geometry tests work in display pixels because that is the
space the scene's author drew in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from stiction.protocol import PASS_THROUGH, MaterialWire, RegionWire, SceneWire

STICK_SLIP = "stick_slip"
STRING = "string"
PRESSURE_LOAD = "pressure_load"


@dataclass(frozen=True, slots=True)
class Material:
    """Friction coefficients plus optional overrides of the daemon's defaults."""

    name: str
    mu_s: float
    mu_k: float
    k: float | None = None
    m: float | None = None
    C_l: float | None = None
    color: str | None = None

    def overrides(self) -> dict[str, float]:
        """The sim parameters this material sets (the rest come from the defaults)."""
        out = {"mu_s": self.mu_s, "mu_k": self.mu_k}
        for key in ("k", "m", "C_l"):
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        return out


@dataclass(frozen=True, slots=True)
class Rect:
    x: float
    y: float
    w: float
    h: float

    def contains(self, px: float, py: float) -> bool:
        return self.x <= px <= self.x + self.w and self.y <= py <= self.y + self.h

    def wire(self) -> dict[str, object]:
        return {"shape": "rect", "rect": [self.x, self.y, self.w, self.h]}


@dataclass(frozen=True, slots=True)
class Circle:
    cx: float
    cy: float
    r: float

    def contains(self, px: float, py: float) -> bool:
        return (px - self.cx) ** 2 + (py - self.cy) ** 2 <= self.r * self.r

    def wire(self) -> dict[str, object]:
        return {"shape": "circle", "center": [self.cx, self.cy], "radius": self.r}


@dataclass(frozen=True, slots=True)
class Polygon:
    """A simple or self-intersecting polygon; inside is decided by the even-odd rule."""

    points: tuple[tuple[float, float], ...]
    bbox: tuple[float, float, float, float] = field(init=False)

    def __post_init__(self) -> None:
        xs = [p[0] for p in self.points]
        ys = [p[1] for p in self.points]
        object.__setattr__(self, "bbox", (min(xs), min(ys), max(xs), max(ys)))

    def contains(self, px: float, py: float) -> bool:
        x0, y0, x1, y1 = self.bbox
        if px < x0 or px > x1 or py < y0 or py > y1:
            return False
        inside = False
        pts = self.points
        j = len(pts) - 1
        for i in range(len(pts)):
            xi, yi = pts[i]
            xj, yj = pts[j]
            if (yi > py) != (yj > py) and px < (xj - xi) * (py - yi) / (yj - yi) + xi:
                inside = not inside
            j = i
        return inside

    def wire(self) -> dict[str, object]:
        return {"shape": "polygon", "points": [[x, y] for x, y in self.points]}


Shape = Rect | Circle | Polygon


@dataclass(frozen=True, slots=True)
class Region:
    """`material` None makes the region pass-through (a hole in what lies below)."""

    name: str
    material: str | None
    shape: Shape


@dataclass(frozen=True, slots=True)
class PressureLoad:
    """load_gain = min_gain + (max_gain - min_gain) * pressure ** exponent."""

    min_gain: float = 0.5
    max_gain: float = 1.5
    exponent: float = 1.0

    def gain(self, pressure: float | None) -> float:
        if pressure is None or not math.isfinite(pressure):
            return 1.0
        p = min(max(pressure, 0.0), 1.0)
        return float(self.min_gain + (self.max_gain - self.min_gain) * p**self.exponent)


@dataclass(frozen=True, slots=True)
class Scene:
    """A validated scene. `outside` is a material name or None for pass-through."""

    name: str
    source: str
    text: str
    display: tuple[int, int]
    effects: frozenset[str]
    materials: dict[str, Material]
    regions: tuple[Region, ...]
    outside: str | None
    pressure_load: PressureLoad = PressureLoad()

    def material_at(self, px: float, py: float) -> str | None:
        """The material under a display point: the topmost (last listed) region wins."""
        for region in reversed(self.regions):
            if region.shape.contains(px, py):
                return region.material
        return self.outside

    def wire(self, resolved: dict[str, dict[str, float]]) -> SceneWire:
        """The scene as published; `resolved` holds each material's full parameters."""
        materials: dict[str, MaterialWire] = {}
        for name, mat in self.materials.items():
            params = resolved[name]
            entry: MaterialWire = {
                "mu_s": params["mu_s"],
                "mu_k": params["mu_k"],
                "k": params["k"],
                "m": params["m"],
                "g": params["g"],
                "C_l": params["C_l"],
            }
            if mat.color is not None:
                entry["color"] = mat.color
            materials[name] = entry
        regions: list[RegionWire] = []
        for r in self.regions:
            material = r.material if r.material is not None else PASS_THROUGH
            regions.append({"name": r.name, "material": material, **r.shape.wire()})  # type: ignore[typeddict-item]
        return {
            "name": self.name,
            "source": self.source,
            "display": [self.display[0], self.display[1]],
            "effects": sorted(self.effects),
            "outside": self.outside if self.outside is not None else PASS_THROUGH,
            "materials": materials,
            "regions": regions,
        }
