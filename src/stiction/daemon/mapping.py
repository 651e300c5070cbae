"""Surface metres -> display pixels, per device.

The simulator works in surface metres (SI, docs/design/model.md); regions and renderers
work in display pixels. Tablets and touchscreens use *area* mapping: a
rectangle of the surface onto a rectangle of the screen, optionally rotated
(a tablet turned for left-handed use) and with its aspect ratio kept
(letterboxed, so a circle drawn stays a circle) or stretched. Touchpads can
use *relative* mapping instead: a contact moves a cursor by its displacement,
so putting a finger down does not make the pointer jump. docs/mapping.md
explains the choices.
"""

from __future__ import annotations

from dataclasses import dataclass

from stiction.errors import StictionError

Rect = tuple[float, float, float, float]
ROTATIONS = (0, 90, 180, 270)
ASPECTS = ("keep", "stretch")
MODES = ("area", "relative")


class MappingError(StictionError):
    """A mapping setting that cannot be used (names the setting)."""


@dataclass(frozen=True, slots=True)
class MappingConfig:
    """How one device is mapped; every field has a sensible default.

    `surface_area` is in metres from the surface's top-left corner (the config's
    `surface_area_mm`, converted) (default:
    the whole surface), `screen_area` in display pixels (default: the whole
    display). `rotate` is how far the device is turned clockwise, as the user
    sees it. `gain` scales relative motion (1.0: the surface's width spans
    the screen area's width).
    """

    mode: str = "area"
    aspect: str = "keep"
    rotate: int = 0
    surface_area: Rect | None = None
    screen_area: Rect | None = None
    gain: float = 1.0

    def check(self) -> None:
        if self.mode not in MODES:
            raise MappingError(f"mapping must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.aspect not in ASPECTS:
            raise MappingError(f"aspect must be one of {', '.join(ASPECTS)}, got {self.aspect!r}")
        if self.rotate not in ROTATIONS:
            raise MappingError(f"rotate must be 0, 90, 180 or 270, got {self.rotate!r}")
        for name, area in (("surface_area", self.surface_area), ("screen_area", self.screen_area)):
            if area is not None and (area[2] <= 0 or area[3] <= 0):
                raise MappingError(f"{name} needs a positive width and height, got {list(area)}")
        if not self.gain > 0:
            raise MappingError(f"gain must be positive, got {self.gain}")


def _rotation(rotate: int) -> tuple[float, float, float, float, float, float]:
    """Unit-square map (u, v) -> (a*u + b*v + c, d*u + e*v + f) for a device turned clockwise."""
    return {
        0: (1.0, 0.0, 0.0, 0.0, 1.0, 0.0),
        90: (0.0, -1.0, 1.0, 1.0, 0.0, 0.0),
        180: (-1.0, 0.0, 1.0, 0.0, -1.0, 1.0),
        270: (0.0, 1.0, 0.0, -1.0, 0.0, 1.0),
    }[rotate]


class AreaMapping:
    """An affine map fixed at construction: a copy and four multiply-adds per point."""

    def __init__(
        self, surface_size: tuple[float, float], display: tuple[int, int], cfg: MappingConfig
    ) -> None:
        cfg.check()
        sx, sy, sw, sh = cfg.surface_area or (0.0, 0.0, surface_size[0], surface_size[1])
        qx, qy, qw, qh = cfg.screen_area or (0.0, 0.0, float(display[0]), float(display[1]))
        a, b, c, d, e, f = _rotation(cfg.rotate)
        # The rotated surface area's size as the user sees it.
        rw, rh = (sh, sw) if cfg.rotate in (90, 270) else (sw, sh)
        if cfg.aspect == "keep":
            scale = min(qw / rw, qh / rh)
            ow, oh = rw * scale, rh * scale
            ox, oy = qx + (qw - ow) / 2, qy + (qh - oh) / 2
        else:
            ow, oh, ox, oy = qw, qh, qx, qy
        # px = ox + ow * (a*u + b*v + c) with u = (x - sx)/sw, v = (y - sy)/sh.
        self._ax, self._bx = ow * a / sw, ow * b / sh
        self._cx = ox + ow * c - self._ax * sx - self._bx * sy
        self._ay, self._by = oh * d / sw, oh * e / sh
        self._cy = oy + oh * f - self._ay * sx - self._by * sy
        self.px_per_m = (ow / rw, oh / rh)

    def begin(self, contact: int, x: float, y: float) -> None:
        pass

    def end(self, contact: int) -> None:
        pass

    def to_px(self, contact: int, x: float, y: float) -> tuple[float, float]:
        return (
            self._ax * x + self._bx * y + self._cx,
            self._ay * x + self._by * y + self._cy,
        )

    def affine(self) -> tuple[float, float, float, float, float, float]:
        """(ax, bx, cx, ay, by, cy): to_px is (ax x + bx y + cx, ay x + by y + cy).

        For the scene pipeline's compiled batch step, which applies it itself."""
        return (self._ax, self._bx, self._cx, self._ay, self._by, self._cy)


class RelativeMapping:
    """Touchpad-style: each contact moves the cursor by its displacement.

    Every contact starts at the cursor; when a contact ends, the cursor stays
    where that contact's pointer was last drawn (clamped to the screen area).
    """

    def __init__(
        self, surface_size: tuple[float, float], display: tuple[int, int], cfg: MappingConfig
    ) -> None:
        cfg.check()
        self._area = cfg.screen_area or (0.0, 0.0, float(display[0]), float(display[1]))
        qx, qy, qw, qh = self._area
        sw = cfg.surface_area[2] if cfg.surface_area else surface_size[0]
        self._scale = cfg.gain * qw / sw
        a, b, _, d, e, _ = _rotation(cfg.rotate)
        self._m = (a * self._scale, b * self._scale, d * self._scale, e * self._scale)
        self.cursor = (qx + qw / 2, qy + qh / 2)
        self._anchors: dict[int, tuple[float, float, float, float]] = {}
        self._last: dict[int, tuple[float, float]] = {}

    def begin(self, contact: int, x: float, y: float) -> None:
        self._anchors[contact] = (x, y, self.cursor[0], self.cursor[1])

    def end(self, contact: int) -> None:
        self._anchors.pop(contact, None)
        last = self._last.pop(contact, None)
        if last is not None:
            qx, qy, qw, qh = self._area
            self.cursor = (min(max(last[0], qx), qx + qw), min(max(last[1], qy), qy + qh))

    def to_px(self, contact: int, x: float, y: float) -> tuple[float, float]:
        anchor = self._anchors.get(contact)
        if anchor is None:
            self.begin(contact, x, y)
            anchor = self._anchors[contact]
        ax, ay, cx, cy = anchor
        m = self._m
        dx, dy = x - ax, y - ay
        p = (cx + m[0] * dx + m[1] * dy, cy + m[2] * dx + m[3] * dy)
        self._last[contact] = p
        return p


def make_mapping(
    surface_size: tuple[float, float] | None,
    display: tuple[int, int],
    cfg: MappingConfig,
    device: str,
) -> AreaMapping | RelativeMapping:
    """Build a device's mapping; a device without a known size must be given one."""
    if surface_size is None:
        if cfg.surface_area is None:
            raise MappingError(
                f"{device}: the device reports no physical size; set size_mm = [width, height] "
                "(millimetres) in its [[devices]] entry of the stictiond config"
            )
        surface_size = (
            cfg.surface_area[0] + cfg.surface_area[2],
            cfg.surface_area[1] + cfg.surface_area[3],
        )
    if not (surface_size[0] > 0 and surface_size[1] > 0):
        raise MappingError(f"{device}: surface size must be positive, got {list(surface_size)}")
    if cfg.mode == "relative":
        return RelativeMapping(surface_size, display, cfg)
    return AreaMapping(surface_size, display, cfg)
