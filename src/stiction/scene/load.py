"""Read a scene TOML file into a validated Scene, or say exactly what is wrong.

A scene is written by hand, often by someone who is not a programmer, and a
daemon given a bad one at run time must keep the scene it had. So every
problem becomes a SceneError naming the file, the line and the field
(``demo.toml:14: regions[1].radius: must be a positive number, got -3``), and
unknown keys are errors rather than silently ignored typos.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from stiction.errors import SceneError
from stiction.protocol import PASS_THROUGH
from stiction.scene.model import (
    PRESSURE_LOAD,
    STICK_SLIP,
    STRING,
    Circle,
    Material,
    Polygon,
    PressureLoad,
    Rect,
    Region,
    Scene,
    Shape,
)
from stiction.tomlcheck import FieldPath, TomlReader
from stiction.tomlcheck import kind as _kind
from stiction.userfiles import read_regular_text

EFFECTS = (STICK_SLIP, STRING, PRESSURE_LOAD)
DEFAULT_DISPLAY = (1920, 1080)
STANDARD = Material(name="standard", mu_s=0.7, mu_k=0.1, color="#2e86de")
"""The paper's standard stimulus (mu_s 0.7 after its second experiment, mu_k 0.1)."""

_TOP_KEYS = {"scene", "materials", "regions", "pressure_load"}
_SCENE_KEYS = {"name", "display", "effects", "outside"}
_MATERIAL_KEYS = {"mu_s", "mu_k", "k", "m", "C_l", "color"}
_SHAPE_KEYS = {"rect": {"rect"}, "circle": {"center", "radius"}, "polygon": {"points"}}
_PRESSURE_KEYS = {"min_gain", "max_gain", "exponent"}

MAX_SCENE_BYTES = 1 << 20
"""A scene is a page of hand-written TOML; a file larger than 1 MiB is a mistake
(or /dev/zero), refused before it is read."""
MAX_NUMBER = 1e9
"""Largest magnitude of any number in a scene (pixels, N/m, kg, px/m): far above
any real scene, and far below what would overflow the simulator or the wire."""
MAX_FRICTION = 100.0
"""Friction coefficients above this are not a surface any more (the paper uses 0-1)."""
MAX_DISPLAY_PX = 1 << 16


class _Checker(TomlReader):
    """The shared TOML checker plus a scene's number and coordinate rules."""

    def __init__(self, source: str, text: str) -> None:
        super().__init__(source, text, SceneError)

    def number(
        self,
        value: Any,
        path: FieldPath,
        *,
        positive: bool = False,
        maximum: float = MAX_NUMBER,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"must be a number, got {_kind(value)}")
        if isinstance(value, int) and abs(value) > maximum:
            self.fail(path, f"must be at most {maximum:g} in magnitude, got {value}")
        v = float(value)
        if not math.isfinite(v):
            self.fail(path, f"must be finite, got {value}")
        if abs(v) > maximum:
            self.fail(path, f"must be at most {maximum:g} in magnitude, got {value}")
        if positive and v <= 0:
            self.fail(path, f"must be a positive number, got {value}")
        if v < 0:
            self.fail(path, f"must not be negative, got {value}")
        return v

    def point(self, value: Any, path: FieldPath) -> tuple[float, float]:
        if not isinstance(value, list) or len(value) != 2:
            self.fail(path, f"must be a pair [x, y] of numbers, got {_kind(value)}")
        return self.coord(value[0], path), self.coord(value[1], path)

    def coord(self, value: Any, path: FieldPath) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"coordinates must be numbers, got {_kind(value)}")
        if not math.isfinite(float(value)):
            self.fail(path, f"coordinates must be finite, got {value}")
        return float(value)


def parse_scene(text: str, source: str = "<scene>") -> Scene:
    """Validate scene text; `source` names it in error messages."""
    if len(text) > MAX_SCENE_BYTES:
        raise SceneError(f"{source}: {len(text)} characters; a scene is at most {MAX_SCENE_BYTES}")
    c = _Checker(source, text)
    data = c.data
    c.table(data, (), _TOP_KEYS)

    head = c.table(data.get("scene", {}), ("scene",), _SCENE_KEYS)
    name = c.string(head.get("name", Path(source).stem or "scene"), ("scene", "name"))
    display = _display(c, head.get("display", list(DEFAULT_DISPLAY)))
    effects = _effects(c, head.get("effects", [STICK_SLIP, STRING]))

    materials: dict[str, Material] = {}
    raw_materials = data.get("materials", {})
    if not isinstance(raw_materials, dict):
        c.fail(("materials",), "must be a table of [materials.NAME] tables")
    for mname, raw in raw_materials.items():
        materials[mname] = _material(c, mname, raw)

    outside_raw = head.get("outside", PASS_THROUGH)
    outside = c.string(outside_raw, ("scene", "outside"))
    if outside != PASS_THROUGH and outside not in materials:
        c.fail(("scene", "outside"), _unknown_material(outside, materials))

    raw_regions = data.get("regions", [])
    if not isinstance(raw_regions, list):
        c.fail(("regions",), "must be an array of [[regions]] tables")
    regions = tuple(_region(c, i, raw, materials) for i, raw in enumerate(raw_regions))
    names = [r.name for r in regions]
    for i, n in enumerate(names):
        if n in names[:i]:
            c.fail(("regions", i, "name"), f"duplicate region name {n!r}")

    pressure = PressureLoad()
    if "pressure_load" in data:
        if PRESSURE_LOAD not in effects:
            c.fail(("pressure_load",), "given but 'pressure_load' is not in scene.effects")
        pressure = _pressure(c, data["pressure_load"])

    return Scene(
        name=name,
        source=source,
        text=text,
        display=display,
        effects=effects,
        materials=materials,
        regions=regions,
        outside=None if outside == PASS_THROUGH else outside,
        pressure_load=pressure,
    )


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; unreadable files are SceneErrors too.

    Only a regular file of at most MAX_SCENE_BYTES is read: the path comes
    from users and from any local process (set_scene), and a FIFO or a
    device such as /dev/zero must be refused, not read until memory runs out.
    It is opened non-blocking so that opening a FIFO cannot wait for a writer.
    """
    p = Path(path)
    text = read_regular_text(p, MAX_SCENE_BYTES, SceneError, "scene")
    return parse_scene(text, str(p))


def default_scene(display: tuple[int, int] = DEFAULT_DISPLAY) -> Scene:
    """The scene used when none is given: the whole surface is the paper's
    standard stimulus, with the string, so the effect is felt at once."""
    return Scene(
        name="default",
        source="<default>",
        text="",
        display=display,
        effects=frozenset({STICK_SLIP, STRING}),
        materials={STANDARD.name: STANDARD},
        regions=(),
        outside=STANDARD.name,
    )


def example_path(name: str) -> Path:
    """A scene shipped with the package (``demo``, ``paper``, ...)."""
    return Path(__file__).with_name("examples") / f"{name}.toml"


def _display(c: _Checker, value: Any) -> tuple[int, int]:
    path: FieldPath = ("scene", "display")
    if (
        not isinstance(value, list)
        or len(value) != 2
        or not all(
            isinstance(v, int) and not isinstance(v, bool) and 0 < v <= MAX_DISPLAY_PX
            for v in value
        )
    ):
        c.fail(path, f"must be [width, height] in whole pixels 1-{MAX_DISPLAY_PX}, got {value!r}")
    return int(value[0]), int(value[1])


def _effects(c: _Checker, value: Any) -> frozenset[str]:
    path: FieldPath = ("scene", "effects")
    if not isinstance(value, list):
        c.fail(path, f"must be an array of effect names, got {_kind(value)}")
    seen: set[str] = set()
    for item in value:
        if not isinstance(item, str) or item not in EFFECTS:
            c.fail(path, f"unknown effect {item!r}; known: {', '.join(EFFECTS)}")
        if item in seen:
            c.fail(path, f"effect {item!r} listed twice")
        seen.add(item)
    for needs in (STRING, PRESSURE_LOAD):
        if needs in seen and STICK_SLIP not in seen:
            c.fail(path, f"{needs!r} needs 'stick_slip' (it acts on the friction simulation)")
    return frozenset(seen)


def _material(c: _Checker, name: str, raw: Any) -> Material:
    path: FieldPath = ("materials", name)
    if name == PASS_THROUGH:
        c.fail(path, f"{PASS_THROUGH!r} is reserved for areas without a material")
    t = c.table(raw, path, _MATERIAL_KEYS)
    for required in ("mu_s", "mu_k"):
        if required not in t:
            c.fail(path, f"missing {required!r} (every material sets mu_s and mu_k)")
    color = t.get("color")
    if color is not None:
        color = c.string(color, (*path, "color"))
    return Material(
        name=name,
        mu_s=c.number(t["mu_s"], (*path, "mu_s"), maximum=MAX_FRICTION),
        mu_k=c.number(t["mu_k"], (*path, "mu_k"), maximum=MAX_FRICTION),
        k=c.number(t["k"], (*path, "k"), positive=True) if "k" in t else None,
        m=c.number(t["m"], (*path, "m"), positive=True) if "m" in t else None,
        C_l=c.number(t["C_l"], (*path, "C_l"), positive=True) if "C_l" in t else None,
        color=color,
    )


def _unknown_material(name: str, materials: Mapping[str, Material]) -> str:
    known = ", ".join(sorted(materials)) or "none defined"
    return f"unknown material {name!r} (materials: {known}; or {PASS_THROUGH!r})"


def _region(c: _Checker, index: int, raw: Any, materials: Mapping[str, Material]) -> Region:
    path: FieldPath = ("regions", index)
    if not isinstance(raw, dict):
        c.fail(path, "must be a table")
    shape_name = raw.get("shape")
    if not isinstance(shape_name, str) or shape_name not in _SHAPE_KEYS:
        c.fail((*path, "shape"), f"must be one of rect, circle, polygon, got {shape_name!r}")
    t = c.table(raw, path, {"name", "material", "shape"} | _SHAPE_KEYS[shape_name])
    name = c.string(t.get("name", f"region{index}"), (*path, "name"))
    if "material" not in t:
        c.fail(path, "missing 'material'")
    material = c.string(t["material"], (*path, "material"))
    if material != PASS_THROUGH and material not in materials:
        c.fail((*path, "material"), _unknown_material(material, materials))
    for key in _SHAPE_KEYS[shape_name]:
        if key not in t:
            c.fail(path, f"a {shape_name} needs {key!r}")
    shape: Shape
    if shape_name == "rect":
        r = t["rect"]
        if not isinstance(r, list) or len(r) != 4:
            c.fail((*path, "rect"), f"must be [x, y, width, height], got {_kind(r)}")
        x, y = c.coord(r[0], (*path, "rect")), c.coord(r[1], (*path, "rect"))
        w = c.number(r[2], (*path, "rect"), positive=True)
        h = c.number(r[3], (*path, "rect"), positive=True)
        shape = Rect(x, y, w, h)
    elif shape_name == "circle":
        cx, cy = c.point(t["center"], (*path, "center"))
        shape = Circle(cx, cy, c.number(t["radius"], (*path, "radius"), positive=True))
    else:
        pts = t["points"]
        if not isinstance(pts, list) or len(pts) < 3:
            c.fail((*path, "points"), f"must be an array of at least 3 [x, y], got {_kind(pts)}")
        points = tuple(c.point(p, (*path, "points")) for p in pts)
        if _area2(points) == 0.0:
            c.fail((*path, "points"), "polygon has zero area")
        shape = Polygon(points)
    return Region(name=name, material=None if material == PASS_THROUGH else material, shape=shape)


def _area2(points: tuple[tuple[float, float], ...]) -> float:
    s = 0.0
    for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1], strict=True):
        s += x0 * y1 - x1 * y0
    return abs(s)


def _pressure(c: _Checker, raw: Any) -> PressureLoad:
    path: FieldPath = ("pressure_load",)
    t = c.table(raw, path, _PRESSURE_KEYS)
    d = PressureLoad()
    lo = c.number(t.get("min_gain", d.min_gain), (*path, "min_gain"))
    hi = c.number(t.get("max_gain", d.max_gain), (*path, "max_gain"), positive=True)
    exponent = c.number(t.get("exponent", d.exponent), (*path, "exponent"), positive=True)
    if lo > hi:
        c.fail((*path, "min_gain"), f"must not exceed max_gain ({lo} > {hi})")
    return PressureLoad(min_gain=lo, max_gain=hi, exponent=exponent)
